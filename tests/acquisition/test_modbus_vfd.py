"""The ``modbus_vfd`` fan backend: exact Modbus RTU frames, errors as one line, and a simulated drive on a pty.

Byte references:
- MODBUS over Serial Line Specification and Implementation Guide V1.02 (modbus.org, 2006), section 2.5.1.2 and
  appendix B: RTU frame = address, PDU, CRC-16 low byte first; the CRC algorithm (init 0xFFFF, shift right, XOR
  0xA001) is re-implemented bit by bit below, independently of the driver's table.
- MODBUS Application Protocol Specification V1.1b3, section 6.6: "write register 2 to 00 03 hex" is the PDU
  06 00 01 00 03; at unit 1 its RTU frame is 01 06 00 01 00 03 98 0B.
- Delta VFD-VE user manual (rev. August 2008, section 4 parameter group 9, RTU example of function 03H): reading
  two registers from 2102H at address 01H is 01 03 21 02 00 02 6F F7, and the drive's answer 01 03 04 17 70 00 00
  FE 5C (frequency command 60.00 Hz, output frequency 0.00 Hz).
- The run/stop/frequency words follow the Delta address list (2000H bits 1-0: 01B stop, 10B run; 2001H frequency
  command in 0.01 Hz); their CRCs are computed here by the appendix-B algorithm (01 06 20 00 00 01 43 CA also
  appears as the stop frame in the VTS2000 inverter manual, a drive with the same address list).
"""

from __future__ import annotations

import pytest
import serial

from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentReplyError
from ornitail.acquisition.modbus_rtu import (
    CRC16_MODBUS_CHECK_VALUE,
    crc16_modbus,
    read_holding_registers_request,
    silent_interval_s,
    with_crc,
    write_single_register_request,
)
from ornitail.acquisition.modbus_rtu_connection import ModbusRtuConnection
from ornitail.acquisition.modbus_vfd_driver import ModbusVfdSettings, ModbusVfdTunnelFan
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.calibration.tunnel_table import TunnelVelocityTable
from ornitail.core.errors import UserInputError
from ornitail.simulated_instruments.modbus_vfd import SimulatedModbusVfd

TABLE = TunnelVelocityTable.from_csv(DEFAULT_RIG_FILE.parent / "tunnel_table.csv")
DELTA_MAP = ModbusVfdSettings(fan_rpm_per_hz=30.0)  # the default (Delta) register map
SPEED_MAP = FanSpeedMap(TABLE, 30.0)
MAX_FAN_RPM = 1800.0  # the table's top: 60 Hz at 30 rpm/Hz

# Frames, hex as in the references above.
SPEC_WRITE_REGISTER_2 = bytes.fromhex("01 06 00 01 00 03 98 0B")
DELTA_READ_2102_2103 = bytes.fromhex("01 03 21 02 00 02 6F F7")
DELTA_REPLY_60HZ_0HZ = bytes.fromhex("01 03 04 17 70 00 00 FE 5C")
WRITE_RUN = bytes.fromhex("01 06 20 00 00 02 03 CB")
WRITE_STOP = bytes.fromhex("01 06 20 00 00 01 43 CA")
WRITE_50_HZ = bytes.fromhex("01 06 20 01 13 88 DE 9C")  # 5000 counts of 0.01 Hz
WRITE_0_HZ = bytes.fromhex("01 06 20 01 00 00 D3 CA")
EXCEPTION_ILLEGAL_ADDRESS_ON_WRITE = bytes.fromhex("01 86 02 C3 A1")


def spec_crc(frame: bytes) -> bytes:
    """CRC-16/MODBUS by the serial-line specification's appendix B, bit by bit; low byte first."""
    register = 0xFFFF
    for byte in frame:
        register ^= byte
        for _ in range(8):
            carry = register & 1
            register >>= 1
            if carry:
                register ^= 0xA001
    return bytes([register & 0xFF, register >> 8])


@pytest.mark.parametrize(
    "frame",
    [
        SPEC_WRITE_REGISTER_2,
        DELTA_READ_2102_2103,
        DELTA_REPLY_60HZ_0HZ,
        WRITE_RUN,
        WRITE_STOP,
        WRITE_50_HZ,
        WRITE_0_HZ,
        EXCEPTION_ILLEGAL_ADDRESS_ON_WRITE,
    ],
)
def test_every_reference_frame_ends_with_the_spec_crc(frame):
    assert spec_crc(frame[:-2]) == frame[-2:]
    assert with_crc(frame[:-2]) == frame


def test_crc_check_value_and_request_builders_match_the_references():
    assert crc16_modbus(b"123456789") == CRC16_MODBUS_CHECK_VALUE == 0x4B37
    assert write_single_register_request(1, 0x0001, 3) == SPEC_WRITE_REGISTER_2
    assert read_holding_registers_request(1, 0x2102, 2) == DELTA_READ_2102_2103


def test_silent_interval_between_frames_follows_the_serial_line_guide():
    assert silent_interval_s(9600) == pytest.approx(3.5 * 11 / 9600)  # 4.01 ms
    assert silent_interval_s(19200) == pytest.approx(3.5 * 11 / 19200)
    assert silent_interval_s(115200) == 0.00175  # fixed above 19200 bit/s


def make_fan(port: str, reply_timeout_s: float = 5.0) -> ModbusVfdTunnelFan:
    return ModbusVfdTunnelFan(
        port,
        settings=DELTA_MAP,
        speed_map=SPEED_MAP,
        max_fan_rpm=MAX_FAN_RPM,
        reply_timeout_s=reply_timeout_s,
    )


def test_driver_sends_exact_frames_for_status_set_frequency_run_and_stop(scripted_device):
    device = scripted_device(
        [
            (8, DELTA_REPLY_60HZ_0HZ),  # open(): read status, answered as in Delta's manual
            (8, WRITE_50_HZ),  # set_frequency_hz(50): set point, echoed
            (8, WRITE_RUN),  # then run
            (8, WRITE_STOP),  # safe_state(): stop
            (8, WRITE_0_HZ),  # then a zero set point
        ]
    )
    fan = make_fan(device.port_path)
    identity = fan.open()
    try:
        assert identity == "Modbus RTU unit 1: frequency command 60.00 Hz, output 0.00 Hz"
        fan.set_frequency_hz(50.0)
        fan.safe_state()
    finally:
        fan.close()
    assert device.received == [DELTA_READ_2102_2103, WRITE_50_HZ, WRITE_RUN, WRITE_STOP, WRITE_0_HZ]


def test_connection_sends_the_spec_example_frame(scripted_device):
    device = scripted_device([(8, SPEC_WRITE_REGISTER_2)])
    connection = ModbusRtuConnection(device.port_path, name="tunnel fan", unit_id=1, baud=9600)
    connection.open()
    try:
        connection.write_register(0x0001, 3)
    finally:
        connection.close()
    assert device.received == [SPEC_WRITE_REGISTER_2]


def one_line_error(error: Exception) -> str:
    text = str(error)
    assert "\n" not in text
    return text


def test_exception_reply_is_one_line_naming_instrument_port_register_and_code(scripted_device):
    device = scripted_device([(8, EXCEPTION_ILLEGAL_ADDRESS_ON_WRITE)])
    connection = ModbusRtuConnection(device.port_path, name="tunnel fan", unit_id=1, baud=9600)
    connection.open()
    try:
        with pytest.raises(InstrumentReplyError) as raised:
            connection.write_register(0x2001, 5000)
    finally:
        connection.close()
    assert one_line_error(raised.value) == (
        f"tunnel fan: refused write of 5000 to register 0x2001 on {device.port_path}: "
        "Modbus exception 02 (illegal data address)"
    )


def test_reply_with_a_bad_crc_is_refused(scripted_device):
    corrupted = WRITE_50_HZ[:-1] + bytes([WRITE_50_HZ[-1] ^ 0xFF])
    device = scripted_device([(8, corrupted)])
    connection = ModbusRtuConnection(device.port_path, name="tunnel fan", unit_id=1, baud=9600)
    connection.open()
    try:
        with pytest.raises(InstrumentReplyError) as raised:
            connection.write_register(0x2001, 5000)
    finally:
        connection.close()
    message = one_line_error(raised.value)
    assert message.startswith("tunnel fan: reply to write of 5000 to register 0x2001 on ")
    assert device.port_path in message and "bad CRC: 01 06 20 01 13 88 de 63" in message


def test_silence_is_a_disconnection_naming_request_unit_and_port(scripted_device):
    device = scripted_device([(8, None)])  # reads the request, never answers
    connection = ModbusRtuConnection(
        device.port_path, name="tunnel fan", unit_id=1, baud=9600, reply_timeout_s=0.2
    )
    connection.open()
    try:
        with pytest.raises(InstrumentDisconnected) as raised:
            connection.read_registers(0x2103, 1)
    finally:
        connection.close()
    assert one_line_error(raised.value) == (
        f"tunnel fan: no reply to read of register 0x2103 (unit 1) within 0.2 s on {device.port_path}"
    )


def test_set_points_beyond_the_rig_limit_are_refused_before_sending(scripted_device):
    device = scripted_device([(8, DELTA_REPLY_60HZ_0HZ)])
    fan = ModbusVfdTunnelFan(
        device.port_path, settings=DELTA_MAP, speed_map=SPEED_MAP, max_fan_rpm=1500.0
    )
    fan.open()
    try:
        with pytest.raises(UserInputError, match="outside the rig limit 0..50 Hz"):
            fan.set_frequency_hz(55.0)
        with pytest.raises(UserInputError, match="must be finite|finite"):
            fan.set_frequency_hz(float("nan"))
    finally:
        fan.close()
    assert device.received == [DELTA_READ_2102_2103]  # nothing after the status read


@pytest.fixture
def simulated_vfd(simulated_clock, simulated_tunnel_signals):
    with SimulatedModbusVfd(simulated_clock, simulated_tunnel_signals, SPEED_MAP, DELTA_MAP) as vfd:
        yield vfd


def test_simulated_drive_ramps_and_drives_the_tunnel_velocity(
    simulated_vfd, simulated_tunnel_signals, wait_for
):
    fan = make_fan(simulated_vfd.port_path)
    assert fan.open().startswith("Modbus RTU unit 1:")
    try:
        fan.set_velocity(3.62)  # 1000 rpm in the table = 33.33 Hz at 30 rpm/Hz
        status = fan.read_status()
        assert status.frequency_command_hz == pytest.approx(33.33)
        readings = [status.output_frequency_hz]
        wait_for(
            lambda: readings.append(fan.read_output_frequency_hz()) or readings[-1] >= 33.33 - 1e-9
        )
        assert readings == sorted(readings)  # ramps up, never jumps down
        assert fan.read_velocity_m_s() == pytest.approx(3.62, abs=0.01)
        operating_point = simulated_tunnel_signals.operating_point()
        assert operating_point["tunnel_velocity_m_s"] == pytest.approx(3.62, abs=0.01)
        fan.safe_state()
        assert fan.read_status().frequency_command_hz == 0.0
        wait_for(lambda: fan.read_output_frequency_hz() == 0.0)
        assert not simulated_vfd.running
    finally:
        fan.close()


def test_simulated_drive_refuses_with_modbus_exceptions(simulated_vfd):
    connection = ModbusRtuConnection(
        simulated_vfd.port_path, name="tunnel fan", unit_id=1, baud=9600
    )
    connection.open()
    try:
        with pytest.raises(
            InstrumentReplyError, match=r"0x3000 .*exception 02 \(illegal data address\)"
        ):
            connection.write_register(0x3000, 1)
        with pytest.raises(InstrumentReplyError, match=r"exception 02 \(illegal data address\)"):
            connection.read_registers(0x2103, 3)  # 0x2104, 0x2105 are not served
        with pytest.raises(InstrumentReplyError, match=r"exception 03 \(illegal data value\)"):
            connection.write_register(0x2001, 6001)  # 60.01 Hz: above the drive's maximum
        with pytest.raises(InstrumentReplyError, match=r"exception 03 \(illegal data value\)"):
            connection.write_register(0x2000, 0x0007)  # not a control value it knows
        with pytest.raises(InstrumentReplyError, match=r"exception 02 \(illegal data address\)"):
            connection.write_register(0x2103, 0)  # output frequency is read-only
        assert connection.read_registers(0x2001, 1) == [0]  # nothing refused was applied
    finally:
        connection.close()


def test_simulated_drive_ignores_other_units_and_bad_crcs(simulated_vfd, wait_for):
    with serial.Serial(simulated_vfd.port_path, 9600, timeout=0.2) as raw:
        raw.write(WRITE_50_HZ[:-1] + b"\x00")  # bad CRC: dropped without a reply
        wait_for(lambda: simulated_vfd.frames_with_bad_crc == 1)
        raw.write(WRITE_50_HZ)
        assert raw.read(8) == WRITE_50_HZ  # the next good frame is answered
    assert simulated_vfd.setpoint_counts == 5000
    other = ModbusRtuConnection(
        simulated_vfd.port_path, name="tunnel fan", unit_id=2, baud=9600, reply_timeout_s=0.2
    )
    other.open()
    try:
        with pytest.raises(
            InstrumentDisconnected, match="no reply to read of register 0x2103 .unit 2."
        ):
            other.read_registers(0x2103, 1)
    finally:
        other.close()


def test_unplugged_drive_is_a_disconnection_naming_it(simulated_vfd):
    fan = make_fan(simulated_vfd.port_path, reply_timeout_s=0.5)
    fan.open()
    try:
        simulated_vfd.unplug()
        with pytest.raises(InstrumentDisconnected) as raised:
            for _ in range(1000):  # until the pty's master is gone
                fan.read_output_frequency_hz()
        assert one_line_error(raised.value).startswith("tunnel fan: ")
        assert simulated_vfd.port_path in str(raised.value)
    finally:
        fan.close()


def test_fan_modbus_settings_errors_name_the_key(tmp_path):
    from ornitail.core.toml_table import TomlTable

    def read(table):
        return ModbusVfdSettings.from_table(
            TomlTable(
                tmp_path / "rig.toml", "fan.modbus", table, ModbusVfdSettings.__dataclass_fields__
            )
        )

    assert read({"fan_rpm_per_hz": 30.0}) == DELTA_MAP
    with pytest.raises(UserInputError, match=r"rig.toml: \[fan.modbus\].unit_id: 0 must be >= 1"):
        read({"fan_rpm_per_hz": 30.0, "unit_id": 0})
    with pytest.raises(
        UserInputError, match=r"\[fan.modbus\].fan_rpm_per_hz: required key is missing"
    ):
        read({})
    with pytest.raises(
        UserInputError, match=r"\[fan.modbus\].control_register: 65536 must be in 0..65535"
    ):
        read({"fan_rpm_per_hz": 30.0, "control_register": 0x10000})
