"""The pytest plugin serves a user's own test file (loaded with -p, time-scale option)."""

import subprocess
import sys
import textwrap
from importlib.metadata import entry_points


def test_user_sweep_script_test_runs_against_the_simulated_rig(tmp_path):
    (tmp_path / "test_user_sweep.py").write_text(
        textwrap.dedent(
            """
            import math

            def test_sweep(simulated_rig, simulated_time_scale):
                assert simulated_time_scale == 25.0
                assert simulated_rig.simulators.clock.time_scale == 25.0
                for pitch_deg in (10.0, 20.0):
                    simulated_rig.set_pitch(math.radians(pitch_deg))
                    simulated_rig.strut.wait_until_settled()
                    assert math.degrees(simulated_rig.read_pitch_rad()) == round(pitch_deg, 4)
            """
        )
    )
    plugin = "ornitail.simulated_instruments.pytest_plugin"
    # once the package declares the pytest11 entry point pytest loads the plugin by itself;
    # naming it again with -p would register it twice
    registered = any(point.value == plugin for point in entry_points(group="pytest11"))
    load_plugin = [] if registered else ["-p", plugin]
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            *load_plugin,
            "--ornitail-time-scale",
            "25",
            "-p",
            "no:cacheprovider",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "1 passed" in result.stdout
