"""Modbus RTU framing: CRC-16/MODBUS, the requests ornitail sends, and the length of a reply from its first bytes.

References (public, modbus.org): *MODBUS over Serial Line Specification and Implementation Guide V1.02* (2006),
section 2.5.1 (RTU frame: address, function, data, CRC low byte first) and section 6.2.2 with appendix B (CRC
generation: initial value 0xFFFF, each byte XORed into the low byte, eight shifts right with XOR 0xA001 when the
bit shifted out is 1); *MODBUS Application Protocol Specification V1.1b3* (2012), sections 6.3 (0x03 Read Holding
Registers), 6.6 (0x06 Write Single Register) and 7 (exception responses: function code + 0x80 and one exception
code). Only these two functions are used. Registers are 16 bits, big-endian on the wire; addresses are the
zero-based protocol addresses (what a drive's manual lists as "2001H" is sent as 0x2001).
"""

from __future__ import annotations

READ_HOLDING_REGISTERS = 0x03
WRITE_SINGLE_REGISTER = 0x06
EXCEPTION_FLAG = 0x80
MAX_READ_REGISTERS = 125
"""Most registers one 0x03 request may read (Application Protocol Specification, 6.3)."""
MIN_UNIT_ID, MAX_UNIT_ID = 1, 247
"""Server addresses of a serial line (0 is broadcast, which gets no reply)."""

EXCEPTION_NAMES = {
    0x01: "illegal function",
    0x02: "illegal data address",
    0x03: "illegal data value",
    0x04: "server device failure",
    0x05: "acknowledge",
    0x06: "server device busy",
    0x08: "memory parity error",
}
"""Exception codes of the Application Protocol Specification, section 7."""

CRC16_MODBUS_CHECK_VALUE = 0x4B37
"""CRC-16/MODBUS of the nine ASCII bytes ``b"123456789"``."""


def silent_interval_s(baud: int) -> float:
    """t3.5, the silence that separates two RTU frames, s (serial-line guide, section 2.5.1.1).

    3.5 character times of 11 bits at ``baud``; above 19200 bit/s the guide fixes it at 1.750 ms.
    """
    return 0.00175 if baud > 19200 else 3.5 * 11 / baud


def _crc_table() -> list[int]:
    table = []
    for byte in range(256):
        register = byte
        for _ in range(8):
            register = (register >> 1) ^ 0xA001 if register & 1 else register >> 1
        table.append(register)
    return table


_CRC_TABLE = _crc_table()


def crc16_modbus(data: bytes) -> int:
    """CRC-16/MODBUS of ``data`` (reflected polynomial 0xA001, initial 0xFFFF, no final XOR)."""
    register = 0xFFFF
    for byte in data:
        register = (register >> 8) ^ _CRC_TABLE[(register ^ byte) & 0xFF]
    return register


def with_crc(frame: bytes) -> bytes:
    """``frame`` followed by its CRC, low byte first."""
    return frame + crc16_modbus(frame).to_bytes(2, "little")


def crc_ok(frame: bytes) -> bool:
    """True when the last two bytes of ``frame`` are the CRC of the others (low byte first)."""
    return len(frame) >= 4 and crc16_modbus(frame[:-2]).to_bytes(2, "little") == frame[-2:]


def _register(value: int, what: str) -> bytes:
    if not 0 <= value <= 0xFFFF:
        raise ValueError(f"{what} {value} is not a 16-bit register value")
    return value.to_bytes(2, "big")


def read_holding_registers_request(unit_id: int, address: int, count: int) -> bytes:
    """``unit 03 address count CRC``: read ``count`` registers from ``address``."""
    if not 1 <= count <= MAX_READ_REGISTERS:
        raise ValueError(f"register count {count} is outside 1..{MAX_READ_REGISTERS}")
    pdu = (
        bytes([READ_HOLDING_REGISTERS]) + _register(address, "address") + _register(count, "count")
    )
    return with_crc(bytes([unit_id]) + pdu)


def write_single_register_request(unit_id: int, address: int, value: int) -> bytes:
    """``unit 06 address value CRC``: write ``value`` to register ``address`` (the reply echoes it)."""
    pdu = bytes([WRITE_SINGLE_REGISTER]) + _register(address, "address") + _register(value, "value")
    return with_crc(bytes([unit_id]) + pdu)


def exception_reply(unit_id: int, function: int, code: int) -> bytes:
    """``unit function|0x80 code CRC``."""
    return with_crc(bytes([unit_id, function | EXCEPTION_FLAG, code]))


def read_registers_reply(unit_id: int, values: list[int]) -> bytes:
    """``unit 03 byte-count values CRC``."""
    data = b"".join(_register(value, "value") for value in values)
    return with_crc(bytes([unit_id, READ_HOLDING_REGISTERS, len(data)]) + data)


def reply_length(head: bytes) -> int | None:
    """Total length of a reply from its first bytes (None: more bytes needed to tell).

    Exception replies are 5 bytes, a 0x06 echo 8, a 0x03 reply 5 + its byte count; any other function code is
    taken as 5 bytes so that a reply the driver does not expect is reported, not waited for.
    """
    if len(head) < 2:
        return None
    function = head[1]
    if function & EXCEPTION_FLAG:
        return 5
    if function == WRITE_SINGLE_REGISTER:
        return 8
    if function == READ_HOLDING_REGISTERS:
        return None if len(head) < 3 else 5 + head[2]
    return 5


def request_length(head: bytes) -> int | None:
    """Length of a 0x03 or 0x06 request from its first bytes (8), None if unknown or too short to tell."""
    if len(head) < 2 or head[1] not in (READ_HOLDING_REGISTERS, WRITE_SINGLE_REGISTER):
        return None
    return 8


def exception_text(code: int) -> str:
    """``"exception 03 (illegal data value)"``."""
    return f"Modbus exception {code:02X} ({EXCEPTION_NAMES.get(code, 'unknown code')})"
