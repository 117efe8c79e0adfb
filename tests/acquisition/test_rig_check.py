"""`ornitail rig check` and connection failures as users meet them: real processes, real ptys, absent ports.

The instruments run in-process for the shipped simulated rig and in a process of their own
(``rig_simulator_server``, reused from ``benchmarks/crash_harness.py``) when a test needs to see what the check
or a failed sweep sent them. Every wait is on a process exit; nothing is asserted about timing.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import crash_harness as harness
import pytest

from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.acquisition.serial_port_access import close_quietly, open_serial_exclusively

REPOSITORY = Path(__file__).resolve().parents[2]
ORNITAIL = str(Path(sys.executable).parent / "ornitail")
DEADLINE_S = 240.0
INSTRUMENTS = {
    "acquisition board": ("daq", "[balance.serial_daq].port", '"/dev/ttyACM0"'),
    "tunnel fan": ("fan", "[fan].port", '"/dev/ttyUSB0"'),
    "strut pitch actuator": ("strut", "[strut].port", '"/dev/ttyUSB1"'),
    "flapping motor": ("motor", "[motor].port", '"/dev/ttyUSB2"'),
}
"""Instrument name -> (simulator server's name, rig file key, port in the shipped rig file)."""
PLAN = """
[plan]
name = "rig-check-test"
[configuration]
tail_id = "S3"
x_h_mm = 98
[steady_state]
theta_deg = 25.0
v_m_s = 0.8
f_hz = 13.5
[protocol]
steady_state_repeats = 1
tailless_points = "none"
record_s = 0.5
"""


def run_ornitail(*arguments: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [ORNITAIL, *arguments],
        capture_output=True,
        text=True,
        timeout=DEADLINE_S,
        stdin=subprocess.DEVNULL,
    )


def rows(stdout: str) -> dict[str, str]:
    """Instrument name -> the rest of its row in the text output."""
    found = {}
    for line in stdout.splitlines():
        for name in INSTRUMENTS:
            if line.startswith(name + " "):
                found[name] = line[len(name) :].strip()
    return found


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    running = harness.start_server(tmp_path_factory.mktemp("server"), time_scale=1.0)
    yield running
    running.stop()


def rig_without_simulation(tmp_path: Path) -> tuple[Path, dict[str, str]]:
    """The shipped rig file, simulation off, every port a path in ``tmp_path`` that does not exist."""
    data = REPOSITORY / "acquisition" / "data"
    text = DEFAULT_RIG_FILE.read_text().replace("simulated = true", "simulated = false")
    text = text.replace('calibration = "', f'calibration = "{data}/')
    text = text.replace('table = "', f'table = "{data}/')
    ports = {}
    for name, (short, _, shipped_port) in INSTRUMENTS.items():
        ports[name] = str(tmp_path / f"ttyABSENT-{short}")
        assert shipped_port in text
        text = text.replace(shipped_port, f'"{ports[name]}"')
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path, ports


def rig_with_one_port_absent(server, tmp_path: Path, instrument: str) -> tuple[Path, str]:
    """The server's rig file with ``instrument``'s port replaced by an absent path."""
    absent = str(tmp_path / "ttyABSENT0")
    text = server.rig_file.read_text()
    port = server.ports[INSTRUMENTS[instrument][0]]
    assert text.count(f'"{port}"') == 1
    path = tmp_path / "rig.toml"
    path.write_text(text.replace(f'"{port}"', f'"{absent}"'))
    return path, absent


def test_rig_check_on_the_simulated_rig_is_all_ok_in_rows_and_in_json():
    text = run_ornitail("rig", "check", str(DEFAULT_RIG_FILE))
    assert text.returncode == 0, text.stdout + text.stderr
    found = rows(text.stdout)
    assert set(found) == set(INSTRUMENTS)
    for row in found.values():
        assert row.split()[1] == "ok", row  # route, then the result
    assert "model=ORNI-FAN" in found["tunnel fan"] and "fan_rpm=" in found["tunnel fan"]
    assert "pitch_deg=" in found["strut pitch actuator"]
    assert "gauge_0_v=" in found["acquisition board"]
    assert "serial ports found:" in text.stdout and "CAN channels found:" in text.stdout

    as_json = run_ornitail("rig", "check", str(DEFAULT_RIG_FILE), "--json")
    assert as_json.returncode == 0, as_json.stderr
    record = json.loads(as_json.stdout)
    assert record["ok"] is True and record["simulated"] is True
    assert isinstance(record["serial_ports"], list) and isinstance(record["can_channels"], list)
    checks = {check["instrument"]: check for check in record["instruments"]}
    assert set(checks) == set(INSTRUMENTS)
    assert all(check["status"] == "ok" and check["problem"] is None for check in checks.values())
    assert checks["tunnel fan"]["reading"]["fan_rpm"] == 0.0
    assert checks["flapping motor"]["reading"]["motor_rpm"] == 0.0
    assert set(checks["acquisition board"]["reading"]) >= {"gauge_0_v", "hall_v", "sample_rate_hz"}
    assert "ORNI-STRUT" in checks["strut pitch actuator"]["identity"]


def test_rig_check_with_absent_ports_is_one_row_per_instrument_naming_its_port_and_exit_3(
    tmp_path,
):
    rig, ports = rig_without_simulation(tmp_path)
    text = run_ornitail("rig", "check", str(rig))
    assert text.returncode == 3, text.stdout + text.stderr
    assert text.stderr == ""  # no traceback
    found = rows(text.stdout)
    assert set(found) == set(INSTRUMENTS)
    for name, row in found.items():
        key = INSTRUMENTS[name][1]
        assert row.startswith(ports[name]), row
        assert f"failed: cannot open port {ports[name]}: No such file or directory" in row
        assert key in row

    record = json.loads(run_ornitail("rig", "check", str(rig), "--json").stdout)
    assert record["ok"] is False and record["simulated"] is False
    for check in record["instruments"]:
        assert check["status"] == "failed" and check["reading"] == {}
        assert ports[check["instrument"]] in check["problem"]


def test_rig_check_finds_the_absent_port_among_present_ones_and_leaves_those_safe(server, tmp_path):
    rig, absent = rig_with_one_port_absent(server, tmp_path, "strut pitch actuator")
    before = server.control.state()
    completed = run_ornitail("rig", "check", str(rig), "--json")
    assert completed.returncode == 3, completed.stderr
    checks = {check["instrument"]: check for check in json.loads(completed.stdout)["instruments"]}
    assert checks["rig simulator"]["status"] == "ok"
    assert checks["strut pitch actuator"]["status"] == "failed"
    assert absent in checks["strut pitch actuator"]["problem"]
    for name in ("acquisition board", "tunnel fan", "flapping motor"):
        assert checks[name]["status"] == "ok", checks[name]
    after = server.control.state()
    for short in ("fan", "motor"):  # each was sent its safe-state command once more
        assert after[short]["safe_commands"] == before[short]["safe_commands"] + 1
        assert after[short]["safe"]
    assert after["strut"]["safe_commands"] == before["strut"]["safe_commands"]
    assert not after["daq"]["streaming"]


def test_a_simulator_server_that_is_gone_is_one_failed_row_naming_its_control_socket(
    server, tmp_path
):
    """The served rig's file with its control socket moved to a path nobody serves: the simulation's link is
    checked in a row of its own, which fails naming the rig file's field and the socket, exit 3."""
    absent = tmp_path / "absent-control.sock"
    text = server.rig_file.read_text()
    served = f'simulator_control = "{server.control.path}"'
    assert served in text
    rig = tmp_path / "rig.toml"
    rig.write_text(text.replace(served, f'simulator_control = "{absent}"'))
    completed = run_ornitail("rig", "check", str(rig), "--json")
    assert completed.returncode == 3, completed.stdout + completed.stderr
    checks = {check["instrument"]: check for check in json.loads(completed.stdout)["instruments"]}
    link = checks["rig simulator"]
    assert link["status"] == "failed" and link["rig_file_key"] == "[rig].simulator_control"
    assert link["route"] == str(absent) and str(absent) in link["problem"]


def test_rig_check_refuses_swapped_ports_without_commanding_the_wrong_instrument(server, tmp_path):
    text = server.rig_file.read_text()
    fan, motor = server.ports["fan"], server.ports["motor"]
    swapped = text.replace(f'"{fan}"', '"@FAN@"').replace(f'"{motor}"', f'"{fan}"')
    rig = tmp_path / "rig.toml"
    rig.write_text(swapped.replace('"@FAN@"', f'"{motor}"'))
    before = server.control.state()
    completed = run_ornitail("rig", "check", str(rig))
    assert completed.returncode == 3, completed.stdout + completed.stderr
    found = rows(completed.stdout)
    assert "answers as 'ORNI-MOTOR', not ORNI-FAN" in found["tunnel fan"]
    assert "answers as 'ORNI-FAN', not ORNI-MOTOR" in found["flapping motor"]
    after = server.control.state()
    for short in ("fan", "motor"):  # neither got the other's STOP / OFF
        assert after[short]["safe_commands"] == before[short]["safe_commands"]


def test_rig_check_of_a_port_held_by_another_program_exits_5(server):
    port = server.ports["fan"]
    connection, lock = open_serial_exclusively(port, 115200, "test holder")
    try:
        completed = run_ornitail("rig", "check", str(server.rig_file), "--json")
    finally:
        close_quietly(connection, lock)
    assert completed.returncode == 5, completed.stdout + completed.stderr
    checks = {check["instrument"]: check for check in json.loads(completed.stdout)["instruments"]}
    assert checks["tunnel fan"]["status"] == "in_use" and port in checks["tunnel fan"]["problem"]
    assert checks["flapping motor"]["status"] == "ok"


def test_sweep_with_an_absent_port_is_one_line_naming_it_exit_3_and_the_connected_rest_safe(
    server, tmp_path
):
    rig, absent = rig_with_one_port_absent(server, tmp_path, "strut pitch actuator")
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN)
    before = server.control.state()
    completed = run_ornitail("sweep", str(plan), "--rig", str(rig), "--data-root", str(tmp_path))
    assert completed.returncode == 3, completed.stderr
    (line,) = completed.stderr.splitlines()
    assert line.startswith(f"ornitail: error: strut pitch actuator: cannot open port {absent}: ")
    assert (
        "safe state confirmed: flapping motor, tunnel fan; not connected: strut pitch actuator"
        in line
    )
    after = server.control.state()
    for short in ("fan", "motor"):  # they had connected: they were made safe
        assert after[short]["safe_commands"] > before[short]["safe_commands"]


def test_sweep_with_no_port_present_says_no_actuator_was_connected(tmp_path):
    rig, ports = rig_without_simulation(tmp_path)
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN)
    completed = run_ornitail("sweep", str(plan), "--rig", str(rig), "--data-root", str(tmp_path))
    assert completed.returncode == 3, completed.stderr
    (line,) = completed.stderr.splitlines()
    assert f"tunnel fan: cannot open port {ports['tunnel fan']}" in line
    assert line.endswith("no actuator was connected, so none was brought to its safe state")
