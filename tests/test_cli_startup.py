"""``ornitail --help`` starts without the heavy libraries and still lists every command (structural, no timing)."""

import os
import subprocess
import sys

import pytest

from ornitail.app.cli import main

HEAVY = ("casadi", "matplotlib", "PySide6", "scipy", "pandas")
COMMANDS = {
    "calibration",
    "demo",
    "design",
    "export",
    "flight",
    "gap",
    "gui",
    "process",
    "rig",
    "runs",
    "sim",
    "sweep",
}
"""Every command of ``ornitail`` before its commands were loaded lazily."""


def run_python(code: str, *arguments: str, columns: int = 80) -> subprocess.CompletedProcess:
    """``code`` in a fresh interpreter (this venv's), offscreen, with a fixed help width."""
    environment = {**os.environ, "COLUMNS": str(columns), "QT_QPA_PLATFORM": "offscreen"}
    return subprocess.run(
        [sys.executable, "-c", code, *arguments],
        capture_output=True,
        text=True,
        env=environment,
        timeout=120,
        check=True,
    )


def test_importing_the_cli_imports_no_heavy_library():
    completed = run_python(
        f"import sys, ornitail.app.cli; print(sorted(set(sys.modules) & {set(HEAVY)!r}))"
    )
    assert completed.stdout.strip() == "[]"


@pytest.mark.parametrize(
    "arguments",
    [
        (),
        ("calibration",),
        ("gap",),
        ("rig",),
        ("sim",),
        ("process",),
        ("runs",),
        ("gui",),
        ("demo",),
        ("flight",),
    ],
)
def test_help_imports_no_heavy_library(arguments):
    completed = run_python(
        "import sys\n"
        "from ornitail.app.cli import main\n"
        "main(sys.argv[1:], prog_name='ornitail', standalone_mode=False)\n"
        f"print(sorted(set(sys.modules) & {set(HEAVY)!r}), file=sys.stderr)\n",
        *arguments,
        "--help",
    )
    assert "Usage: ornitail" in completed.stdout
    assert completed.stderr.strip() == "[]"


@pytest.mark.parametrize(
    ("group", "columns"),  # every width for the main listing; the groups' (the same code) at one
    [("", 60), ("", 80), ("", 200), ("design", 80), ("flight", 80)],
)
def test_help_lists_every_command_as_the_loaded_commands_describe_themselves(group, columns):
    arguments = [*group.split(), "--help"]
    lazy = run_python(
        "import sys; from ornitail.app.cli import main; main(sys.argv[1:], prog_name='ornitail')",
        *arguments,
        columns=columns,
    )
    loaded = run_python(
        "import sys\n"
        "from ornitail.app.cli import main\n"
        f"group = main.commands[{group!r}] if {group!r} else main\n"
        "for name in list(group.commands):\n"
        "    group.commands[name]\n"
        "main(sys.argv[1:], prog_name='ornitail')\n",
        *arguments,
        columns=columns,
    )
    assert lazy.stdout == loaded.stdout
    listed = lazy.stdout.split("Commands:\n", 1)[1].splitlines()
    names = {line.split()[0] for line in listed if line.startswith("  ") and line[2] != " "}
    subcommands = {
        "design": {"geometry", "pareto", "propose", "trends"},
        "flight": {"identify", "campaign"},
    }
    assert names == (COMMANDS if not group else subcommands[group])


def test_every_command_loads_and_flight_keeps_its_campaign_command():
    assert set(main.commands) == COMMANDS
    for name in COMMANDS:
        assert main.commands[name].name == name
    assert "campaign" in main.commands["flight"].commands
    design = main.commands["design"].commands
    assert {name: design[name].name for name in design} == {name: name for name in design}
