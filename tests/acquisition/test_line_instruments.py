"""Fan, strut and motor: exact line-protocol strings, drivers with limits, simulated dynamics."""

import math
import time

import pytest
import serial

from ornitail.acquisition.flapping_motor_driver import FlappingMotorDriver
from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentReplyError
from ornitail.acquisition.strut_pitch_driver import StrutPitchDriver
from ornitail.acquisition.tunnel_fan_driver import TunnelFanDriver
from ornitail.core.errors import UserInputError
from ornitail.simulated_instruments.line_instrument import first_order_step


@pytest.fixture
def simulated_time_scale() -> float:
    """Slower than the plugin's default 20 so that slewing and spin-up are seen in progress.

    The strut's 30 deg at 10 deg/s then lasts 0.6 s of wall time and the fan needs at least 0.25 s
    to pass 500 rpm, far longer than one query (about 1 ms).
    """
    return 5.0


def exchange(port_path: str, lines: list[bytes]) -> list[bytes]:
    """Send raw lines to a simulated instrument and return the raw reply lines."""
    with serial.Serial(port_path, 115200, timeout=1.0) as port:
        replies = []
        for line in lines:
            port.write(line)
            replies.append(port.read_until(b"\n"))
        return replies


def test_fan_protocol_strings(simulated_fan):
    replies = exchange(
        simulated_fan.port_path,
        [b"ID?\n", b"RPM 1200\n", b"TARGET?\n", b"RPM 99999\n", b"RPM abc\n", b"FOO\n", b"STOP\n"],
    )
    assert replies == [
        b"ID model=ORNI-FAN serial=SIM00001 firmware=1.0.0\n",
        b"OK\n",
        b"TARGET 1200.0\n",
        b"ERR rpm 99999 outside 0..1800\n",
        b"ERR RPM needs one number\n",
        b"ERR unknown command 'FOO'\n",
        b"OK\n",
    ]
    reply = exchange(simulated_fan.port_path, [b"RPM?\n"])[0]
    assert reply.startswith(b"RPM ") and reply.endswith(b"\n")


def test_strut_protocol_strings(simulated_strut):
    replies = exchange(
        simulated_strut.port_path,
        [b"STATUS?\n", b"ANGLE 10\n", b"ANGLE?\n", b"LIMITS?\n", b"HOME\n", b"HALT\n"],
    )
    assert replies == [
        b"STATUS homed=0 moving=0\n",
        b"ERR not homed\n",
        b"ANGLE 3.7000\n",
        b"LIMITS -30.000 60.000\n",
        b"OK\n",
        b"OK\n",
    ]


def test_motor_protocol_strings(simulated_motor):
    replies = exchange(
        simulated_motor.port_path,
        [b"THROTTLE 1.5\n", b"RPM -1\n", b"THROTTLE 0.5\n", b"OFF\n", b"RPM 0\n"],
    )
    assert replies == [
        b"ERR throttle 1.5 outside 0..1\n",
        b"ERR rpm -1 outside 0..30000\n",
        b"OK\n",
        b"OK\n",
        b"OK\n",
    ]


@pytest.mark.parametrize(
    ("value", "target", "dt", "tau", "rate", "expected"),
    [
        (0.0, 100.0, 1.0, 1.0, math.inf, 100.0 * (1 - math.exp(-1.0))),  # pure lag
        (0.0, 100.0, 0.1, 0.0, 10.0, 1.0),  # pure rate limit: 10/s * 0.1 s
        (50.0, 0.0, 0.5, 0.2, 20.0, 40.0),  # lag wants -45.9, rate limit allows -10
        (5.0, 5.0, 1.0, 1.0, 1.0, 5.0),
    ],
)
def test_first_order_step(value, target, dt, tau, rate, expected):
    assert first_order_step(value, target, dt, tau, rate) == pytest.approx(expected, rel=1e-12)


def wait_for(predicate, timeout_s: float = 10.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "condition not reached"
        time.sleep(0.01)


def test_fan_spins_up_gradually_and_drives_the_tunnel_velocity(
    simulated_fan, simulated_tunnel_signals
):
    fan = TunnelFanDriver(simulated_fan.port_path, max_rpm=1600.0)
    fan.open()
    fan.set_rpm(1000.0)
    readings = [fan.read_rpm()]
    wait_for(lambda: readings.append(fan.read_rpm()) or readings[-1] > 999.0)
    assert readings[0] < 500.0  # spin-up takes seconds of simulated time, not one step
    assert all(
        b >= a for a, b in zip(readings, readings[1:], strict=False)
    )  # monotonic, no overshoot
    # packaged table: 1000 rpm -> 3.62 m/s; the source follows the measured rpm (within 1 rpm:
    # 3.8e-3 m/s per rpm here)
    assert simulated_tunnel_signals.operating_point()["tunnel_velocity_m_s"] == pytest.approx(
        3.62, abs=0.005
    )
    fan.safe_state()
    assert fan.read_target_rpm() == 0.0
    fan.close()


def test_a_reply_left_over_from_a_cut_exchange_is_not_taken_for_the_next_one(simulated_fan):
    """A set command whose reply was never read (the exchange was interrupted between write and read) leaves
    ``OK`` waiting on the port; the next query must still get its own ``RPM <value>`` reply, not that ``OK``."""
    fan = TunnelFanDriver(simulated_fan.port_path, max_rpm=1500.0, name="tunnel fan")
    fan.open()
    port = fan.connection._serial
    port.write(b"RPM 800\n")  # what query() writes; the reply is left unread
    deadline = time.monotonic() + 2.0
    while port.in_waiting == 0 and time.monotonic() < deadline:
        time.sleep(0.005)
    assert port.in_waiting > 0  # the stale "OK" is waiting
    assert fan.read_target_rpm() == 800.0
    fan.set_rpm(0.0)
    fan.close()


def test_fan_refuses_set_point_above_limit_before_sending(simulated_fan):
    fan = TunnelFanDriver(simulated_fan.port_path, max_rpm=1500.0, name="tunnel fan")
    fan.open()
    for bad in (1600.0, -1.0, math.nan):
        with pytest.raises(UserInputError, match="fan_rpm"):
            fan.set_rpm(bad)
    assert fan.read_target_rpm() == 0.0  # nothing was sent
    fan.close()


def test_strut_homes_slews_and_drives_the_pitch(simulated_strut, simulated_tunnel_signals):
    strut = StrutPitchDriver(
        simulated_strut.port_path, pitch_min_rad=math.radians(-10), pitch_max_rad=math.radians(45)
    )
    assert strut.open().startswith("ID model=ORNI-STRUT")
    with pytest.raises(InstrumentReplyError, match="not homed"):
        strut.set_pitch(math.radians(10))
    strut.home()
    assert strut.read_pitch_rad() == 0.0
    strut.set_pitch(math.radians(30))
    # 30 deg at 10 deg/s takes 3 s of simulated time: the strut is seen moving first
    assert strut.status().moving
    assert 0.0 < strut.read_pitch_rad() < math.radians(30)
    strut.wait_until_settled()
    assert math.degrees(strut.read_pitch_rad()) == pytest.approx(
        30.0, abs=1e-4
    )  # 4 decimals on the wire
    assert simulated_tunnel_signals.operating_point()["pitch_rad"] == pytest.approx(
        math.radians(30)
    )
    with pytest.raises(UserInputError, match=r"50 deg is outside the rig limit -10..45 deg"):
        strut.set_pitch(math.radians(50))
    strut.close()


def test_motor_follows_with_lag_and_sets_flapping_frequency(
    simulated_motor, simulated_tunnel_signals
):
    motor = FlappingMotorDriver(simulated_motor.port_path, max_rpm=20_000.0)
    motor.open()
    motor.set_target_rpm(14_077.8)  # 11 Hz * 60 * 21.33
    # the simulated lag snaps to the target once within 0.05 rpm, so the reading becomes exact
    wait_for(lambda: motor.read_rpm() == 14_077.8)
    point = simulated_tunnel_signals.operating_point()
    assert point["flapping_frequency_hz"] == pytest.approx(11.0, abs=1e-9)
    # the source's own tachometer adds speed wander and noise of a few tenths of a percent
    assert simulated_tunnel_signals.motor_rpm == pytest.approx(14_077.8, rel=0.01)
    with pytest.raises(UserInputError, match="max_motor_rpm"):
        motor.set_target_rpm(25_000.0)
    with pytest.raises(UserInputError, match="throttle_fraction"):
        motor.set_throttle(1.2)
    motor.safe_state()
    wait_for(lambda: motor.read_rpm() == 0.0)
    motor.close()


def test_unplugged_instrument_raises_disconnected_naming_it(simulated_motor):
    motor = FlappingMotorDriver(simulated_motor.port_path, max_rpm=20_000.0, name="flapping motor")
    motor.open()
    simulated_motor.unplug()
    time.sleep(0.05)
    with pytest.raises(InstrumentDisconnected, match="flapping motor: port /dev/pts/"):
        motor.read_rpm()
    motor.close()
