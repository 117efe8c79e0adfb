"""Wire protocol of ATI's NETCANOEM force/torque board on classic CAN (no I/O here).

Identifiers are 11 bits: ``(base << 4) | opcode`` with a 7-bit base (default 0x20) and a 4-bit
opcode. Multi-byte numbers are big-endian. Requests and the replies they trigger are listed in
``docs/instrument-protocols.md``; the layouts below follow ATI document 9610-05-1030 as summarised
in the project's lessons (two-frame gauge reply: first frame opcode 0x0 with the status word and
gauges 0, 2, 4; second frame opcode 0x1 with gauges 1, 3, 5; matrix rows in three frames, opcodes
0x2-0x4). Check a real board against ATI's manual before relying on a layout detail that is not
tested here.
"""

from __future__ import annotations

import math
import struct

import numpy as np

from ornitail.vehicle.constants import STANDARD_GRAVITY_M_S2

DEFAULT_BASE_ID = 0x20
OPCODE_READ_GAUGES = 0x0
OPCODE_GAUGES_SECOND_REPLY = 0x1
OPCODE_READ_MATRIX_ROW = 0x2
MATRIX_ROW_REPLY_OPCODES = (0x2, 0x3, 0x4)
OPCODE_SERIAL_NUMBER = 0x5
OPCODE_SET_ACTIVE_CALIBRATION = 0x6
OPCODE_COUNTS_PER_UNIT = 0x7
OPCODE_UNIT_CODES = 0x8
OPCODE_RESET = 0xC
OPCODE_SET_BASE_ID = 0xD
OPCODE_SET_BIT_RATE = 0xE
OPCODE_FIRMWARE_VERSION = 0xF

GAUGE_SATURATION_LOW = -32768
GAUGE_SATURATION_HIGH = 32767
BIT_RATE_DIVIDEND = 2_000_000  # bit rate = 2 Mbit/s / (divisor + 1)

# ATI unit codes -> factor to SI (N, N m)
FORCE_UNIT_CODES_TO_N = {
    1: 4.4482216152605,
    2: 1.0,
    3: 4448.2216152605,
    4: 1000.0,
    5: STANDARD_GRAVITY_M_S2,
    6: 0.00980665,
}
TORQUE_UNIT_CODES_TO_N_M = {
    1: 0.112984829027617,
    2: 1.3558179483314,
    3: 1.0,
    4: 0.001,
    5: 0.0980665,
    6: 1000.0,
}
FORCE_UNIT_NAMES = {1: "lbf", 2: "N", 3: "klbf", 4: "kN", 5: "kgf", 6: "gf"}
TORQUE_UNIT_NAMES = {1: "lbf-in", 2: "lbf-ft", 3: "N-m", 4: "N-mm", 5: "kgf-cm", 6: "kN-m"}


def arbitration_id(base_id: int, opcode: int) -> int:
    """11-bit CAN identifier for ``opcode`` on a board at ``base_id`` (0..127)."""
    if not 0 <= base_id <= 0x7F or not 0 <= opcode <= 0xF:
        raise ValueError(f"base id {base_id:#x} must be 0..0x7f and opcode {opcode:#x} 0..0xf")
    return (base_id << 4) | opcode


def split_arbitration_id(identifier: int) -> tuple[int, int]:
    """Return ``(base_id, opcode)`` of an 11-bit identifier."""
    return (identifier >> 4) & 0x7F, identifier & 0xF


def encode_gauge_replies(status_word: int, gauges: np.ndarray) -> tuple[bytes, bytes]:
    """Encode the two replies to a gauge read: 8 bytes (status, g0, g2, g4) and 6 (g1, g3, g5)."""
    g = np.asarray(gauges, dtype=np.int64).tolist()
    return (
        struct.pack(">Hhhh", status_word & 0xFFFF, g[0], g[2], g[4]),
        struct.pack(">hhh", g[1], g[3], g[5]),
    )


def decode_gauge_replies(first: bytes, second: bytes) -> tuple[int, np.ndarray]:
    """Decode the two gauge replies into ``(status_word, gauges)``; gauges (6,) int16, 0..5."""
    if len(first) != 8 or len(second) != 6:
        raise ValueError(f"gauge replies must be 8 and 6 bytes, got {len(first)} and {len(second)}")
    status_word, g0, g2, g4 = struct.unpack(">Hhhh", first)
    g1, g3, g5 = struct.unpack(">hhh", second)
    return status_word, np.array([g0, g1, g2, g3, g4, g5], dtype=np.int16)


def decode_gauge_reply_batch(
    first_replies: bytes, second_replies: bytes
) -> tuple[np.ndarray, np.ndarray]:
    """Decode n gauge samples at once: ``first_replies`` is n 8-byte first replies joined, ``second_replies``
    the n 6-byte second replies joined. Returns status words (n,) uint16 and gauges (n, 6) int16, each row as
    :func:`decode_gauge_replies` decodes it."""
    if len(first_replies) % 8 or len(second_replies) != len(first_replies) // 8 * 6:
        raise ValueError(
            f"{len(first_replies)} and {len(second_replies)} bytes are not n 8-byte and n 6-byte replies"
        )
    first = np.frombuffer(first_replies, dtype=">i2").reshape(-1, 4)
    second = np.frombuffer(second_replies, dtype=">i2").reshape(-1, 3)
    gauges = np.empty((len(first), 6), dtype=np.int16)
    gauges[:, 0::2] = first[:, 1:]
    gauges[:, 1::2] = second
    return first[:, 0].astype(np.uint16), gauges


def saturated_gauges(gauges: np.ndarray) -> np.ndarray:
    """True where a gauge reads -32768 or +32767 (the ADC is at the end of its range)."""
    gauges = np.asarray(gauges)
    return (gauges == GAUGE_SATURATION_LOW) | (gauges == GAUGE_SATURATION_HIGH)


def encode_matrix_row_replies(coefficients: np.ndarray) -> tuple[bytes, bytes, bytes]:
    """Six float32 coefficients of one matrix row, two per 8-byte reply (opcodes 0x2, 0x3, 0x4)."""
    values = [float(v) for v in np.asarray(coefficients, dtype=np.float32)]
    if len(values) != 6:
        raise ValueError(f"a matrix row has 6 coefficients, got {len(values)}")
    return tuple(struct.pack(">ff", values[2 * i], values[2 * i + 1]) for i in range(3))


def decode_matrix_row(replies: tuple[bytes, bytes, bytes]) -> np.ndarray:
    """Decode the three matrix-row replies (in opcode order 0x2, 0x3, 0x4) into (6,) float64."""
    values: list[float] = []
    for payload in replies:
        values.extend(struct.unpack(">ff", payload))
    return np.array(values, dtype=np.float64)


def encode_counts_per_unit(counts_per_force: int, counts_per_torque: int) -> bytes:
    """Reply to opcode 0x7: int32 counts per force unit, int32 counts per torque unit."""
    return struct.pack(">ii", counts_per_force, counts_per_torque)


def decode_counts_per_unit(payload: bytes) -> tuple[int, int]:
    """Decode the opcode 0x7 reply into ``(counts_per_force, counts_per_torque)``."""
    return struct.unpack(">ii", payload)


def encode_firmware_version(major: int, minor: int, build: int) -> bytes:
    """Reply to opcode 0xF: major (u8), minor (u8), build (u16)."""
    return struct.pack(">BBH", major, minor, build)


def decode_firmware_version(payload: bytes) -> str:
    """Decode the opcode 0xF reply into ``"major.minor.build"``."""
    major, minor, build = struct.unpack(">BBH", payload)
    return f"{major}.{minor}.{build}"


def encode_serial_number(serial_number: str) -> bytes:
    """Reply to opcode 0x5: the serial number as 8 ASCII bytes, NUL padded."""
    data = serial_number.encode("ascii")
    if len(data) > 8:
        raise ValueError(f"serial number {serial_number!r} is longer than 8 characters")
    return data.ljust(8, b"\0")


def decode_serial_number(payload: bytes) -> str:
    """Decode the opcode 0x5 reply."""
    return payload.rstrip(b"\0").decode("ascii", errors="replace")


def bit_rate_for_divisor(divisor: int) -> float:
    """Bus bit rate set by opcode 0xE with ``divisor``: 2 Mbit/s / (divisor + 1), bit/s."""
    return BIT_RATE_DIVIDEND / (divisor + 1)


def divisor_for_bit_rate(bit_rate: float) -> int:
    """Divisor for opcode 0xE; ValueError if 2 Mbit/s / bit_rate - 1 is not a whole number."""
    divisor = BIT_RATE_DIVIDEND / bit_rate - 1
    if divisor < 0 or abs(divisor - round(divisor)) > 1e-9 or round(divisor) > 255:
        raise ValueError(f"{bit_rate:g} bit/s is not 2 Mbit/s divided by a whole number 1..256")
    return int(round(divisor))


def classic_can_frame_bits(data_length: int, *, worst_case_stuffing: bool = True) -> int:
    """Bits a classic 11-bit-id CAN data frame occupies on the bus, interframe space included.

    44 bits of framing + 8 per data byte + 3 interframe bits, plus (worst case) one stuff bit per
    four of the 34 + 8*DLC stuffable bits: floor((34 + 8*DLC - 1) / 4).
    """
    bits = 44 + 8 * data_length + 3
    if worst_case_stuffing:
        bits += (34 + 8 * data_length - 1) // 4
    return bits


def gauge_sample_bits(*, worst_case_stuffing: bool = True) -> int:
    """Bits per polled gauge sample: request (DLC 0) + replies of DLC 8 and 6."""
    return sum(
        classic_can_frame_bits(dlc, worst_case_stuffing=worst_case_stuffing) for dlc in (0, 8, 6)
    )


def gauge_sample_rate_ceiling_hz(bit_rate: float, *, worst_case_stuffing: bool = True) -> float:
    """Most polled gauge samples per second the bus can carry at ``bit_rate`` bit/s."""
    if not math.isfinite(bit_rate) or bit_rate <= 0:
        raise ValueError(f"bit rate {bit_rate!r} must be a positive number")
    return bit_rate / gauge_sample_bits(worst_case_stuffing=worst_case_stuffing)
