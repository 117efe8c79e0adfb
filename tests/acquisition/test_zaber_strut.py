"""The ``zaber_ascii`` strut backend: exact command lines, replies and errors, and a simulated controller on a pty.

Byte references: Zaber's ASCII protocol manual (firmware 7, https://www.zaber.com/protocol-manual?protocol=ASCII;
message format summarised in https://www.zaber.com/articles/ascii-protocol): a command is ``/`` device address,
axis, command and data separated by spaces and ended by a newline (``/1 1 move abs 12345``); a reply is ``@`` +
two-digit address, axis, ``OK``/``RJ``, ``IDLE``/``BUSY``, warning flag (``--`` none), data, ended by CR LF
(``@01 0 OK IDLE -- 0``). The lone ``\\n`` the driver sends first on open ends any command a crashed host left
half-written (it is an empty message, which the device ignores) before the port is drained.
"""

from __future__ import annotations

import math

import pytest

from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentReplyError
from ornitail.acquisition.zaber_ascii import parse_reply
from ornitail.acquisition.zaber_strut_driver import ZaberAsciiStrut, ZaberStrutSettings
from ornitail.core.errors import UserInputError
from ornitail.core.toml_table import TomlTable
from ornitail.simulated_instruments.zaber_strut import SIMULATED_DEVICE_ID, SimulatedZaberStrut

SETTINGS = ZaberStrutSettings(
    device=1, axis=1, counts_per_deg=2000.0, pitch_at_zero_counts_deg=-10.0
)


def make_strut(port: str, *, reply_timeout_s: float = 5.0, pitch_max_deg: float = 45.0):
    return ZaberAsciiStrut(
        port,
        settings=SETTINGS,
        pitch_min_rad=math.radians(-10.0),
        pitch_max_rad=math.radians(pitch_max_deg),
        reply_timeout_s=reply_timeout_s,
    )


def lines(*texts: str) -> list[bytes]:
    return [text.encode("ascii") for text in texts]


def test_driver_sends_exact_lines_and_reads_exact_replies(scripted_device):
    sent = lines(
        "\n",
        "/1 0 get device.id\n",
        "/1 1 home\n",
        "/1 1 get pos\n",
        "/1 1 move abs 40000\n",  # 10 deg: (10 - (-10)) deg * 2000 counts/deg
        "/1 1 get pos\n",
        "/1 1 stop\n",
    )
    replies = [
        None,
        b"@01 0 OK IDLE -- 50081\r\n",
        b"@01 1 OK BUSY WR 0\r\n",
        b"@01 1 OK IDLE -- 0\r\n",  # homed (no WR/WH flag) and idle
        b"@01 1 OK BUSY -- 0\r\n",
        b"@01 1 OK BUSY -- 12345\r\n",
        b"@01 1 OK IDLE NI 0\r\n",
    ]
    device = scripted_device(
        [(len(line), reply) for line, reply in zip(sent, replies, strict=True)]
    )
    strut = make_strut(device.port_path)
    assert strut.open() == "Zaber device 1 axis 1 device.id=50081"
    try:
        strut.home()
        strut.set_pitch(math.radians(10.0))
        assert math.degrees(strut.read_pitch_rad()) == pytest.approx(-10.0 + 12345 / 2000)
        strut.safe_state()
    finally:
        strut.close()
    assert device.received == sent


def test_reply_parsing_follows_the_manual_fields():
    reply = parse_reply("@01 0 OK IDLE -- 0")
    assert (reply.device, reply.axis, reply.accepted, reply.busy, reply.warning, reply.data) == (
        1,
        0,
        True,
        False,
        "--",
        "0",
    )
    rejected = parse_reply("@02 1 RJ BUSY WR BADDATA")
    assert not rejected.accepted and rejected.busy and rejected.data == "BADDATA"
    assert parse_reply("#01 0 some info") is None and parse_reply("OK") is None


@pytest.mark.parametrize(
    ("reply", "error", "message"),
    [
        (
            b"@01 1 RJ IDLE -- BADDATA\r\n",
            InstrumentReplyError,
            "strut pitch actuator: rejected '/1 1 get pos' on {port}: BADDATA (flag -- (no warning))",
        ),
        (
            b"@01 1 OK IDLE FS 0\r\n",
            InstrumentReplyError,
            "strut pitch actuator: reports fault FS (stalled and stopped) after '/1 1 get pos' on {port}",
        ),
        (
            b"@02 1 OK IDLE -- 0\r\n",
            InstrumentReplyError,
            "strut pitch actuator: unexpected reply to '/1 1 get pos' on {port}: '@02 1 OK IDLE -- 0'",
        ),
        (
            None,
            InstrumentDisconnected,
            "strut pitch actuator: no reply to '/1 1 get pos' within 0.3 s on {port}",
        ),
    ],
)
def test_errors_are_one_line_naming_instrument_port_and_command(
    scripted_device, reply, error, message
):
    script = [(1, None), (len("/1 0 get device.id\n"), b"@01 0 OK IDLE -- 50081\r\n")]
    device = scripted_device([*script, (len("/1 1 get pos\n"), reply)])
    strut = make_strut(device.port_path, reply_timeout_s=0.3)
    strut.open()
    try:
        with pytest.raises(error) as raised:
            strut.read_pitch_rad()
    finally:
        strut.close()
    assert str(raised.value) == message.format(port=device.port_path)


def test_safe_state_accepts_a_stop_answered_with_a_fault_flag(scripted_device):
    stop = "/1 1 stop\n"
    device = scripted_device(
        [
            (1, None),
            (len("/1 0 get device.id\n"), b"@01 0 OK IDLE -- 50081\r\n"),
            (len(stop), b"@01 1 OK IDLE FS 0\r\n"),  # stalled and stopped: at rest, stop accepted
        ]
    )
    strut = make_strut(device.port_path)
    strut.open()
    try:
        strut.safe_state()
    finally:
        strut.close()
    assert device.received[-1] == stop.encode()


def test_pitch_outside_the_rig_limits_is_refused_before_sending(scripted_device):
    device = scripted_device([(1, None), (len("/1 0 get device.id\n"), b"@01 0 OK IDLE -- 1\r\n")])
    strut = make_strut(device.port_path)
    strut.open()
    try:
        with pytest.raises(UserInputError, match="50 deg is outside the rig limit -10..45 deg"):
            strut.set_pitch(math.radians(50.0))
    finally:
        strut.close()
    assert len(device.received) == 2


@pytest.fixture
def simulated_zaber(simulated_clock, simulated_tunnel_signals):
    with SimulatedZaberStrut(simulated_clock, simulated_tunnel_signals, SETTINGS) as controller:
        yield controller


def test_simulated_controller_homes_moves_and_drives_the_pitch(
    simulated_zaber, simulated_tunnel_signals
):
    strut = make_strut(simulated_zaber.port_path, pitch_max_deg=80.0)
    assert strut.open() == f"Zaber device 1 axis 1 device.id={SIMULATED_DEVICE_ID}"
    try:
        assert not strut.state().homed
        with pytest.raises(
            InstrumentReplyError, match=r"rejected '/1 1 move abs 40000' .*BADCOMMAND .*WR"
        ):
            strut.set_pitch(math.radians(10.0))  # no reference position yet
        strut.home()
        assert strut.state().homed
        assert math.degrees(strut.read_pitch_rad()) == pytest.approx(-10.0)
        strut.set_pitch(math.radians(20.0))
        strut.wait_until_settled()
        assert math.degrees(strut.read_pitch_rad()) == pytest.approx(20.0)
        pitch = simulated_tunnel_signals.operating_point()["pitch_rad"]
        assert math.degrees(pitch) == pytest.approx(20.0)
        with pytest.raises(InstrumentReplyError, match="BADDATA"):
            strut.set_pitch(math.radians(70.0))  # beyond the controller's travel (60 deg)
        assert strut.check_reading() == {
            "pitch_deg": pytest.approx(20.0),
            "position_counts": 60000,
            "homed": True,
        }
        strut.safe_state()
    finally:
        strut.close()


def test_simulated_controller_ignores_other_device_addresses(simulated_zaber):
    other = ZaberAsciiStrut(
        simulated_zaber.port_path,
        settings=ZaberStrutSettings(device=2, axis=1, counts_per_deg=2000.0),
        pitch_min_rad=0.0,
        pitch_max_rad=1.0,
        reply_timeout_s=0.3,
    )
    with pytest.raises(InstrumentDisconnected, match="no reply to '/2 0 get device.id'"):
        other.open()
    assert not other.is_open


def test_strut_zaber_settings_errors_name_the_key(tmp_path):
    def read(table):
        return ZaberStrutSettings.from_table(
            TomlTable(
                tmp_path / "rig.toml", "strut.zaber", table, ZaberStrutSettings.__dataclass_fields__
            )
        )

    assert read({"counts_per_deg": 2000.0, "pitch_at_zero_counts_deg": -10.0}) == SETTINGS
    with pytest.raises(UserInputError, match=r"\[strut.zaber\].counts_per_deg: must not be 0"):
        read({"counts_per_deg": 0})
    with pytest.raises(
        UserInputError, match=r"\[strut.zaber\].counts_per_deg: required key is missing"
    ):
        read({})
    with pytest.raises(UserInputError, match=r"\[strut.zaber\].axis: 10 must be in 1..9"):
        read({"counts_per_deg": 1.0, "axis": 10})
