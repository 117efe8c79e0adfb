"""Actuator backends chosen by the rig file: built-in ones on a simulated rig, a third party's through the
``ornitail.instruments`` entry points, the rig check of each, and rig-file mistakes as one line naming the field.

The third-party backend is a real installed distribution: a ``*.dist-info`` folder with ``entry_points.txt`` and a
module on ``sys.path``, found by ``importlib.metadata`` exactly as a pip-installed package would be.
"""

from __future__ import annotations

import math
import shutil
import sys
import textwrap
from pathlib import Path

import pytest

from ornitail.acquisition.actuator_backends import backend_names
from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.acquisition.modbus_vfd_driver import ModbusVfdTunnelFan
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.rig_check import check_rig
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, read_rig_file
from ornitail.acquisition.zaber_strut_driver import ZaberAsciiStrut
from ornitail.calibration.tunnel_table import TunnelVelocityTable
from ornitail.core.errors import UserInputError
from ornitail.simulated_instruments.rig_simulator_server import RigSimulatorServer

DATA = DEFAULT_RIG_FILE.parent
MODBUS_ZABER_RIG = DATA / "simulated_rig_modbus_zaber.toml"


def rig_copy(tmp_path: Path, source: Path, replacements: dict[str, str]) -> Path:
    """``source`` with its data files beside it, after text replacements."""
    shutil.copytree(DATA / "calibration", tmp_path / "calibration", dirs_exist_ok=True)
    shutil.copy(DATA / "tunnel_table.csv", tmp_path / "tunnel_table.csv")
    text = source.read_text()
    for old, new in replacements.items():
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


def test_simulated_rig_with_modbus_fan_and_zaber_strut_sets_reads_and_closes_safe(wait_for):
    with Rig.from_file(MODBUS_ZABER_RIG, time_scale=20.0) as rig:
        assert isinstance(rig.fan, ModbusVfdTunnelFan) and isinstance(rig.strut, ZaberAsciiStrut)
        rig.set_tunnel_velocity(3.0)
        rig.set_pitch(math.radians(20.0))
        rig.set_flapping_frequency(11.0)
        wait_for(lambda: abs(rig.read_tunnel_velocity_m_s() - 3.0) < 0.01)
        rig.strut.wait_until_settled()
        assert math.degrees(rig.read_pitch_rad()) == pytest.approx(20.0, abs=1e-3)
        point = rig.simulators.signals.operating_point()
        assert point["tunnel_velocity_m_s"] == pytest.approx(3.0, abs=0.01)
        assert point["pitch_rad"] == pytest.approx(math.radians(20.0), abs=1e-5)
        with pytest.raises(UserInputError, match=r"7 m/s is outside the rig limit 0..6 m/s"):
            rig.set_tunnel_velocity(7.0)
        vfd = rig.simulators.fan
        assert rig.recording_description()["actuator_backends"] == {
            "fan": "modbus_vfd",
            "strut": "zaber_ascii",
            "motor": "orni_line",
        }
    assert rig.safe_state_outcome == {
        "flapping motor": "safe",
        "tunnel fan": "safe",
        "strut pitch actuator": "safe",
    }
    assert not vfd.running and vfd.setpoint_counts == 0


def test_rig_check_identifies_and_reads_the_modbus_drive_and_the_zaber_controller():
    result = check_rig(MODBUS_ZABER_RIG)
    assert result.ok, [check.problem for check in result.instruments]
    checks = {check.instrument: check for check in result.instruments}
    fan, strut = checks["tunnel fan"], checks["strut pitch actuator"]
    assert fan.rig_file_key == "[fan].port" and fan.route.startswith("/dev/")
    assert fan.identity == "Modbus RTU unit 1: frequency command 0.00 Hz, output 0.00 Hz"
    assert fan.reading == {"frequency_command_hz": 0.0, "output_frequency_hz": 0.0, "fan_rpm": 0.0}
    assert strut.identity == "Zaber device 1 axis 1 device.id=30222"
    assert set(strut.reading) == {"pitch_deg", "position_counts", "homed"}
    assert strut.reading["homed"] is False  # the check moves nothing, so it does not home
    assert "model=ORNI-MOTOR" in checks["flapping motor"].identity


@pytest.mark.parametrize(
    ("replacements", "field", "problem"),
    [
        (
            {'backend = "modbus_vfd"': 'backend = "modbus_vdf"'},
            "[fan].backend",
            "'modbus_vdf' is not a fan backend; available: orni_line, modbus_vfd",
        ),
        ({"fan_rpm_per_hz = 30.0": ""}, "[fan.modbus].fan_rpm_per_hz", "required key is missing"),
        ({"unit_id = 1": "unit_id = 248"}, "[fan.modbus].unit_id", "248 must be in 1..247"),
        ({'parity = "N"': 'parity = "X"'}, "[fan.modbus].parity", "'X' must be one of N, E, O"),
        ({"stop_bits = 2": "stopbits = 2"}, "[fan.modbus].stopbits", "unknown key"),
        (
            {"counts_per_deg = 2000.0": "counts_per_deg = 0.0"},
            "[strut.zaber].counts_per_deg",
            "must not be 0",
        ),
        (
            {'backend = "zaber_ascii"': 'backend = "orni_line"'},
            "[strut].zaber",
            "unknown key; allowed keys are backend, baud, port",
        ),
    ],
)
def test_backend_mistakes_in_the_rig_file_name_file_and_field(
    tmp_path, replacements, field, problem
):
    path = rig_copy(tmp_path, MODBUS_ZABER_RIG, replacements)
    with pytest.raises(UserInputError) as raised:
        read_rig_file(path)
    message = str(raised.value)
    assert message.startswith(f"{path}: {field}: "), message
    assert problem in message and "\n" not in message


def test_the_simulator_server_refuses_backends_it_does_not_serve_yet(tmp_path):
    description = read_rig_file(MODBUS_ZABER_RIG)
    with pytest.raises(UserInputError) as raised:
        RigSimulatorServer(description, tmp_path / "control.sock")
    assert str(raised.value).startswith(f"{MODBUS_ZABER_RIG}: [fan].backend: ")
    assert "orni_line backends only (not yet 'modbus_vfd')" in str(raised.value)


def test_fan_speed_map_converts_velocity_rpm_and_frequency_and_clamps_readings():
    speed_map = FanSpeedMap(TunnelVelocityTable.from_csv(DATA / "tunnel_table.csv"), 30.0)
    assert speed_map.rpm_for_velocity(3.62) == pytest.approx(1000.0)
    assert speed_map.frequency_hz_for_velocity(3.62) == pytest.approx(1000.0 / 30.0)
    assert speed_map.velocity_for_frequency_hz(1000.0 / 30.0) == pytest.approx(3.62)
    assert speed_map.velocity_for_rpm(-5.0) == 0.0  # a reading below the table: its first velocity
    assert speed_map.velocity_for_rpm(5000.0) == 6.60  # above: its last
    with pytest.raises(UserInputError, match="outside the tunnel table's range"):
        speed_map.rpm_for_velocity(7.0)


def test_existing_rig_files_use_the_orni_line_backends():
    description = read_rig_file(DEFAULT_RIG_FILE)
    assert (description.fan.backend, description.strut.backend, description.motor.backend) == (
        "orni_line",
        "orni_line",
        "orni_line",
    )
    assert description.fan.baud == 115_200 and description.fan.settings is None


PLUGIN_MODULE = '''
"""A third party's tunnel fan backend (what an NI-DAQmx analog-output fan driver would look like)."""

from ornitail.acquisition.actuator_interfaces import TunnelFan


class MemoryTunnelFan(TunnelFan):
    settings_table = "memory"
    settings_keys = frozenset({"volts_per_m_s"})
    calls = []

    def __init__(self, name, port, volts_per_m_s):
        self.name, self.port, self.volts_per_m_s = name, port, volts_per_m_s
        self._open = False
        self.velocity_m_s = 0.0

    @classmethod
    def read_settings(cls, table):
        return table.number("volts_per_m_s", positive=True)

    @classmethod
    def from_rig(cls, context):
        return cls(context.name, context.port, context.settings)

    @property
    def route(self):
        return self.port

    @property
    def is_open(self):
        return self._open

    def open(self):
        self._open = True
        return "memory fan"

    def close(self):
        self._open = False

    def safe_state(self):
        self.velocity_m_s = 0.0
        MemoryTunnelFan.calls.append("safe_state")

    def set_velocity(self, velocity_m_s):
        self.velocity_m_s = velocity_m_s
        MemoryTunnelFan.calls.append(("volts", velocity_m_s * self.volts_per_m_s))

    def read_velocity_m_s(self):
        return self.velocity_m_s

    def check_reading(self):
        return {"velocity_m_s": self.velocity_m_s}


class NotAFan:
    pass
'''


@pytest.fixture
def installed_plugin(tmp_path, monkeypatch):
    """A distribution ``ornitail-memory-fan`` with two entry points in ``ornitail.instruments``, on sys.path."""
    site = tmp_path / "site"
    info = site / "ornitail_memory_fan-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: ornitail-memory-fan\nVersion: 0.1\n"
    )
    (info / "entry_points.txt").write_text(
        textwrap.dedent(
            """\
            [ornitail.instruments]
            fan.memory = ornitail_memory_fan:MemoryTunnelFan
            fan.not_a_fan = ornitail_memory_fan:NotAFan
            fan.broken = ornitail_memory_fan_missing:Fan
            """
        )
    )
    (site / "ornitail_memory_fan.py").write_text(PLUGIN_MODULE)
    monkeypatch.syspath_prepend(str(site))
    yield
    sys.modules.pop("ornitail_memory_fan", None)


def test_a_backend_installed_through_the_entry_point_group_drives_the_rig_fan(
    tmp_path, installed_plugin
):
    assert backend_names("fan") == ["orni_line", "modbus_vfd", "broken", "memory", "not_a_fan"]
    path = rig_copy(
        tmp_path,
        DEFAULT_RIG_FILE,
        {
            '[fan]\nport = "/dev/ttyUSB0"\nbaud = 115200': '[fan]\nbackend = "memory"\n'
            'port = "/dev/ttyUSB0"\n[fan.memory]\nvolts_per_m_s = 0.5'
        },
    )
    with Rig.from_file(path, time_scale=20.0) as rig:
        fan = rig.fan
        assert type(fan).__name__ == "MemoryTunnelFan" and fan.route == "/dev/ttyUSB0"
        rig.set_tunnel_velocity(4.0)
        assert rig.read_tunnel_velocity_m_s() == 4.0
        assert rig.simulators.fan is None  # a third party's backend has no simulator here
    assert type(fan).calls == ["safe_state", ("volts", 2.0), "safe_state"]
    assert rig.safe_state_outcome["tunnel fan"] == "safe"
    checks = {check.instrument: check for check in check_rig(path).instruments}
    assert checks["tunnel fan"].identity == "memory fan" and checks["tunnel fan"].ok


@pytest.mark.parametrize(
    ("backend", "problem"),
    [
        (
            "not_a_fan",
            "backend 'not_a_fan' (ornitail_memory_fan:NotAFan) is not a subclass of "
            "ornitail.acquisition.actuator_interfaces.TunnelFan",
        ),
        (
            "broken",
            "backend 'broken' (ornitail_memory_fan_missing:Fan) cannot be loaded: ModuleNotFoundError",
        ),
    ],
)
def test_a_bad_installed_backend_is_one_line_naming_the_field(
    tmp_path, installed_plugin, backend, problem
):
    path = rig_copy(
        tmp_path,
        DEFAULT_RIG_FILE,
        {'[fan]\nport = "/dev/ttyUSB0"': f'[fan]\nbackend = "{backend}"\nport = "x"'},
    )
    with pytest.raises(UserInputError) as raised:
        read_rig_file(path)
    assert str(raised.value).startswith(f"{path}: [fan].backend: {problem}")
    assert "\n" not in str(raised.value)
