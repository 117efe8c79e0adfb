"""Bad-input corpus: every ``ornitail`` command and subcommand against malformed input.

Each case is a command line plus the input files it names (made in a module-scoped workspace). A case
expects either documented valid input (exit 0) or a refusal: exit code 2, exactly one line on stderr
(``ornitail: error: <where>: <what>``) naming the file, field, option or value, nothing on stdout and
no traceback. Categories: non-UTF-8, binary, empty, too large, missing files, directories, FIFOs and
``/dev/zero`` for every file input; huge numbers (``1e308``, the literal ``1e309``), NaN and infinity
in numeric options and file fields; negative and zero counts and seeds; wrong types; unknown keys;
unwritable ``--out`` / ``--data-root``; hostile model expressions; a flight log timed in
milliseconds; singular calibrations; degenerate fits; plans beyond the rig (refused before the rig
is connected: no run directory, strut never homed); ``ornitail runs`` with broken run directories.

Cases run in-process through click's ``CliRunner`` (fast); a few run the console script in a real
process. Nothing here may hang: file inputs are refused by type and size before any read.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from ornitail.app.cli import main
from ornitail.core.input_files import MAX_INPUT_FILE_BYTES

REPOSITORY = Path(__file__).resolve().parents[1]
ORNITAIL = str(Path(sys.executable).parent / "ornitail")
CAL_FILE = REPOSITORY / "tests" / "data" / "calibration" / "FT8884.cal"
TWIN_OTTER_CSV = REPOSITORY / "tests" / "data" / "twin-otter" / "twin_otter_020213f1_019.csv"
RIG_FILE = REPOSITORY / "acquisition" / "data" / "simulated_rig.toml"
TUNNEL_TABLE = REPOSITORY / "acquisition" / "data" / "tunnel_table.csv"
HOTWIRE_POINTS = REPOSITORY / "calibration" / "data" / "example_hotwire_points.csv"
UNWRITABLE_PARENTS = ("/proc/ornitail-corpus", "{ws}/ok/a-file.txt")
"""Folders no one can create anything in: /proc, and a path below a regular file."""

GOOD_PLAN = """
[plan]
name = "corpus"
[configuration]
tail_id = "S3"
x_h_mm = 98
[steady_state]
theta_deg = 25.0
v_m_s = 0.8
f_hz = 13.5
[sweeps]
v_m_s = [-0.2, 0.2]
[protocol]
steady_state_repeats = 2
record_s = 0.6
[settle]
stable_for_s = 0.3
"""

GAP_BASELINE = """
[baseline]
kind = "simulator"
tail = "S3"
x_h_mm = 98
effects_off = ["added_mass"]
"""

CAMPAIGN_FILE = """
seed = 2018
[[configuration]]
tail = "S3"
x_h_mm = 98
simulate = 6
"""

USER_CSV = "tail,x_h_mm,quantity,value,sigma\nS3,98,Mq,-0.0009,0.0001\n"

BAD_CONTENT = {
    "nonutf8": b'name = "\xff\xfe\xfd"\n\x80\x81\x82 = 1\n',
    "binary": bytes(range(256)) * 8,
    "empty": b"",
}
FILE_KINDS = (*BAD_CONTENT, "toolarge", "missing", "directory", "fifo", "devzero")
TEXT_SUFFIXES = (".toml", ".csv", ".json")
"""Inputs read as UTF-8 text; .cal (XML), .mat and .parquet are binary formats of their own."""
PROBLEM_WORDS = {
    "nonutf8": "UTF-8",
    "binary": "",
    "empty": "",
    "toolarge": "larger than",
    "missing": "not found",
    "directory": "directory",
    "fifo": "not a regular file",
    "devzero": "not a regular file",
}


@dataclass(frozen=True)
class Case:
    """One command line; ``valid`` cases must exit 0, the others be refused in one line."""

    id: str
    category: str
    args: tuple[str, ...]
    valid: bool = False
    expect: tuple[str, ...] = ()
    stdout_expect: tuple[str, ...] = ()
    env: dict[str, str] = field(default_factory=dict)


CASES: list[Case] = []


def case(category: str, id_: str, *args: str, valid: bool = False, expect=(), **kwargs) -> None:
    """Add a case; ``expect`` holds substrings the error line (or stdout when valid) must contain."""
    expect = (expect,) if isinstance(expect, str) else tuple(expect)
    CASES.append(Case(f"{category}:{id_}", category, tuple(args), valid, expect, **kwargs))


def bad_path(kind: str, suffix: str) -> str:
    """The workspace path of a bad input file of ``kind`` with ``suffix``."""
    if kind == "devzero":
        return "/dev/zero"
    return f"{{ws}}/bad/{kind}{suffix}"


# -- 1. every file input against every kind of bad file ---------------------------------------
FILE_SLOTS: dict[str, tuple[str, tuple[str, ...]]] = {
    "sweep-plan": (".toml", ("sweep", "{f}", "--data-root", "{ws}/data")),
    "sweep-rig": (
        ".toml",
        ("sweep", "{ws}/ok/plan.toml", "--rig", "{f}", "--data-root", "{ws}/data"),
    ),
    "sweep-rig-calibration": (".cal", ("sweep", "{ws}/ok/plan.toml", "--rig", "{rig_cal}")),
    "sweep-rig-tunnel-table": (".csv", ("sweep", "{ws}/ok/plan.toml", "--rig", "{rig_table}")),
    "rig-check": (".toml", ("rig", "check", "{f}")),
    "rig-check-calibration": (".cal", ("rig", "check", "{rig_cal}")),
    "calibration-show": (".cal", ("calibration", "show", "--cal", "{f}")),
    "calibration-convert": (
        ".cal",
        ("calibration", "convert", "--cal", "{f}", "--volts", "0,0,0,0,0,0"),
    ),
    "hotwire-points": (".csv", ("calibration", "hotwire-fit", "--points", "{f}")),
    "tunnel-table": (".csv", ("calibration", "tunnel", "--table", "{f}", "--rpm", "500")),
    "identify-model": (".toml", ("flight", "identify", "--model", "{f}", "--data", "{twin}")),
    "identify-data-csv": (
        ".csv",
        ("flight", "identify", "--model", "twin_otter_short_period", "--data", "{f}"),
    ),
    "identify-data-parquet": (
        ".parquet",
        ("flight", "identify", "--model", "twin_otter_short_period", "--data", "{f}"),
    ),
    "identify-data-mat": (
        ".mat",
        ("flight", "identify", "--model", "twin_otter_short_period", "--data", "{f}"),
    ),
    "campaign-file": (".toml", ("flight", "campaign", "--campaign", "{f}", "--out", "{ws}/out")),
    "campaign-log": (
        ".csv",
        (
            "flight",
            "campaign",
            "--log",
            "S3@98={f}",
            "--mass-kg",
            "0.0234",
            "--iyy-kg-m2",
            "1.35e-4",
            "--out",
            "{ws}/out",
        ),
    ),
    "campaign-model": (
        ".toml",
        ("flight", "campaign", "--simulate", "S3@98", "--model", "{f}", "--out", "{ws}/out"),
    ),
    "trends-campaign-csv": (".csv", ("design", "trends", "--campaign", "{f}")),
    "trends-campaign-json": (".json", ("design", "trends", "--campaign", "{f}")),
    "trends-tunnel": (".csv", ("design", "trends", "--tunnel", "{f}")),
    "trends-user-csv": (".csv", ("design", "trends", "--user-csv", "{f}")),
    "propose-user-csv": (
        ".csv",
        ("design", "propose", "--theta-ss-deg", "25", "--user-csv", "{f}", "--out", "{ws}/out"),
    ),
    "pareto-tunnel": (".json", ("design", "pareto", "--tunnel", "{f}", "--out", "{ws}/out")),
    "gap-model": (".toml", ("gap", "diagnose", "--model", "{f}", "--data", "{twin}")),
    "gap-data": (
        ".csv",
        (
            "gap",
            "diagnose",
            "--model",
            "{ws}/ok/baseline.toml",
            "--data",
            "{f}",
            "--out",
            "{ws}/out",
        ),
    ),
    "export-csv": (".csv", ("export", "{f}", "--format", "mat", "--out", "{ws}/out")),
    "gui-rig": (".toml", ("gui", "--rig", "{f}")),
    "runs-plot-hotwire-law": (
        ".toml",
        ("runs", "--plot", "{ws}/runs/ok", "--out", "{ws}/out/plot", "--hotwire-law", "{f}"),
    ),
    "sim-tunnel-rig": (
        ".toml",
        ("sim", "tunnel", "--tail", "S3", "--theta-deg", "25", "--v-m-s", "0.8", "--f-hz", "13.5")
        + ("--rig", "{f}"),
    ),
}
for slot, (suffix, template) in FILE_SLOTS.items():
    for kind in FILE_KINDS:
        path = bad_path(kind, suffix)
        args = tuple(
            item.replace("{f}", path)
            .replace("{rig_cal}", f"{{ws}}/rigs/calibration-{kind}.toml")
            .replace("{rig_table}", f"{{ws}}/rigs/table-{kind}.toml")
            for item in template
        )
        named = "/dev/zero" if kind == "devzero" else f"{kind}{suffix}"
        problem = PROBLEM_WORDS[kind] if suffix in TEXT_SUFFIXES or kind not in BAD_CONTENT else ""
        case("file", f"{slot}-{kind}", *args, expect=(named, problem))

# -- 2. run directories: process reads run.json, journal.jsonl, samples.h5 ---------------------
RUN_DAMAGE = {
    "run-json-nonutf8": ("run.json", "UTF-8"),
    "run-json-binary": ("run.json", "run.json"),
    "run-json-empty": ("run.json", "run.json"),
    "run-json-1e309": ("run.json", "run.json"),
    "run-json-nan": ("run.json", "run.json"),
    "run-json-deep": ("run.json", "run.json"),
    "run-json-list": ("run.json", "run.json"),
    "run-json-fifo": ("run.json", "not a regular file"),
    "run-json-directory": ("run.json", "directory"),
    "run-json-toolarge": ("run.json", "larger than"),
    "run-json-missing": ("run.json", "run.json"),
    "journal-nonutf8": ("journal.jsonl", "UTF-8"),
    "journal-fifo": ("journal.jsonl", "not a regular file"),
    "journal-binary": ("journal.jsonl", "journal.jsonl"),
    "samples-missing": ("samples.h5", "samples.h5"),
    "samples-binary": ("samples.h5", "samples.h5"),
    "samples-fifo": ("samples.h5", "not a regular file"),
    "samples-directory": ("samples.h5", "directory"),
}
for damage, (named, problem) in RUN_DAMAGE.items():
    case(
        "run-directory",
        f"runs-plot-{damage}",
        "runs",
        "--plot",
        f"{{ws}}/runs/{damage}",
        "--out",
        "{ws}/out/plot",
        expect=(named, problem),
    )
for damage, (named, problem) in RUN_DAMAGE.items():
    case(
        "run-directory",
        f"process-{damage}",
        "process",
        f"{{ws}}/runs/{damage}",
        "--out",
        "{ws}/out/process",
        expect=(named, problem),
    )
for damage, (named, problem) in RUN_DAMAGE.items():
    case(
        "run-directory",
        f"export-{damage}",
        "export",
        f"{{ws}}/runs/{damage}",
        "--format",
        "netcdf",
        "--out",
        "{ws}/out/export",
        expect=(named, problem),
    )
case(
    "run-directory",
    "export-missing",
    "export",
    "{ws}/runs/none",
    "--format",
    "mat",
    "--out",
    "{ws}/out",
    expect="not found",
)
case(
    "run-directory",
    "export-a-toml-file",
    "export",
    "{ws}/ok/plan.toml",
    "--format",
    "mat",
    "--out",
    "{ws}/out",
    expect=("plan.toml", "not a run directory or a CSV table"),
)
case(
    "run-directory",
    "process-missing-directory",
    "process",
    "{ws}/runs/none",
    "--out",
    "{ws}/out",
    expect="not found",
)
case(
    "run-directory",
    "process-a-file",
    "process",
    "{ws}/ok/plan.toml",
    "--out",
    "{ws}/out",
    expect="plan.toml",
)
case("run-directory", "process-no-runs", "process", "--out", "{ws}/out", expect="run directories")
case(
    "run-directory",
    "process-plan-unknown",
    "process",
    "--plan",
    "nope",
    "--data-root",
    "{ws}/roots/ok",
    "--out",
    "{ws}/out",
    expect="nope",
)
case(
    "run-directory",
    "process-data-root-missing",
    "process",
    "--plan",
    "nope",
    "--data-root",
    "{ws}/none",
    "--out",
    "{ws}/out",
    expect="none",
)
case(
    "run-directory",
    "process-plan-and-runs",
    "process",
    "{ws}/runs/ok",
    "--plan",
    "x",
    "--out",
    "{ws}/out",
    expect="--plan",
)
for damage in (
    "run-json-nonutf8",
    "run-json-binary",
    "run-json-empty",
    "run-json-1e309",
    "run-json-fifo",
):
    case(
        "runs",
        f"runs-lists-{damage}-as-unreadable",
        "runs",
        "--data-root",
        f"{{ws}}/roots/{damage}",
        "--json",
        valid=True,
        expect=("unreadable",),
    )
case(
    "runs",
    "runs-samples-gone-not-completed",
    "runs",
    "--data-root",
    "{ws}/roots/samples-missing",
    "--json",
    valid=True,
    expect=('"exit_status": "damaged"', "samples.h5 is missing"),
)
case(
    "runs",
    "runs-ok",
    "runs",
    "--data-root",
    "{ws}/roots/ok",
    "--json",
    valid=True,
    expect=('"completed"',),
)
case(
    "runs",
    "runs-empty-root",
    "runs",
    "--data-root",
    "{ws}/data-empty",
    valid=True,
    expect=("no runs",),
)
case(
    "runs",
    "runs-status-bogus",
    "runs",
    "--data-root",
    "{ws}/roots/ok",
    "--status",
    "bogus",
    expect="bogus",
)
case(
    "runs",
    "runs-x-h-nan",
    "runs",
    "--data-root",
    "{ws}/roots/ok",
    "--x-h-mm",
    "nan",
    expect="--x-h-mm",
)
case(
    "runs",
    "runs-x-h-1e309",
    "runs",
    "--data-root",
    "{ws}/roots/ok",
    "--x-h-mm",
    "1e309",
    expect="--x-h-mm",
)
case(
    "runs",
    "runs-x-h-text",
    "runs",
    "--data-root",
    "{ws}/roots/ok",
    "--x-h-mm",
    "ninety",
    expect="--x-h-mm",
)
case(
    "runs",
    "runs-since-text",
    "runs",
    "--data-root",
    "{ws}/roots/ok",
    "--since",
    "yesterday",
    expect="--since",
)
case(
    "runs",
    "runs-since-huge-year",
    "runs",
    "--data-root",
    "{ws}/roots/ok",
    "--since",
    "99999-01-01",
    expect="--since",
)
case(
    "runs", "runs-data-root-file", "runs", "--data-root", "{ws}/ok/a-file.txt", expect="a-file.txt"
)
case(
    "runs",
    "runs-catalog-binary",
    "runs",
    "--data-root",
    "{ws}/roots/catalog-binary",
    expect="catalog",
)
case(
    "runs",
    "runs-catalog-fifo",
    "runs",
    "--data-root",
    "{ws}/roots/catalog-fifo",
    expect="not a regular file",
)
case(
    "runs",
    "runs-plot-without-the-channels-it-draws",
    "runs",
    "--plot",
    "{ws}/runs/ok",
    "--out",
    "{ws}/out/plot",
    expect="hotwire_bridge_v",
)
case(
    "runs",
    "runs-plot-unknown-run-id",
    "runs",
    "--data-root",
    "{ws}/roots/ok",
    "--plot",
    "no-such-run",
    "--out",
    "{ws}/out/plot",
    expect=("--plot", "no-such-run"),
)
case("runs", "runs-plot-empty", "runs", "--plot", "", "--out", "{ws}/out/plot", expect="--plot")
case("runs", "runs-plot-without-out", "runs", "--plot", "{ws}/runs/ok", expect="--out")
case("runs", "runs-out-without-plot", "runs", "--out", "{ws}/out/plot", expect="--out")
case(
    "runs",
    "runs-hotwire-law-without-plot",
    "runs",
    "--hotwire-law",
    "{ws}/ok/a-file.txt",
    expect="--hotwire-law",
)
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"runs-plot-out-{Path(parent).name}",
        "runs",
        "--plot",
        "{ws}/runs/ok",
        "--out",
        f"{parent}/plot",
        expect=parent.replace("{ws}/", ""),
    )
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"runs-data-root-{Path(parent).name}",
        "runs",
        "--data-root",
        f"{parent}/data",
        expect=parent.replace("{ws}/", ""),
    )

# -- 3. sweep plans: content, bounds, and plans the rig cannot do -------------------------------
PLAN_EDITS: dict[str, tuple[str, str, str]] = {
    # id: (old, new, named in the message)
    "theta-1e309": ("theta_deg = 25.0", "theta_deg = 1e309", "theta_deg"),
    "theta-nan": ("theta_deg = 25.0", "theta_deg = nan", "theta_deg"),
    "theta-inf": ("theta_deg = 25.0", "theta_deg = inf", "theta_deg"),
    "theta-1e308": ("theta_deg = 25.0", "theta_deg = 1e308", "theta_deg"),
    "theta-text": ("theta_deg = 25.0", 'theta_deg = "25"', "theta_deg"),
    "v-negative": ("v_m_s = 0.8", "v_m_s = -0.8", "v_m_s"),
    "v-1e308": ("v_m_s = 0.8", "v_m_s = 1e308", "v_m_s"),
    "f-zero": ("f_hz = 13.5", "f_hz = 0", "f_hz"),
    "f-negative": ("f_hz = 13.5", "f_hz = -13.5", "f_hz"),
    "f-1e309": ("f_hz = 13.5", "f_hz = 1e309", "f_hz"),
    "f-over-max-motor-rpm": ("f_hz = 13.5", "f_hz = 15.5", "max_motor_rpm"),
    "x-h-zero": ("x_h_mm = 98", "x_h_mm = 0", "x_h_mm"),
    "x-h-1e309": ("x_h_mm = 98", "x_h_mm = 1e309", "x_h_mm"),
    "x-h-bool": ("x_h_mm = 98", "x_h_mm = true", "x_h_mm"),
    "tail-empty": ('tail_id = "S3"', 'tail_id = ""', "tail_id"),
    "tail-number": ('tail_id = "S3"', "tail_id = 3", "tail_id"),
    "unknown-key": ("f_hz = 13.5", "f_hz = 13.5\nf_hzz = 1", "f_hzz"),
    "unknown-table": ("[settle]", "[settling]", "settling"),
    "record-1e300": ("record_s = 0.6", "record_s = 1e300", "record_s"),
    "record-700": ("record_s = 0.6", "record_s = 700", "record_s"),
    "record-nan": ("record_s = 0.6", "record_s = nan", "record_s"),
    "record-zero": ("record_s = 0.6", "record_s = 0", "record_s"),
    "record-short": ("record_s = 0.6", "record_s = 0.1", "record_s"),
    "repeats-1e9": (
        "steady_state_repeats = 2",
        "steady_state_repeats = 1000000000",
        "steady_state_repeats",
    ),
    "repeats-zero": (
        "steady_state_repeats = 2",
        "steady_state_repeats = 0",
        "steady_state_repeats",
    ),
    "repeats-negative": (
        "steady_state_repeats = 2",
        "steady_state_repeats = -1",
        "steady_state_repeats",
    ),
    "repeats-float": (
        "steady_state_repeats = 2",
        "steady_state_repeats = 2.5",
        "steady_state_repeats",
    ),
    "repeats-huge-int": (
        "steady_state_repeats = 2",
        "steady_state_repeats = 9223372036854775807",
        "steady_state_repeats",
    ),
    "sweep-repeats-1e9": (
        "record_s = 0.6",
        "record_s = 0.6\nsweep_repeats = 1000000000",
        "sweep_repeats",
    ),
    "steps-1e9": ("v_m_s = [-0.2, 0.2]", "v_m_s = { span = 0.2, steps = 1000000000 }", "steps"),
    "steps-zero": ("v_m_s = [-0.2, 0.2]", "v_m_s = { span = 0.2, steps = 0 }", "steps"),
    "span-nan": ("v_m_s = [-0.2, 0.2]", "v_m_s = { span = nan, steps = 2 }", "span"),
    "offset-zero": ("v_m_s = [-0.2, 0.2]", "v_m_s = [0.0, 0.2]", "v_m_s"),
    "offset-1e309": ("v_m_s = [-0.2, 0.2]", "v_m_s = [1e309]", "v_m_s"),
    "offset-text": ("v_m_s = [-0.2, 0.2]", 'v_m_s = ["fast"]', "v_m_s"),
    "offsets-20000": (
        "v_m_s = [-0.2, 0.2]",
        "v_m_s = [" + ", ".join(f"{0.2 + k * 1e-5:.5f}" for k in range(1, 20001)) + "]",
        "offsets",
    ),
    "offset-beyond-limit": ("v_m_s = [-0.2, 0.2]", "v_m_s = [-0.2, 9.0]", "limits"),
    "tailless-bogus": (
        "record_s = 0.6",
        'record_s = 0.6\ntailless_points = "some"',
        "tailless_points",
    ),
    "tares-text": ("record_s = 0.6", 'record_s = 0.6\nwind_off_tares = "yes"', "wind_off_tares"),
    "rate-1e308": ("record_s = 0.6", "record_s = 0.6\nsample_rate_hz = 1e308", "sample_rate_hz"),
    "rate-50": ("record_s = 0.6", "record_s = 0.6\nsample_rate_hz = 50", "sample_rate_hz"),
    "rate-over-link": (
        "record_s = 0.6",
        "record_s = 0.6\nsample_rate_hz = 20000",
        "sample_rate_hz",
    ),
    "rate-nan": ("record_s = 0.6", "record_s = 0.6\nsample_rate_hz = nan", "sample_rate_hz"),
    "stable-1e300": ("stable_for_s = 0.3", "stable_for_s = 1e300", "stable_for_s"),
    "stable-negative": ("stable_for_s = 0.3", "stable_for_s = -1", "stable_for_s"),
    "timeout-1e300": ("stable_for_s = 0.3", "stable_for_s = 0.3\ntimeout_s = 1e300", "timeout_s"),
    "timeout-zero": ("stable_for_s = 0.3", "stable_for_s = 0.3\ntimeout_s = 0", "timeout_s"),
    "tolerance-nan": (
        "stable_for_s = 0.3",
        "stable_for_s = 0.3\npitch_tolerance_deg = nan",
        "pitch_tolerance_deg",
    ),
    "duration-over-24h": ("record_s = 0.6", "record_s = 600.0\nsweep_repeats = 100", "24 h"),
    "points-over-10000": (
        "v_m_s = [-0.2, 0.2]\n[protocol]",
        "v_m_s = { span = 0.2, steps = 1000 }\n[protocol]\nsweep_repeats = 6",
        "10000",
    ),
    "not-toml": ("[plan]", "[plan", "TOML"),
    "deep-array": ("[plan]", "x = " + "[" * 5000 + "]" * 5000 + "\n[plan]", "TOML"),
    "plan-name-table": ('name = "corpus"', "name = { a = 1 }", "name"),
}
SLOW_MOTOR = ("max_motor_rpm = 21000.0", "max_motor_rpm = 18000.0")
"""A rig whose motor cannot reach the 16 Hz frequency limit: 18000 rpm / 60 / 21.33 = 14.06 Hz."""
for edit_id, (_, _, named) in PLAN_EDITS.items():
    case(
        "sweep-plan",
        edit_id,
        "sweep",
        f"{{ws}}/plans/{edit_id}.toml",
        "--rig",
        "{ws}/rigs/slow-motor.toml",
        "--data-root",
        "{ws}/data",
        expect=named,
    )

RIG_EDITS: dict[str, tuple[str, str, str]] = {
    "baud-1e11": ("baud = 4000000", "baud = 100000000000", "baud"),
    "baud-zero": ("baud = 4000000", "baud = 0", "baud"),
    "baud-float": ("baud = 4000000", "baud = 4e6", "baud"),
    "fan-baud-1e11": (
        '[fan]\nport = "/dev/ttyUSB0"\nbaud = 115200',
        '[fan]\nport = "/dev/ttyUSB0"\nbaud = 100000000000',
        "baud",
    ),
    "rate-1e308": ("sample_rate_hz = 10000.0", "sample_rate_hz = 1e308", "sample_rate_hz"),
    "rate-nan": ("sample_rate_hz = 10000.0", "sample_rate_hz = nan", "sample_rate_hz"),
    "gear-nan": ("gear_ratio = 21.33", "gear_ratio = nan", "gear_ratio"),
    "gear-zero": ("gear_ratio = 21.33", "gear_ratio = 0", "gear_ratio"),
    "gear-1e309": ("gear_ratio = 21.33", "gear_ratio = 1e309", "gear_ratio"),
    "max-rpm-1e309": ("max_motor_rpm = 21000.0", "max_motor_rpm = 1e309", "max_motor_rpm"),
    "max-rpm-negative": ("max_motor_rpm = 21000.0", "max_motor_rpm = -1.0", "max_motor_rpm"),
    "pitch-nan": ("pitch_deg = [-10.0, 45.0]", "pitch_deg = [nan, 45.0]", "pitch_deg"),
    "pitch-reversed": ("pitch_deg = [-10.0, 45.0]", "pitch_deg = [45.0, -10.0]", "pitch_deg"),
    "pitch-1e309": ("pitch_deg = [-10.0, 45.0]", "pitch_deg = [-10.0, 1e309]", "pitch_deg"),
    "seed-negative": ("seed = 0", "seed = -1", "seed"),
    "time-scale-nan": ("time_scale = 1.0 ", "time_scale = nan ", "time_scale"),
    "time-scale-zero": ("time_scale = 1.0 ", "time_scale = 0.0 ", "time_scale"),
    "unknown-key": ("gear_ratio = 21.33", "gear_ratio = 21.33\ngear_ration = 2", "gear_ration"),
    "unknown-section": ("[limits]", "[limitz]", "limitz"),
    "route-bogus": ('route = "serial_daq"', 'route = "usb"', "route"),
    "route-can": ('route = "serial_daq"', 'route = "can"', "route"),
    "tool-transform-nan": (
        "tool_transform_mm_deg = [-12.0, 0.0, -5.7, 180.0, 0.0, 0.0]",
        "tool_transform_mm_deg = [nan, 0.0, -5.7, 180.0, 0.0, 0.0]",
        "tool_transform_mm_deg",
    ),
    "tool-transform-short": (
        "tool_transform_mm_deg = [-12.0, 0.0, -5.7, 180.0, 0.0, 0.0]",
        "tool_transform_mm_deg = [1.0]",
        "tool_transform_mm_deg",
    ),
    "base-id-big": ("base_id = 0x20", "base_id = 0x2000", "base_id"),
    "can-bit-rate-1e11": ("bit_rate = 1000000", "bit_rate = 100000000000", "bit_rate"),
}
for edit_id, (_, _, named) in RIG_EDITS.items():
    case(
        "rig-file",
        edit_id,
        "sweep",
        "{ws}/ok/plan.toml",
        "--rig",
        f"{{ws}}/rigs/{edit_id}.toml",
        "--data-root",
        "{ws}/data",
        expect=named,
    )
for value in ("nan", "inf", "0", "-1", "1e309", "fast"):
    case(
        "sweep-options",
        f"time-scale-{value}",
        "sweep",
        "{ws}/ok/plan.toml",
        "--time-scale",
        value,
        "--data-root",
        "{ws}/data",
        expect="time",
    )
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"sweep-data-root-{Path(parent).name}",
        "sweep",
        "{ws}/ok/plan.toml",
        "--data-root",
        f"{parent}/data",
        expect=parent.replace("{ws}/", ""),
    )
case("sweep-options", "plan-missing-argument", "sweep", expect="PLAN")
case("rig-options", "rig-missing-argument", "rig", "check", expect="RIG")
case(
    "rig-options", "unknown-option", "rig", "check", "{ws}/ok/rig.toml", "--bogus", expect="--bogus"
)
case("sweep-options", "unknown-option", "sweep", "{ws}/ok/plan.toml", "--bogus", expect="--bogus")

# -- 4. calibration -----------------------------------------------------------------------------
CAL_VARIANTS = (
    "zero-matrix",
    "singular-matrix",
    "nan-value",
    "1e309-value",
    "1e308-value",
    "missing-axis",
    "deep-xml",
    "entity-bomb",
    "five-values",
)
for name in CAL_VARIANTS:
    case(
        "calibration-file",
        f"show-{name}",
        "calibration",
        "show",
        "--cal",
        f"{{ws}}/cals/{name}.cal",
        expect=(f"{name}.cal", "singular" if "matrix" in name else ""),
    )
    case(
        "calibration-file",
        f"convert-{name}",
        "calibration",
        "convert",
        "--cal",
        f"{{ws}}/cals/{name}.cal",
        "--volts",
        "0,0,0,0,0,0",
        expect=(f"{name}.cal", "singular" if "matrix" in name else ""),
    )
case(
    "calibration-file",
    "show-ok",
    "calibration",
    "show",
    "--cal",
    str(CAL_FILE),
    "--json",
    valid=True,
)
case(
    "calibration-file",
    "convert-ok",
    "calibration",
    "convert",
    "--cal",
    str(CAL_FILE),
    "--volts",
    "0.1,0,0,0,0,0",
    "--json",
    valid=True,
)
CONVERT_OPTIONS = {
    "volts-1e308": ("--volts", "1e308,0,0,0,0,0"),
    "volts-1e309": ("--volts", "1e309,0,0,0,0,0"),
    "volts-nan": ("--volts", "nan,0,0,0,0,0"),
    "volts-five": ("--volts", "0,0,0,0,0"),
    "volts-text": ("--volts", "a,b,c,d,e,f"),
    "volts-empty": ("--volts", ""),
    "volts-long": ("--volts", ",".join(["0"] * 100000)),
    "bias-inf": ("--bias", "inf,0,0,0,0,0"),
    "bias-1e308": ("--bias", "-1e308,0,0,0,0,0"),
    "tool-nan": ("--tool-transform", "nan,0,0,0,0,0"),
    "tool-1e308": ("--tool-transform", "1e308,0,0,0,0,0"),
    "tool-angle-1e308": ("--tool-transform", "0,0,0,1e308,0,0"),
    "tool-four": ("--tool-transform", "0,0,0,0"),
}
for name, (option, value) in CONVERT_OPTIONS.items():
    extra = () if option == "--volts" else ("--volts", "0.1,0,0,0,0,0")
    case(
        "calibration-options",
        f"convert-{name}",
        "calibration",
        "convert",
        "--cal",
        str(CAL_FILE),
        option,
        value,
        *extra,
        expect=option,
    )
case(
    "calibration-options",
    "convert-missing-cal",
    "calibration",
    "convert",
    "--volts",
    "0,0,0,0,0,0",
    expect="--cal",
)
HOTWIRE_FILES = {
    "identical-points": "velocity_m_s,voltage_v,temperature_c\n" + "1.0,1.6,20.0\n" * 6,
    "identical-velocities": "velocity_m_s,voltage_v,temperature_c\n"
    + "".join(f"1.0,{1.5 + k / 100},20.0\n" for k in range(6)),
    "two-points": "velocity_m_s,voltage_v,temperature_c\n1.0,1.6,20\n2.0,1.7,20\n",
    "nan-voltage": "velocity_m_s,voltage_v,temperature_c\n1.0,nan,20\n2.0,1.7,20\n3,1.8,20\n4,1.9,20\n",
    "1e309-velocity": "velocity_m_s,voltage_v,temperature_c\n1e309,1.6,20\n2.0,1.7,20\n3,1.8,20\n4,1.9,20\n",
    "1e308-velocity": "velocity_m_s,voltage_v,temperature_c\n1e308,1.6,20\n2.0,1.7,20\n3,1.8,20\n4,1.9,20\n",
    "negative-velocity": "velocity_m_s,voltage_v,temperature_c\n-1,1.6,20\n2.0,1.7,20\n3,1.8,20\n4,1.9,20\n",
    "zero-voltage": "velocity_m_s,voltage_v,temperature_c\n1,0,20\n2.0,0,20\n3,0,20\n4,0,20\n",
    "missing-column": "velocity_m_s,voltage_v\n1,1.6\n2,1.7\n3,1.8\n",
    "text-cell": "velocity_m_s,voltage_v,temperature_c\n1,one,20\n2.0,1.7,20\n3,1.8,20\n",
    "temperature-at-wire-250": "velocity_m_s,voltage_v,temperature_c\n"
    + "".join(f"{k},{1.5 + k / 10},250\n" for k in range(1, 7)),
    "temperature-below-zero-kelvin": "velocity_m_s,voltage_v,temperature_c\n"
    + "".join(f"{k},{1.5 + k / 10},-300\n" for k in range(1, 7)),
    "ragged-row": "velocity_m_s,voltage_v,temperature_c\n1,1.6,20,5\n",
}
for name in HOTWIRE_FILES:
    named = "hotter than the flow" if name == "temperature-at-wire-250" else f"{name}.csv"
    case(
        "hotwire",
        f"fit-{name}",
        "calibration",
        "hotwire-fit",
        "--points",
        f"{{ws}}/hotwire/{name}.csv",
        expect=named,
    )
case(
    "hotwire",
    "fit-polynomial-identical",
    "calibration",
    "hotwire-fit",
    "--points",
    "{ws}/hotwire/identical-points.csv",
    "--law",
    "polynomial",
    expect="identical-points.csv",
)
for option, value in (
    ("--order", "0"),
    ("--order", "-1"),
    ("--order", "50"),
    ("--order", "four"),
    ("--wire-temperature-c", "nan"),
    ("--wire-temperature-c", "1e308"),
    ("--wire-temperature-c", "-300"),
    ("--wire-temperature-c", "20"),
    ("--reference-temperature-c", "inf"),
    ("--reference-temperature-c", "-1e309"),
    ("--reference-temperature-c", "-300"),
    ("--law", "cubic"),
):
    law = ("--law", "polynomial") if option == "--order" else ()
    named = "order" if option == "--order" and value != "four" else option
    case(
        "hotwire",
        f"option{option}-{value}",
        "calibration",
        "hotwire-fit",
        "--points",
        str(HOTWIRE_POINTS),
        *law,
        option,
        value,
        expect=named,
    )
case(
    "hotwire",
    "out-suffix",
    "calibration",
    "hotwire-fit",
    "--points",
    str(HOTWIRE_POINTS),
    "--out",
    "{ws}/out/law.txt",
    expect="--out",
)
case(
    "hotwire",
    "out-directory",
    "calibration",
    "hotwire-fit",
    "--points",
    str(HOTWIRE_POINTS),
    "--out",
    "{ws}/ok/dir.toml",
    expect="dir.toml",
)
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"hotwire-out-{Path(parent).name}",
        "calibration",
        "hotwire-fit",
        "--points",
        str(HOTWIRE_POINTS),
        "--out",
        f"{parent}/law.toml",
        expect=parent.replace("{ws}/", ""),
    )
case(
    "hotwire",
    "fit-ok",
    "calibration",
    "hotwire-fit",
    "--points",
    str(HOTWIRE_POINTS),
    "--json",
    valid=True,
)
TUNNEL_TABLES = {
    "decreasing": "fan_rpm,velocity_m_s\n0,0\n500,1\n400,2\n",
    "one-row": "fan_rpm,velocity_m_s\n0,0\n",
    "nan": "fan_rpm,velocity_m_s\n0,0\n500,nan\n1000,2\n",
    "1e309": "fan_rpm,velocity_m_s\n0,0\n1e309,1\n",
    "constant": "fan_rpm,velocity_m_s\n0,0\n500,0\n1000,0\n",
}
for name in TUNNEL_TABLES:
    case(
        "tunnel-table",
        f"table-{name}",
        "calibration",
        "tunnel",
        "--table",
        f"{{ws}}/tables/{name}.csv",
        "--rpm",
        "500",
        expect=f"{name}.csv",
    )
for option, value in (
    ("--rpm", "nan"),
    ("--rpm", "-1"),
    ("--rpm", "1e308"),
    ("--rpm", "1e309"),
    ("--rpm", "fast"),
    ("--velocity-m-s", "nan"),
    ("--velocity-m-s", "-1"),
    ("--velocity-m-s", "1e308"),
    ("--velocity-m-s", "-inf"),
):
    case(
        "tunnel-table",
        f"option{option}-{value}",
        "calibration",
        "tunnel",
        "--table",
        str(TUNNEL_TABLE),
        option,
        value,
        expect=option,
    )
case(
    "tunnel-table", "neither", "calibration", "tunnel", "--table", str(TUNNEL_TABLE), expect="--rpm"
)
case(
    "tunnel-table",
    "both",
    "calibration",
    "tunnel",
    "--table",
    str(TUNNEL_TABLE),
    "--rpm",
    "1",
    "--velocity-m-s",
    "1",
    expect="--rpm",
)
case(
    "tunnel-table",
    "ok",
    "calibration",
    "tunnel",
    "--table",
    str(TUNNEL_TABLE),
    "--rpm",
    "500",
    valid=True,
)

# -- 5. flight identify: model files, expressions, logs ----------------------------------------
DEEP = "(" * 1000 + "Ma" + ")" * 1000
LONG = "+".join(["Ma"] * 34000)
MODEL_EDITS = {
    "expr-deep": ('["Ma", "Mq"]', f'["{DEEP}", "Mq"]', "A"),
    "expr-long": ('["Ma", "Mq"]', f'["{LONG}", "Mq"]', "A"),
    "expr-power-tower": ('["Ma", "Mq"]', '["9**9**9**9", "Mq"]', "9**9**9**9"),
    "expr-divide-by-zero": ('["Ma", "Mq"]', '["1/0", "Mq"]', "1/0"),
    "expr-divide-by-zero-parameter": ('["Ma", "Mq"]', '["Ma/Zq", "Mq"]', "Ma/Zq"),
    "expr-exp-overflow": ('["Ma", "Mq"]', '["exp(1000)", "Mq"]', "exp(1000)"),
    "expr-sqrt-negative": ('["Ma", "Mq"]', '["sqrt(-1)", "Mq"]', "sqrt(-1)"),
    "expr-1e309": ('["Ma", "Mq"]', '["1e309", "Mq"]', "A"),
    "expr-literal-1e309": ('["Ma", "Mq"]', '[1e309, "Mq"]', "A"),
    "expr-nan": ('["Ma", "Mq"]', '[nan, "Mq"]', "A"),
    "expr-dunder": ('["Ma", "Mq"]', '["__import__", "Mq"]', "__import__"),
    "expr-attribute": ('["Ma", "Mq"]', '["Ma.real", "Mq"]', "Ma.real"),
    "expr-lambda": ('["Ma", "Mq"]', '["lambda: 1", "Mq"]', "lambda"),
    "expr-unknown-name": ('["Ma", "Mq"]', '["Mz", "Mq"]', "Mz"),
    "expr-empty": ('["Ma", "Mq"]', '["", "Mq"]', "A"),
    "start-1e309": ("Ma = { start = -5.0", "Ma = { start = 1e309", "Ma"),
    "start-nan": ("Ma = { start = -5.0", "Ma = { start = nan", "Ma"),
    "bounds-reversed": ("lower = -50.0, upper = 10.0", "lower = 10.0, upper = -50.0", "Mq"),
    "scale-1e309": (
        'column = "alpha_deg", scale = 0.017453292519943295',
        'column = "alpha_deg", scale = 1e309',
        "alpha",
    ),
    "time-scale-zero": (
        'time_column = "time_sec"',
        'time_column = "time_sec"\ntime_scale = 0',
        "time_scale",
    ),
    "time-scale-nan": (
        'time_column = "time_sec"',
        'time_column = "time_sec"\ntime_scale = nan',
        "time_scale",
    ),
    "unknown-key": (
        'time_column = "time_sec"',
        'time_column = "time_sec"\ntime_unit = "ms"',
        "time_unit",
    ),
    "unknown-table": ("[data]", "[dataz]", "dataz"),
    "states-text": ('states = ["alpha", "q"]', 'states = "alpha q"', "states"),
    "matrix-ragged": ('["Ma", "Mq"],', '["Ma"],', "A"),
    "missing-column": (
        'column = "alpha_deg", scale',
        'column = "alpha_degrees", scale',
        "alpha_degrees",
    ),
    "input-hold-bogus": ('input_hold = "first_order"', 'input_hold = "cubic"', "input_hold"),
}
for name, (_, _, named) in MODEL_EDITS.items():
    case(
        "model-file",
        name,
        "flight",
        "identify",
        "--model",
        f"{{ws}}/models/{name}.toml",
        "--data",
        "{twin}",
        expect=named,
    )
case(
    "model-file",
    "preset-unknown",
    "flight",
    "identify",
    "--model",
    "no_such_preset",
    "--data",
    "{twin}",
    expect="no_such_preset",
)
case(
    "model-file",
    "preset-empty",
    "flight",
    "identify",
    "--model",
    "",
    "--data",
    "{twin}",
    expect="model",
)
FLIGHT_LOGS = {
    "time-in-ms": "time in milliseconds",
    "time-in-ms-1000x": "time_scale",
    "nan-cell": "alpha_deg",
    "inf-cell": "alpha_deg",
    "1e309-cell": "alpha_deg",
    "text-column": "alpha_deg",
    "header-only": "header-only",
    "time-backwards": "time_sec",
    "time-constant": "time_sec",
    "ten-rows": "ten-rows",
    "ragged": "ragged",
    "time-1e308": "time_sec",
}
for name, named in FLIGHT_LOGS.items():
    case(
        "flight-log",
        name,
        "flight",
        "identify",
        "--model",
        "twin_otter_short_period",
        "--data",
        f"{{ws}}/logs/{name}.csv",
        expect=named if name != "time-in-ms" else "time_sec",
    )
case(
    "flight-log",
    "unknown-suffix",
    "flight",
    "identify",
    "--model",
    "twin_otter_short_period",
    "--data",
    "{ws}/ok/plan.toml",
    expect="plan.toml",
)
case(
    "flight-log",
    "mat-text",
    "flight",
    "identify",
    "--model",
    "twin_otter_short_period",
    "--data",
    "{ws}/logs/text.mat",
    expect="text.mat",
)
case(
    "flight-log",
    "parquet-text",
    "flight",
    "identify",
    "--model",
    "twin_otter_short_period",
    "--data",
    "{ws}/logs/text.parquet",
    expect="text.parquet",
)
for option, value in (("--method", "magic"), ("--input-hold", "cubic")):
    case(
        "flight-options",
        f"identify{option}",
        "flight",
        "identify",
        "--model",
        "twin_otter_short_period",
        "--data",
        "{twin}",
        option,
        value,
        expect=option,
    )
case(
    "flight-options",
    "identify-missing-data",
    "flight",
    "identify",
    "--model",
    "twin_otter_short_period",
    expect="--data",
)
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"identify-out-{Path(parent).name}",
        "flight",
        "identify",
        "--model",
        "twin_otter_short_period",
        "--data",
        "{twin}",
        "--out",
        f"{parent}/report",
        expect=parent.replace("{ws}/", ""),
    )

# -- 6. flight campaign -------------------------------------------------------------------------
CAMPAIGN_EDITS = {
    "seed-negative": ("seed = 2018", "seed = -1", "seed"),
    "seed-1e309": ("seed = 2018", "seed = 1e309", "seed"),
    "seed-huge": ("seed = 2018", "seed = 9223372036854775807", "seed"),
    "x-h-1e309": ("x_h_mm = 98", "x_h_mm = 1e309", "x_h_mm"),
    "x-h-nan": ("x_h_mm = 98", "x_h_mm = nan", "x_h_mm"),
    "x-h-negative": ("x_h_mm = 98", "x_h_mm = -98", "x_h_mm"),
    "simulate-zero": ("simulate = 6", "simulate = 0", "simulate"),
    "simulate-1e9": ("simulate = 6", "simulate = 1000000000", "simulate"),
    "simulate-text": ("simulate = 6", 'simulate = "six"', "simulate"),
    "tail-unknown": ('tail = "S3"', 'tail = "Q9"', "Q9"),
    "unknown-key": ("seed = 2018", "seed = 2018\nseeds = 1", "seeds"),
    "configuration-missing": (
        '[[configuration]]\ntail = "S3"\nx_h_mm = 98\nsimulate = 6',
        "",
        "configuration",
    ),
    "log-missing-file": (
        "simulate = 6",
        'mass_kg = 0.0234\niyy_kg_m2 = 1.35e-4\nlog = ["nothere.csv"]',
        "nothere.csv",
    ),
    "log-devzero": (
        "simulate = 6",
        'mass_kg = 0.0234\niyy_kg_m2 = 1.35e-4\nlog = ["/dev/zero"]',
        "/dev/zero",
    ),
    "mass-nan": ("simulate = 6", 'mass_kg = nan\niyy_kg_m2 = 1.35e-4\nlog = ["x.csv"]', "mass_kg"),
    "time-range-reversed": (
        "simulate = 6",
        'mass_kg = 0.0234\niyy_kg_m2 = 1.35e-4\nlog = [{ path = "x.csv", time_range_s = [10.0, 1.0] }]',
        "time_range_s",
    ),
    "selection-bogus": ("seed = 2018", 'seed = 2018\nselection_rule = "best"', "selection_rule"),
}
for name, (_, _, named) in CAMPAIGN_EDITS.items():
    case(
        "campaign-file",
        name,
        "flight",
        "campaign",
        "--campaign",
        f"{{ws}}/campaigns/{name}.toml",
        "--out",
        "{ws}/out/campaign",
        expect=named,
    )
CAMPAIGN_OPTIONS = {
    "simulate-no-at": (("--simulate", "S3"), "--simulate"),
    "simulate-x-h-nan": (("--simulate", "S3@nan"), "--simulate"),
    "simulate-x-h-1e309": (("--simulate", "S3@1e309"), "--simulate"),
    "simulate-x-h-negative": (("--simulate", "S3@-98"), "--simulate"),
    "simulate-unknown-tail": (("--simulate", "Q9@98"), "Q9"),
    "log-no-equals": (("--log", "S3@98"), "--log"),
    "log-no-at": (("--log", "S3={twin}", "--mass-kg", "0.02", "--iyy-kg-m2", "1e-4"), "--log"),
    "mass-nan": (("--simulate", "S3@98", "--mass-kg", "nan"), "--mass-kg"),
    "mass-negative": (("--simulate", "S3@98", "--mass-kg", "-1"), "--mass-kg"),
    "iyy-1e309": (("--simulate", "S3@98", "--iyy-kg-m2", "1e309"), "--iyy-kg-m2"),
    "manoeuvres-zero": (("--simulate", "S3@98", "--manoeuvres", "0"), "--manoeuvres"),
    "manoeuvres-negative": (("--simulate", "S3@98", "--manoeuvres", "-5"), "--manoeuvres"),
    "manoeuvres-1e9": (("--simulate", "S3@98", "--manoeuvres", "1000000000"), "--manoeuvres"),
    "seed-negative": (("--simulate", "S3@98", "--seed", "-1"), "--seed"),
    "seed-text": (("--simulate", "S3@98", "--seed", "abc"), "--seed"),
    "seed-huge": (("--simulate", "S3@98", "--seed", "99999999999999999999999999"), "--seed"),
    "nothing": ((), "campaign"),
    "selection-rule-bogus": (
        ("--simulate", "S3@98", "--selection-rule", "best"),
        "--selection-rule",
    ),
    "model-unknown": (("--simulate", "S3@98", "--model", "no_such_model"), "no_such_model"),
}
for name, (arguments, named) in CAMPAIGN_OPTIONS.items():
    case(
        "campaign-options",
        name,
        "flight",
        "campaign",
        *arguments,
        "--out",
        "{ws}/out/campaign",
        expect=named,
    )
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"campaign-out-{Path(parent).name}",
        "flight",
        "campaign",
        "--simulate",
        "S3@98",
        "--out",
        f"{parent}/campaign",
        expect=parent.replace("{ws}/", ""),
    )

# -- 7. design -------------------------------------------------------------------------------------
NUMBER_VALUES = ("nan", "inf", "-inf", "1e308", "1e309", "-1", "0", "abc")
GEOMETRY = {"--b": "203", "--b-le": "105", "--c-r": "66", "--c-t": "35"}
for option in GEOMETRY:
    for value in NUMBER_VALUES:
        arguments = [
            item
            for key, good in GEOMETRY.items()
            for item in (key, value if key == option else good)
        ]
        case(
            "design-geometry",
            f"{option}-{value}",
            "design",
            "geometry",
            *arguments,
            expect=option if value != "abc" else option,
        )
case(
    "design-geometry",
    "ok",
    "design",
    "geometry",
    "--b",
    "203",
    "--b-le",
    "105",
    "--c-r",
    "66",
    "--c-t",
    "35",
    "--json",
    valid=True,
)
case(
    "design-geometry",
    "ok-elliptical",
    "design",
    "geometry",
    "--b",
    "203",
    "--c-r",
    "66",
    "--c-t",
    "35",
    valid=True,
)
case(
    "design-geometry", "missing-b", "design", "geometry", "--c-r", "66", "--c-t", "35", expect="--b"
)
PROPOSE_OPTIONS = {
    "--theta-ss-deg": ("nan", "inf", "1e308", "1e309", "abc"),
    "--theta-tol-deg": ("-1", "nan", "1e309"),
    "--v-ss-m-s": ("-1", "0", "nan", "1e308"),
    "--f-ss-hz": ("0", "-1", "nan", "1e309"),
    "--zeta": ("nan", "-1", "1e308"),
    "--omega-rad-s": ("-1", "nan", "1e309"),
    "--robust-k": ("nan", "-1", "1e308"),
    "--x-h-mm": ("nan", "-1", "0", "1e308"),
    "--starts": ("0", "-1", "1000000000", "many"),
}
for option, values in PROPOSE_OPTIONS.items():
    for value in values:
        base = () if option == "--theta-ss-deg" else ("--theta-ss-deg", "25")
        case(
            "design-propose",
            f"{option}-{value}",
            "design",
            "propose",
            *base,
            option,
            value,
            "--out",
            "{ws}/out/proposal",
            expect=option,
        )
case(
    "design-propose",
    "no-target",
    "design",
    "propose",
    "--out",
    "{ws}/out/proposal",
    expect="target",
)
case(
    "design-propose",
    "objective-bogus",
    "design",
    "propose",
    "--objective",
    "max-fun",
    expect="--objective",
)
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"propose-out-{Path(parent).name}",
        "design",
        "propose",
        "--theta-ss-deg",
        "25",
        "--out",
        f"{parent}/proposal",
        expect=parent.replace("{ws}/", ""),
    )
PARETO_OPTIONS = {
    "--points": ("0", "-1", "1000000000"),
    "--x-h-mm": ("nan", "-1", "1e309"),
    "--starts": ("0", "-1"),
    "--theta-ss-deg": ("nan", "1e308"),
    "--theta-tol-deg": ("-1", "inf"),
}
for option, values in PARETO_OPTIONS.items():
    for value in values:
        case(
            "design-pareto",
            f"{option}-{value}",
            "design",
            "pareto",
            option,
            value,
            "--out",
            "{ws}/out/pareto",
            expect=option,
        )
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"pareto-out-{Path(parent).name}",
        "design",
        "pareto",
        "--out",
        f"{parent}/pareto",
        expect=parent.replace("{ws}/", ""),
    )
PREDICT = {
    "--predict-b": "203",
    "--predict-b-le": "105",
    "--predict-c-r": "66",
    "--predict-c-t": "35",
    "--predict-x-h-mm": "98",
}
for option in PREDICT:
    for value in ("nan", "1e309", "-1", "1e308"):
        arguments = [
            item
            for key, good in PREDICT.items()
            for item in (key, value if key == option else good)
        ]
        case(
            "design-trends",
            f"{option}-{value}",
            "design",
            "trends",
            "--study",
            *arguments,
            expect=option,
        )
case(
    "design-trends",
    "predict-partial",
    "design",
    "trends",
    "--study",
    "--predict-b",
    "203",
    expect="--predict",
)
case("design-trends", "no-source", "design", "trends", expect="--study")
case("design-trends", "basis-bogus", "design", "trends", "--basis", "cubic", expect="--basis")
TREND_FILES = {
    "user-nan": ("user", "tail,x_h_mm,quantity,value,sigma\nS3,98,Mq,nan,0.0001\n", "value"),
    "user-1e309": ("user", "tail,x_h_mm,quantity,value,sigma\nS3,98,Mq,1e309,0.0001\n", "value"),
    "user-sigma-zero": ("user", "tail,x_h_mm,quantity,value,sigma\nS3,98,Mq,-0.0009,0\n", "sigma"),
    "user-x-h-1e308": (
        "user",
        "tail,x_h_mm,quantity,value,sigma\nS3,1e308,Mq,-0.0009,0.0001\n",
        "x_h_mm",
    ),
    "user-quantity-bogus": (
        "user",
        "tail,x_h_mm,quantity,value,sigma\nS3,98,Mqq,-0.0009,0.0001\n",
        "Mqq",
    ),
    "user-tail-unknown": (
        "user",
        "tail,x_h_mm,quantity,value,sigma\nQ9,98,Mq,-0.0009,0.0001\n",
        "Q9",
    ),
    "user-missing-column": ("user", "tail,x_h_mm,value\nS3,98,-0.0009\n", "quantity"),
    "campaign-json-list": ("campaign", "[1, 2, 3]", "campaign-json-list"),
    "campaign-json-deep": ("campaign", "[" * 100000 + "]" * 100000, "campaign-json-deep"),
    "campaign-json-nan": (
        "campaign",
        '{"configurations": [{"tail": "S3", "x_h_mm": NaN}]}',
        "campaign-json-nan",
    ),
}
for name, (kind, _, named) in TREND_FILES.items():
    suffix = ".json" if name.startswith("campaign-json") else ".csv"
    option = "--user-csv" if kind == "user" else "--campaign"
    case(
        "design-trends",
        f"file-{name}",
        "design",
        "trends",
        option,
        f"{{ws}}/trends/{name}{suffix}",
        expect=named,
    )
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"trends-out-{Path(parent).name}",
        "design",
        "trends",
        "--study",
        "--out",
        f"{parent}/trends",
        expect=parent.replace("{ws}/", ""),
    )

# -- 8. sim ------------------------------------------------------------------------------------------
for value in ("nan", "inf", "-1", "0", "1e308", "1e309", "abc"):
    case(
        "sim",
        f"trim-x-h-{value}",
        "sim",
        "trim",
        "--tail",
        "S3",
        "--x-h-mm",
        value,
        expect="--x-h-mm",
    )
    case(
        "sim",
        f"flight-x-h-{value}",
        "sim",
        "flight",
        "--tail",
        "S3",
        "--x-h-mm",
        value,
        "--out",
        "{ws}/out/f.csv",
        expect="--x-h-mm",
    )
for tail in ("Q9", "", "S3;rm"):
    case("sim", f"trim-tail-{tail or 'empty'}", "sim", "trim", "--tail", tail, expect="--tail")
for value in ("nan", "0", "-1", "1e308", "1e309", "inf"):
    case(
        "sim",
        f"flight-duration-{value}",
        "sim",
        "flight",
        "--tail",
        "S3",
        "--duration-s",
        value,
        "--out",
        "{ws}/out/f.csv",
        expect="--duration-s",
    )
for value in ("-1", "abc", "99999999999999999999999999", "1.5"):
    case(
        "sim",
        f"flight-seed-{value}",
        "sim",
        "flight",
        "--tail",
        "S3",
        "--duration-s",
        "1",
        "--seed",
        value,
        "--out",
        "{ws}/out/f.csv",
        expect="--seed",
    )
case(
    "sim",
    "flight-out-directory",
    "sim",
    "flight",
    "--tail",
    "S3",
    "--duration-s",
    "1",
    "--out",
    "{ws}/ok",
    expect="ok",
)
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"sim-flight-out-{Path(parent).name}",
        "sim",
        "flight",
        "--tail",
        "S3",
        "--duration-s",
        "1",
        "--out",
        f"{parent}/f.csv",
        expect=parent.replace("{ws}/", ""),
    )
case("sim", "trim-ok", "sim", "trim", "--tail", "S3", "--json", valid=True)
case("sim", "trim-out-ok", "sim", "trim", "--tail", "S3", "--out", "{ws}/out/trim", valid=True)
case(
    "sim",
    "trim-out-a-file",
    "sim",
    "trim",
    "--tail",
    "S3",
    "--out",
    "{ws}/ok/a-file.txt",
    expect="a-file.txt",
)
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"sim-trim-out-{Path(parent).name}",
        "sim",
        "trim",
        "--tail",
        "S3",
        "--out",
        f"{parent}/trim",
        expect=parent.replace("{ws}/", ""),
    )

TUNNEL_POINT = {"--theta-deg": "25", "--v-m-s": "0.8", "--f-hz": "13.5"}
for option in (*TUNNEL_POINT, "--x-h-mm"):
    for value in ("nan", "1e309", "-inf", "1e308", "abc"):
        options = {**TUNNEL_POINT, option: value}
        case(
            "sim",
            f"tunnel{option}-{value}",
            "sim",
            "tunnel",
            "--tail",
            "S3",
            *(item for pair in options.items() for item in pair),
            expect=option,
        )
for option, value in (
    ("--v-m-s", "-0.1"),
    ("--f-hz", "31"),
    ("--theta-deg", "95"),
    ("--day", "-1"),
):
    options = {**TUNNEL_POINT, option: value}
    case(
        "sim",
        f"tunnel-out-of-range{option}",
        "sim",
        "tunnel",
        "--tail",
        "S3",
        *(item for pair in options.items() for item in pair),
        expect=option,
    )
case(
    "sim",
    "tunnel-tail-unknown",
    "sim",
    "tunnel",
    "--tail",
    "Q9",
    *(item for pair in TUNNEL_POINT.items() for item in pair),
    expect="Q9",
)
case(
    "sim",
    "tunnel-ok",
    "sim",
    "tunnel",
    "--tail",
    "S3",
    *(item for pair in TUNNEL_POINT.items() for item in pair),
    "--json",
    valid=True,
)

# -- 9. gap ------------------------------------------------------------------------------------------
GAP_MODELS = {
    "kind-bogus": ('kind = "simulator"', 'kind = "oracle"', "kind"),
    "x-h-1e309": ("x_h_mm = 98", "x_h_mm = 1e309", "x_h_mm"),
    "x-h-nan": ("x_h_mm = 98", "x_h_mm = nan", "x_h_mm"),
    "tail-unknown": ('tail = "S3"', 'tail = "Q9"', "Q9"),
    "effect-unknown": ('["added_mass"]', '["teleport"]', "teleport"),
    "unknown-key": ('tail = "S3"', 'tail = "S3"\ntails = 1', "tails"),
    "effects-text": ('["added_mass"]', '"added_mass"', "effects_off"),
    "linear-missing-model": ('kind = "simulator"', 'kind = "linear_model"', "model"),
    "linear-model-devzero": (
        'kind = "simulator"',
        'kind = "linear_model"\nmodel = "/dev/zero"',
        "/dev/zero",
    ),
}
for name, (_, _, named) in GAP_MODELS.items():
    case(
        "gap",
        f"model-{name}",
        "gap",
        "diagnose",
        "--model",
        f"{{ws}}/gap/{name}.toml",
        "--data",
        "{ws}/logs/delfly.csv",
        "--out",
        "{ws}/out/gap",
        expect=named,
    )
case(
    "gap",
    "seed-negative",
    "gap",
    "diagnose",
    "--model",
    "{ws}/ok/baseline.toml",
    "--data",
    "{ws}/logs/delfly.csv",
    "--seed",
    "-1",
    "--out",
    "{ws}/out/gap",
    expect="--seed",
)
case(
    "gap",
    "seed-huge",
    "gap",
    "diagnose",
    "--model",
    "{ws}/ok/baseline.toml",
    "--data",
    "{ws}/logs/delfly.csv",
    "--seed",
    "99999999999999999999999999",
    "--out",
    "{ws}/out/gap",
    expect="--seed",
)
case(
    "gap",
    "data-twin-otter-columns",
    "gap",
    "diagnose",
    "--model",
    "{ws}/ok/baseline.toml",
    "--data",
    "{twin}",
    "--out",
    "{ws}/out/gap",
    expect="twin_otter",
)
case(
    "gap",
    "data-ms-flight",
    "gap",
    "diagnose",
    "--model",
    "{ws}/ok/baseline.toml",
    "--data",
    "{ws}/logs/delfly-ms.csv",
    "--out",
    "{ws}/out/gap",
    expect="time_s",
)
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"gap-out-{Path(parent).name}",
        "gap",
        "diagnose",
        "--model",
        "{ws}/ok/baseline.toml",
        "--data",
        "{ws}/logs/delfly.csv",
        "--out",
        f"{parent}/gap",
        expect=parent.replace("{ws}/", ""),
    )
    case(
        "unwritable",
        f"gap-example-out-{Path(parent).name}",
        "gap",
        "example",
        "--out",
        f"{parent}/example",
        expect=parent.replace("{ws}/", ""),
    )
    case(
        "unwritable",
        f"gap-benchmark-out-{Path(parent).name}",
        "gap",
        "benchmark",
        "--cases",
        "1",
        "--out",
        f"{parent}/bench.json",
        expect=parent.replace("{ws}/", ""),
    )
for arguments, named in (
    (("--effect", "teleport"), "teleport"),
    (("--effect", "added_mass=nan"), "--effect"),
    (("--effect", "added_mass=1e309"), "--effect"),
    (("--effect", "added_mass=1e308"), "added_mass"),
    (("--effect", "added_mass=abc"), "--effect"),
    (("--x-h-mm", "nan"), "--x-h-mm"),
    (("--x-h-mm", "-1"), "--x-h-mm"),
    (("--x-h-mm", "1e309"), "--x-h-mm"),
    (("--tail", "Q9"), "Q9"),
    (("--seed", "-1"), "--seed"),
    (("--manoeuvres", "2"), "--manoeuvres"),
    (("--kind", "wind"), "--kind"),
):
    case(
        "gap",
        f"example{arguments[0]}-{arguments[1]}",
        "gap",
        "example",
        *arguments,
        "--out",
        "{ws}/out/example",
        expect=named,
    )
for arguments, named in (
    (("--cases", "0"), "--cases"),
    (("--cases", "-1"), "--cases"),
    (("--seed", "-1"), "--seed"),
    (("--manoeuvres", "5"), "--manoeuvres"),
    (("--out", "{ws}/ok"), "ok"),
):
    case(
        "gap",
        f"benchmark{arguments[0]}-{arguments[1]}",
        "gap",
        "benchmark",
        *arguments,
        expect=named,
    )

# -- 10. gui (no display) and demo ---------------------------------------------------------------------
NO_DISPLAY = {"DISPLAY": "", "WAYLAND_DISPLAY": "", "QT_QPA_PLATFORM": ""}
for value in ("nan", "0", "-1", "inf", "1e309", "abc"):
    case(
        "gui",
        f"time-scale-{value}",
        "gui",
        "--time-scale",
        value,
        expect="--time-scale",
        env=NO_DISPLAY,
    )
    case(
        "demo",
        f"time-scale-{value}",
        "demo",
        "--time-scale",
        value,
        "--data-root",
        "{ws}/data",
        expect="--time-scale",
    )
case("gui", "no-display", "gui", expect="display", env=NO_DISPLAY)
case(
    "gui",
    "data-root-file",
    "gui",
    "--data-root",
    "{ws}/ok/a-file.txt",
    expect="a-file.txt",
    env=NO_DISPLAY,
)
for parent in UNWRITABLE_PARENTS:
    case(
        "unwritable",
        f"gui-data-root-{Path(parent).name}",
        "gui",
        "--data-root",
        f"{parent}/data",
        expect=parent.replace("{ws}/", ""),
        env=NO_DISPLAY,
    )
    case(
        "unwritable",
        f"demo-data-root-{Path(parent).name}",
        "demo",
        "--data-root",
        f"{parent}/data",
        expect=parent.replace("{ws}/", ""),
    )
case(
    "gui", "rig-bad-baud", "gui", "--rig", "{ws}/rigs/baud-1e11.toml", expect="baud", env=NO_DISPLAY
)

# -- 11. the command line itself ------------------------------------------------------------------------
case("command-line", "unknown-command", "fly", expect="fly")
case("command-line", "unknown-subcommand", "design", "sketch", expect="sketch")
case("command-line", "unknown-option", "runs", "--colour", expect="--colour")
case("command-line", "option-needs-value", "calibration", "show", "--cal", expect="--cal")
case("command-line", "extra-argument", "sim", "trim", "--tail", "S3", "extra", expect="extra")
case("command-line", "help", "--help", valid=True, expect=("sweep",))
case("command-line", "version", "--version", valid=True)


# -- the workspace ----------------------------------------------------------------------------------------
def _rig_text(calibration: str = str(CAL_FILE), table: str = str(TUNNEL_TABLE)) -> str:
    text = RIG_FILE.read_text(encoding="utf-8")
    text = text.replace('calibration = "calibration/FT8884.cal"', f'calibration = "{calibration}"')
    return text.replace('table = "tunnel_table.csv"', f'table = "{table}"')


def _edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _write_bad_files(folder: Path) -> None:
    folder.mkdir()
    suffixes = {suffix for suffix, _ in FILE_SLOTS.values()}
    for suffix in suffixes:
        for kind, content in BAD_CONTENT.items():
            (folder / f"{kind}{suffix}").write_bytes(content)
        with open(folder / f"toolarge{suffix}", "wb") as stream:
            stream.truncate(MAX_INPUT_FILE_BYTES + 1)  # sparse: no disk used
        (folder / f"directory{suffix}").mkdir()
        os.mkfifo(folder / f"fifo{suffix}")


def _cal_variants(folder: Path) -> None:
    folder.mkdir()
    text = CAL_FILE.read_text(encoding="utf-8")
    lines = text.splitlines(keepends=True)
    axis_lines = [index for index, line in enumerate(lines) if "<Axis " in line]

    def with_values(values: list[str]) -> str:
        new = list(lines)
        for index, value in zip(axis_lines, values, strict=True):
            start = new[index].index('values="') + len('values="')
            end = new[index].index('"', start)
            new[index] = new[index][:start] + value + new[index][end:]
        return "".join(new)

    zero = " ".join(["0"] * 6)
    (folder / "zero-matrix.cal").write_text(with_values([zero] * 6))
    row = " 1 2 3 4 5 6 "
    (folder / "singular-matrix.cal").write_text(with_values([row] * 6))
    original = [
        lines[index][
            lines[index].index('values="') + 8 : lines[index].index(
                '"', lines[index].index('values="') + 8
            )
        ]
        for index in axis_lines
    ]
    (folder / "nan-value.cal").write_text(
        with_values([original[0].replace("0.01075", "nan"), *original[1:]])
    )
    (folder / "1e309-value.cal").write_text(
        with_values([original[0].replace("0.01075", "1e309"), *original[1:]])
    )
    (folder / "1e308-value.cal").write_text(
        with_values([original[0].replace("0.01075", "1e308"), *original[1:]])
    )
    (folder / "five-values.cal").write_text(with_values([" 1 2 3 4 5 ", *original[1:]]))
    (folder / "missing-axis.cal").write_text(
        "".join(line for index, line in enumerate(lines) if index != axis_lines[-1])
    )
    (folder / "deep-xml.cal").write_text("<a>" * 100000 + "</a>" * 100000)
    (folder / "entity-bomb.cal").write_text(
        '<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">'
        '<!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;"><!ENTITY d "&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;">'
        '<!ENTITY e "&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;"><!ENTITY f "&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;">'
        '<!ENTITY g "&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;">]><FTSensor Serial="&g;"/>'
    )


def _record_run(data_root: Path) -> Path:
    """A short real run (two blocks, one set point) under ``data_root``; its directory."""
    from ornitail.acquisition.recorder import Recorder
    from ornitail.acquisition.recording_layout import (
        ChannelSpec,
        RunConfiguration,
        SetPointRecord,
        StreamLayout,
    )
    from ornitail.acquisition.run_documents import DocumentDispatcher
    from ornitail.acquisition.run_engine import open_run

    layout = StreamLayout(
        [ChannelSpec(f"gauge_{i}", "V") for i in range(6)], sample_rate_hz=10_000.0
    )
    recorder = Recorder(data_root, RunConfiguration("S3", 0.098, True, "corpus"), layout)
    with open_run(
        recorder, DocumentDispatcher(), set_points_planned=2
    ):  # registered, as sweeps register
        for block in range(2):
            counters = np.arange(block * 500, (block + 1) * 500)
            recorder.put_block(counters, np.zeros((500, 6)))
        known = {item.name for item in dataclasses.fields(SetPointRecord)}
        extra = dict(motor_rpm_mean=17272.0, saturated_samples=0, over_range_samples=0)
        extra = {name: value for name, value in extra.items() if name in known}
        recorder.complete_set_point(
            SetPointRecord(0, "tare", 0, 499, 0.26, 0.0, 0.0, True, **extra)
        )
        recorder.complete_set_point(
            SetPointRecord(1, "measurement", 500, 999, 0.26, 0.8, 13.5, True, **extra)
        )
    return recorder.run_directory


def _damage(run: Path, damage: str) -> None:
    run_json, journal, samples = run / "run.json", run / "journal.jsonl", run / "samples.h5"
    original = run_json.read_text(encoding="utf-8")
    if damage == "run-json-nonutf8":
        run_json.write_bytes(BAD_CONTENT["nonutf8"])
    elif damage == "run-json-binary":
        run_json.write_bytes(BAD_CONTENT["binary"])
    elif damage == "run-json-empty":
        run_json.write_bytes(b"")
    elif damage == "run-json-1e309":
        run_json.write_text(
            original.replace('"sample_rate_hz": 10000.0', '"sample_rate_hz": 1e309')
        )
    elif damage == "run-json-nan":
        run_json.write_text(original.replace('"sample_rate_hz": 10000.0', '"sample_rate_hz": NaN'))
    elif damage == "run-json-deep":
        run_json.write_text("[" * 100000 + "]" * 100000)
    elif damage == "run-json-list":
        run_json.write_text("[]")
    elif damage == "run-json-fifo":
        run_json.unlink()
        os.mkfifo(run_json)
    elif damage == "run-json-directory":
        run_json.unlink()
        run_json.mkdir()
    elif damage == "run-json-toolarge":
        with open(run_json, "r+b") as stream:
            stream.truncate(MAX_INPUT_FILE_BYTES + 1)
    elif damage == "run-json-missing":
        run_json.unlink()
    elif damage == "journal-nonutf8":
        journal.write_bytes(BAD_CONTENT["nonutf8"])
    elif damage == "journal-fifo":
        journal.unlink()
        os.mkfifo(journal)
    elif damage == "journal-binary":
        journal.write_bytes(BAD_CONTENT["binary"])
    elif damage == "samples-missing":
        samples.unlink()
    elif damage == "samples-binary":
        samples.write_bytes(BAD_CONTENT["binary"])
    elif damage == "samples-fifo":
        samples.unlink()
        os.mkfifo(samples)
    elif damage == "samples-directory":
        samples.unlink()
        samples.mkdir()
    else:
        raise AssertionError(damage)


def _write_twin_otter_variants(folder: Path) -> None:
    import pandas as pd

    folder.mkdir()
    log = pd.read_csv(TWIN_OTTER_CSV)
    in_ms = log.copy()
    in_ms["time_sec"] = (in_ms["time_sec"] - in_ms["time_sec"].iloc[0]) * 1000.0
    in_ms.to_csv(folder / "time-in-ms.csv", index=False)
    in_ms_1000 = log.copy()
    in_ms_1000["time_sec"] = in_ms_1000["time_sec"] * 1000.0
    in_ms_1000.to_csv(folder / "time-in-ms-1000x.csv", index=False)
    text = TWIN_OTTER_CSV.read_text(encoding="utf-8")
    header, first, *rest = text.splitlines()
    alpha = header.split(",").index("alpha_deg")

    def with_cell(value: str) -> str:
        cells = first.split(",")
        cells[alpha] = value
        return "\n".join([header, ",".join(cells), *rest]) + "\n"

    (folder / "nan-cell.csv").write_text(with_cell("nan"))
    (folder / "inf-cell.csv").write_text(with_cell("inf"))
    (folder / "1e309-cell.csv").write_text(with_cell("1e309"))
    (folder / "text-column.csv").write_text(with_cell("high"))
    (folder / "header-only.csv").write_text(header + "\n")
    (folder / "ten-rows.csv").write_text("\n".join([header, *[first] * 3, *rest[:7]]) + "\n")
    (folder / "ragged.csv").write_text("\n".join([header, first + ",1,2,3", *rest]) + "\n")
    backwards = log.copy()
    backwards["time_sec"] = backwards["time_sec"].iloc[::-1].to_numpy()
    backwards.to_csv(folder / "time-backwards.csv", index=False)
    constant = log.copy()
    constant["time_sec"] = 5.0
    constant.to_csv(folder / "time-constant.csv", index=False)
    huge = log.copy()
    huge["time_sec"] = np.arange(len(huge)) * 1e305
    huge.to_csv(folder / "time-1e308.csv", index=False)
    (folder / "text.mat").write_text("this is not a MATLAB file\n")
    (folder / "text.parquet").write_text("this is not a Parquet file\n")
    # A DelFly flight log (the columns of docs/flight-campaign.md) at 512 Hz, and the same timed in ms.
    time_s = np.arange(0, 20.0, 1 / 512)
    delfly = pd.DataFrame(
        {
            "time_s": time_s,
            "q_rad_s": 0.1 * np.sin(time_s),
            "u_m_s": 0.8 + 0.01 * np.cos(time_s),
            "w_m_s": 0.3 + 0.01 * np.sin(time_s),
            "theta_rad": 0.4 + 0.01 * np.sin(time_s),
            "elevator_cmd": np.where((time_s % 4) < 1, 0.1, 0.0),
            "elevator_rad": np.where((time_s % 4) < 1, 0.1, 0.0),
            "rudder_cmd": np.zeros_like(time_s),
        }
    )
    delfly.to_csv(folder / "delfly.csv", index=False)
    delfly_ms = delfly.copy()
    delfly_ms["time_s"] = delfly_ms["time_s"] * 1000.0
    delfly_ms.to_csv(folder / "delfly-ms.csv", index=False)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    """Every input file the cases name, under one folder (``{ws}`` in the case arguments)."""
    ws = tmp_path_factory.mktemp("corpus")
    ok = ws / "ok"
    ok.mkdir()
    (ok / "plan.toml").write_text(GOOD_PLAN)
    (ok / "rig.toml").write_text(_rig_text())
    (ok / "baseline.toml").write_text(GAP_BASELINE)
    (ok / "campaign.toml").write_text(CAMPAIGN_FILE)
    (ok / "user.csv").write_text(USER_CSV)
    (ok / "a-file.txt").write_text("a regular file\n")
    (ok / "dir.toml").mkdir()
    (ws / "data-empty").mkdir()
    _write_bad_files(ws / "bad")
    rigs = ws / "rigs"
    rigs.mkdir()
    for kind in FILE_KINDS:
        (rigs / f"calibration-{kind}.toml").write_text(
            _rig_text(calibration=bad_path(kind, ".cal").replace("{ws}", str(ws)))
        )
        (rigs / f"table-{kind}.toml").write_text(
            _rig_text(table=bad_path(kind, ".csv").replace("{ws}", str(ws)))
        )
    for edit_id, (old, new, _) in RIG_EDITS.items():
        (rigs / f"{edit_id}.toml").write_text(_edit(_rig_text(), old, new))
    (rigs / "slow-motor.toml").write_text(_edit(_rig_text(), *SLOW_MOTOR))
    plans = ws / "plans"
    plans.mkdir()
    for edit_id, (old, new, _) in PLAN_EDITS.items():
        (plans / f"{edit_id}.toml").write_text(_edit(GOOD_PLAN, old, new))
    _cal_variants(ws / "cals")
    for folder, files in (("hotwire", HOTWIRE_FILES), ("tables", TUNNEL_TABLES)):
        (ws / folder).mkdir()
        for name, text in files.items():
            (ws / folder / f"{name}.csv").write_text(text)
    models = ws / "models"
    models.mkdir()
    preset = (REPOSITORY / "flight" / "models" / "twin_otter_short_period.toml").read_text()
    for name, (old, new, _) in MODEL_EDITS.items():
        (models / f"{name}.toml").write_text(_edit(preset, old, new))
    _write_twin_otter_variants(ws / "logs")
    campaigns = ws / "campaigns"
    campaigns.mkdir()
    for name, (old, new, _) in CAMPAIGN_EDITS.items():
        (campaigns / f"{name}.toml").write_text(_edit(CAMPAIGN_FILE, old, new))
    trends = ws / "trends"
    trends.mkdir()
    for name, (_, text, _) in TREND_FILES.items():
        suffix = ".json" if name.startswith("campaign-json") else ".csv"
        (trends / f"{name}{suffix}").write_text(text)
    gap = ws / "gap"
    gap.mkdir()
    for name, (old, new, _) in GAP_MODELS.items():
        (gap / f"{name}.toml").write_text(_edit(GAP_BASELINE, old, new))
    runs = ws / "runs"
    roots = ws / "roots"
    template_root = ws / "template-root"
    template_run = _record_run(template_root)
    shutil.copytree(template_run, runs / "ok")
    shutil.copytree(template_root, roots / "ok")
    for damage in RUN_DAMAGE:
        shutil.copytree(template_run, runs / damage)
        _damage(runs / damage, damage)
        if damage in (
            "run-json-nonutf8",
            "run-json-binary",
            "run-json-empty",
            "run-json-1e309",
            "run-json-fifo",
            "samples-missing",
        ):
            root = roots / damage
            shutil.copytree(template_root, root)
            _damage(root / "runs" / template_run.name, damage)
    for name in ("catalog-binary", "catalog-fifo"):
        (roots / name).mkdir(parents=True)
    (roots / "catalog-binary" / "catalog.sqlite").write_bytes(BAD_CONTENT["binary"])
    os.mkfifo(roots / "catalog-fifo" / "catalog.sqlite")
    return ws


def _resolve(arguments: tuple[str, ...], ws: Path) -> list[str]:
    return [
        item.replace("{ws}", str(ws)).replace("{twin}", str(TWIN_OTTER_CSV)) for item in arguments
    ]


def _check_refusal(case_: Case, exit_code: int, stdout: str, stderr: str, ws: Path) -> None:
    lines = stderr.strip().splitlines()
    assert "Traceback" not in stderr + stdout, stderr
    assert exit_code == 2, (exit_code, stderr, stdout[-2000:])
    assert len(lines) == 1, stderr[-3000:]
    assert lines[0].startswith("ornitail: error: "), lines[0]
    assert stdout == "", stdout[-2000:]
    for expected in case_.expect:
        expected = expected.replace("{ws}", str(ws))
        assert expected.lower() in lines[0].lower(), (expected, lines[0])


@pytest.mark.parametrize("case_", CASES, ids=[case_.id for case_ in CASES])
def test_bad_input_corpus(case_: Case, workspace: Path, monkeypatch) -> None:
    """Valid input exits 0; anything else is one line on stderr, exit code 2, no traceback."""
    monkeypatch.chdir(workspace)
    monkeypatch.setenv("ORNITAIL_DATA", str(workspace / "data-default"))
    env = {name: (value or None) for name, value in case_.env.items()}
    result = CliRunner().invoke(
        main, _resolve(case_.args, workspace), env=env, catch_exceptions=True
    )
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        import traceback

        pytest.fail(
            "traceback:\n"
            + "".join(traceback.format_exception(result.exception))[-4000:]
            + f"\nstderr: {result.stderr[-1000:]}"
        )
    if case_.valid:
        assert result.exit_code == 0, result.stderr[-3000:]
        assert "Traceback" not in result.stderr
        for expected in case_.expect:
            assert expected in result.stdout, result.stdout[-3000:]
        return
    _check_refusal(case_, result.exit_code, result.stdout, result.stderr, workspace)


def test_corpus_covers_every_command() -> None:
    """Every command and subcommand of ``ornitail --help`` has cases, and there are at least 372."""
    import click

    def leaves(group: click.Group, prefix: tuple[str, ...]) -> list[tuple[str, ...]]:
        names = []
        for name, command in group.commands.items():
            if isinstance(command, click.Group):
                names += leaves(command, (*prefix, name))
            else:
                names.append((*prefix, name))
        return names

    covered = {tuple(case_.args[: len(path)]) for case_ in CASES for path in leaves(main, ())}
    missing = [" ".join(path) for path in leaves(main, ()) if path not in covered]
    assert not missing, missing
    assert len(CASES) >= 372


# -- plans refused before the rig is touched ------------------------------------------------------------------
def test_a_refused_plan_creates_no_run_and_never_homes_the_strut(workspace, monkeypatch) -> None:
    """A plan beyond the rig (motor rpm, board rate, duration) is refused before connecting."""
    from dataclasses import replace

    from ornitail.acquisition import rig as rig_module
    from ornitail.acquisition.sweep import run_sweep
    from ornitail.acquisition.sweep_plan import load_plan
    from ornitail.core.errors import UserInputError

    connected = []
    monkeypatch.setattr(rig_module.Rig, "connect", lambda self, **kwargs: connected.append(self))
    data_root = workspace / "refused-data"
    for edit_id in ("f-over-max-motor-rpm", "rate-over-link", "duration-over-24h", "record-700"):
        arguments = ["sweep", str(workspace / "plans" / f"{edit_id}.toml")]
        arguments += [
            "--rig",
            str(workspace / "rigs" / "slow-motor.toml"),
            "--data-root",
            str(data_root),
        ]
        result = CliRunner().invoke(main, arguments)
        assert result.exit_code == 2, (edit_id, result.stderr)
    assert connected == []
    assert not (data_root / "runs").exists() or not any((data_root / "runs").iterdir())
    # run_sweep itself refuses such a plan first thing, before it mounts or moves anything.
    rig = rig_module.Rig.from_file(workspace / "rigs" / "slow-motor.toml")
    plan = load_plan(workspace / "ok" / "plan.toml")
    fast = replace(
        plan,
        set_points=tuple(
            replace(point, flapping_frequency_hz=15.5) if point.kind == "measurement" else point
            for point in plan.set_points
        ),
    )
    moved = []
    monkeypatch.setattr(rig_module.Rig, "mount_vehicle", lambda self, *a: moved.append("mount"))
    monkeypatch.setattr(rig_module.Rig, "set_pitch", lambda self, *a: moved.append("pitch"))
    with pytest.raises(UserInputError, match="max_motor_rpm"):
        run_sweep(fast, rig, data_root)
    assert moved == []
    assert not (data_root / "runs").exists() or not any((data_root / "runs").iterdir())


def test_a_refused_plan_on_the_simulated_rig_leaves_the_strut_unhomed(workspace) -> None:
    """On a connected simulated rig, run_sweep refuses the plan before moving the strut or recording."""
    from dataclasses import replace

    from ornitail.acquisition.rig import Rig
    from ornitail.acquisition.sweep import run_sweep
    from ornitail.acquisition.sweep_plan import load_plan
    from ornitail.core.errors import UserInputError

    plan = load_plan(workspace / "ok" / "plan.toml")
    slow = replace(plan, sample_rate_hz=50.0)
    data_root = workspace / "refused-connected"
    rig = Rig.from_file(workspace / "ok" / "rig.toml", time_scale=20.0)
    rig.connect(home_strut=False)
    try:
        with pytest.raises(UserInputError, match="sample_rate_hz"):
            run_sweep(slow, rig, data_root)
        assert not rig.simulators.strut.homed
        assert rig.simulators.strut.angle_deg == rig.simulators.strut.target_deg
    finally:
        rig.close()
    assert not (data_root / "runs").exists() or not any((data_root / "runs").iterdir())


# -- the console script in real processes ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "arguments, named",
    [
        (
            ["design", "geometry", "--b", "1e308", "--b-le", "105", "--c-r", "66", "--c-t", "35"],
            "--b",
        ),
        (
            [
                "sim",
                "flight",
                "--tail",
                "S3",
                "--seed",
                "-1",
                "--duration-s",
                "1",
                "--out",
                "f.csv",
            ],
            "--seed",
        ),
        (["calibration", "show", "--cal", "/dev/zero"], "/dev/zero"),
        (["sweep", "{ws}/plans/record-1e300.toml", "--data-root", "{ws}/data"], "record_s"),
        (
            ["calibration", "convert", "--cal", str(CAL_FILE), "--volts", "1e308,0,0,0,0,0"],
            "--volts",
        ),
    ],
)
def test_console_script_refuses_in_one_line(arguments, named, workspace) -> None:
    """The installed ``ornitail`` command: exit 2, one line on stderr, nothing on stdout."""
    completed = subprocess.run(
        [ORNITAIL, *_resolve(tuple(arguments), workspace)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=workspace,
        stdin=subprocess.DEVNULL,
    )
    assert completed.returncode == 2, completed.stderr
    assert completed.stdout == ""
    assert "Traceback" not in completed.stderr
    assert len(completed.stderr.strip().splitlines()) == 1, completed.stderr
    assert named in completed.stderr


def test_console_script_valid_input_exits_0(workspace) -> None:
    completed = subprocess.run(
        [
            ORNITAIL,
            "design",
            "geometry",
            "--b",
            "203",
            "--b-le",
            "105",
            "--c-r",
            "66",
            "--c-t",
            "35",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )
    assert completed.returncode == 0, completed.stderr
    assert math.isfinite(json.loads(completed.stdout)["s_cm2"])
