"""Rig file loading errors and the simulated rig: connect, set, read, close in safe state."""

import math
import shutil
import time
from pathlib import Path

import pytest

from ornitail.acquisition import actuator_backends
from ornitail.acquisition.instrument_errors import InstrumentDisconnected
from ornitail.acquisition.netcanoem_driver import NetCanOemDriver
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, read_rig_file
from ornitail.acquisition.serial_daq_driver import SerialDaqDriver
from ornitail.calibration.hotwire_laws import KingsLaw
from ornitail.core.errors import UserInputError

DATA = DEFAULT_RIG_FILE.parent


def write_rig(
    tmp_path: Path, replacements: dict[str, str] | None = None, text: str | None = None
) -> Path:
    """A copy of the packaged rig file (data files in a subfolder) after text replacements."""
    (tmp_path / "files").mkdir()
    shutil.copy(DATA / "calibration" / "FT8884.cal", tmp_path / "files" / "FT8884.cal")
    shutil.copy(DATA / "tunnel_table.csv", tmp_path / "files" / "table.csv")
    if text is None:
        text = DEFAULT_RIG_FILE.read_text()
        text = text.replace('"calibration/FT8884.cal"', '"files/FT8884.cal"')
        text = text.replace('"tunnel_table.csv"', '"files/table.csv"')
        for old, new in (replacements or {}).items():
            assert old in text, old
            text = text.replace(old, new)
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


def test_packaged_rig_file_reads_with_paths_relative_to_it():
    description = read_rig_file(DEFAULT_RIG_FILE)
    assert description.simulated and description.balance_route == "serial_daq"
    assert description.calibration_path == (DATA / "calibration" / "FT8884.cal").resolve()
    assert description.limits.pitch_max_rad == pytest.approx(math.radians(45.0))
    assert description.can.base_id == 0x20


def test_relative_paths_resolve_against_the_rig_file_folder(tmp_path):
    description = read_rig_file(write_rig(tmp_path))
    assert description.tunnel_table_path == (tmp_path / "files" / "table.csv").resolve()


@pytest.mark.parametrize(
    ("replacements", "field", "problem"),
    [
        ({"[limits]": "[limitz]"}, "[limitz]", "unknown section"),
        ({"max_motor_rpm": "max_motor_speed"}, "[limits].max_motor_speed", "unknown key"),
        (
            {"pitch_deg = [-10.0, 45.0]": "pitch_deg = [45.0, -10.0]"},
            "[limits].pitch_deg",
            "minimum 45 must be below maximum -10",
        ),
        (
            {"pitch_deg = [-10.0, 45.0]": "pitch_deg = [-10.0, nan]"},
            "[limits].pitch_deg",
            "must be 2 finite numbers [minimum, maximum]",
        ),
        (
            {'route = "serial_daq"': 'route = "usb"'},
            "[balance].route",
            "must be one of serial_daq, can",
        ),
        (
            {'"files/FT8884.cal"': '"files/nope.cal"'},
            "[balance].calibration",
            "file 'files/nope.cal' not found",
        ),
        ({"time_scale = 1.0": "time_scale = -2.0"}, "[rig].time_scale", "must be > 0"),
        (
            {"max_motor_rpm = 21000.0": 'max_motor_rpm = "fast"'},
            "[limits].max_motor_rpm",
            "finite number",
        ),
        ({"simulated = true": "simulated = 1"}, "[rig].simulated", "must be true or false"),
        ({"base_id = 0x20": "base_id = 0x80"}, "[balance.can].base_id", "must be in 0..127"),
        (
            {"sample_rate_hz = 10000.0": "sample_rate_hz = 20000.0"},
            "[balance.serial_daq].sample_rate_hz",
            "exceeds the serial link ceiling 16000 Hz",
        ),
        (
            {
                'route = "serial_daq"': 'route = "can"',
                "sample_rate_hz = 2000.0": "sample_rate_hz = 4000.0",
            },
            "[balance.can].sample_rate_hz",
            "exceeds the CAN ceiling 3953 samples/s",
        ),
    ],
)
def test_rig_file_errors_name_file_and_field(tmp_path, replacements, field, problem):
    path = write_rig(tmp_path, replacements)
    with pytest.raises(UserInputError) as caught:
        read_rig_file(path)
    assert caught.value.where == f"{path}: {field}"
    assert problem in caught.value.problem


def test_missing_section_and_bad_toml(tmp_path):
    path = write_rig(tmp_path, text="[rig]\nname = 'x'\n")
    with pytest.raises(UserInputError, match=r"rig.toml: \[balance\]: section missing"):
        read_rig_file(path)
    path.write_text("[rig\n")
    with pytest.raises(UserInputError, match="rig.toml: not valid TOML"):
        read_rig_file(path)
    with pytest.raises(UserInputError, match="absent.toml: file not found"):
        read_rig_file(tmp_path / "absent.toml")


def test_velocity_limit_beyond_the_tunnel_table_is_refused(tmp_path):
    path = write_rig(tmp_path, {"velocity_m_s = [0.0, 6.0]": "velocity_m_s = [0.0, 9.0]"})
    with pytest.raises(
        UserInputError, match=r"\[limits\].velocity_m_s: 0..9 m/s is not inside the tunnel table"
    ):
        Rig.from_file(path)


def test_a_simulated_rig_without_simulated_instruments_installed_is_one_line(tmp_path, monkeypatch):
    path = write_rig(tmp_path)
    monkeypatch.setattr(actuator_backends, "installed_entry_points", lambda: [])
    with pytest.raises(UserInputError) as caught:
        Rig.from_file(path)
    assert caught.value.where == f"{path}: [rig].simulated"
    assert caught.value.problem.startswith(
        "the simulated instruments ('simulated') are not installed"
    )
    assert "'rig.simulated' in the group 'ornitail.instruments'" in caught.value.problem


def test_a_rig_file_names_its_hot_wire_law_and_a_missing_one_is_one_line(tmp_path):
    """A real rig's ``[tunnel].hotwire_law``: the window's live view converts the bridge voltage with it (the
    law here is a King's law with other constants than the simulated hot-wire's, so it wins on a simulated rig)."""
    text = (
        'law = "king"\nreference_temperature_k = 293.15\nwire_temperature_k = 523.15\na_v2 = 1.7\n'
        'b = 0.9\nexponent_n = 0.5\npoints_content_hash = "test"\npoint_count = 9\n'
        "rms_residual_m_s = 0.01\nmax_abs_residual_m_s = 0.02\n"
    )
    for folder, simulated in (("real", "false"), ("simulated", "true")):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "law.toml").write_text(text)
        rig = Rig.from_file(
            write_rig(
                tmp_path / folder,
                {
                    "simulated = true": f"simulated = {simulated}",
                    'table = "files/table.csv"': 'table = "files/table.csv"\nhotwire_law = "law.toml"',
                },
            )
        )
        law = rig.hotwire_law()
        assert isinstance(law, KingsLaw) and (law.a_v2, law.b, law.exponent_n) == (1.7, 0.9, 0.5)
    (tmp_path / "absent").mkdir()
    path = write_rig(
        tmp_path / "absent",
        {'table = "files/table.csv"': 'table = "files/table.csv"\nhotwire_law = "gone.toml"'},
    )
    with pytest.raises(UserInputError) as caught:
        read_rig_file(path)
    assert caught.value.where == f"{path}: [tunnel].hotwire_law"
    assert "'gone.toml' not found" in caught.value.problem


def test_the_rig_file_chooses_the_simulation_and_its_hot_wire_law(tmp_path):
    (tmp_path / "real").mkdir()
    simulated = Rig.from_file(write_rig(tmp_path))
    law = simulated.hotwire_law()
    assert isinstance(law, KingsLaw) and (law.a_v2, law.b, law.exponent_n) == (2.0, 1.2, 0.45)
    real = Rig.from_file(write_rig(tmp_path / "real", {"simulated = true": "simulated = false"}))
    assert real.hotwire_law() is None
    real.start_simulation()  # nothing to reach
    assert real.simulators is None and real.time_scale == 1.0


def wait_for(predicate, timeout_s: float = 10.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "condition not reached"
        time.sleep(0.01)


def test_simulated_rig_sets_reads_and_streams(simulated_rig):
    rig = simulated_rig
    assert isinstance(rig.balance, SerialDaqDriver)  # packaged rig: the serial DAQ route
    rig.set_tunnel_velocity(3.0)
    rig.set_pitch(math.radians(20.0))
    rig.set_flapping_frequency(11.0)
    wait_for(lambda: abs(rig.read_tunnel_velocity_m_s() - 3.0) < 0.01)
    wait_for(lambda: abs(rig.read_flapping_frequency_hz() - 11.0) < 1e-3)
    rig.strut.wait_until_settled()
    assert math.degrees(rig.read_pitch_rad()) == pytest.approx(20.0, abs=1e-4)
    point = rig.simulators.signals.operating_point()
    assert point["tunnel_velocity_m_s"] == pytest.approx(3.0, abs=0.01)
    assert point["flapping_frequency_hz"] == pytest.approx(11.0, abs=1e-3)
    assert point["pitch_rad"] == pytest.approx(math.radians(20.0), abs=1e-6)
    with pytest.raises(UserInputError, match=r"7 m/s is outside the rig limit 0..6 m/s"):
        rig.set_tunnel_velocity(7.0)
    with pytest.raises(UserInputError, match=r"17 Hz is outside the rig limit 0..16 Hz"):
        rig.set_flapping_frequency(17.0)
    rig.start_balance(sample_rate_hz=2000.0)  # DAQ clock at 20x real time: keep the stream light
    block = rig.balance.get_block(timeout_s=2.0)
    rig.stop_balance()
    assert block is not None and block.volts.shape[1] == 9


def test_close_brings_motor_and_fan_to_safe_state_even_after_an_error():
    rig = Rig.from_file(time_scale=20.0)
    with pytest.raises(RuntimeError, match="sweep script failed"), rig:
        rig.set_tunnel_velocity(2.0)
        rig.set_flapping_frequency(10.0)
        simulators = rig.simulators
        wait_for(lambda: simulators.motor.rpm > 1000.0)
        raise RuntimeError("sweep script failed")
    assert simulators.motor.target_rpm == 0.0
    assert simulators.fan.target_rpm == 0.0
    assert rig.simulators is None and rig.fan is None


def test_close_still_stops_the_motor_when_the_fan_is_unplugged():
    rig = Rig.from_file(time_scale=20.0).connect()
    rig.set_flapping_frequency(10.0)
    simulators = rig.simulators
    simulators.fan.unplug()
    time.sleep(0.05)
    with pytest.raises(InstrumentDisconnected, match="tunnel fan"):
        rig.close()
    assert simulators.motor.target_rpm == 0.0


def test_can_route_rig_polls_the_simulated_netcanoem(tmp_path):
    path = write_rig(tmp_path, {'route = "serial_daq"': 'route = "can"'})
    with Rig.from_file(path, time_scale=20.0) as rig:
        assert isinstance(rig.balance, NetCanOemDriver)
        assert rig.balance.read_serial_number() == "FT8884"
        rig.start_balance()
        block = rig.balance.get_block(timeout_s=2.0)
        rig.stop_balance()
        assert block is not None and block.gauges.shape[1] == 6
        assert not block.saturated.any()
