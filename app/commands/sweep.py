"""``ornitail sweep PLAN --rig RIG``: run a sweep plan headless (app/sweep_session.py), print its result."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import click

from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.app.cli_output import emit, json_option


@click.command("sweep")
@click.argument("plan", type=click.Path(path_type=Path))
@click.option(
    "--rig",
    "rig_path",
    type=click.Path(path_type=Path),
    default=DEFAULT_RIG_FILE,
    show_default="the simulated rig",
    help="Rig file (TOML).",
)
@click.option(
    "--data-root",
    type=click.Path(path_type=Path),
    default=None,
    help="Where runs and the catalog live [default: $ORNITAIL_DATA or ./ornitail-data].",
)
@click.option(
    "--resume",
    is_flag=True,
    help="Continue the newest sweep of this plan at its first unfinished point.",
)
@click.option(
    "--time-scale",
    type=float,
    default=None,
    help="Simulated rigs only: run this many times faster than real time.",
)
@json_option
def sweep_command(
    plan: Path,
    rig_path: Path,
    data_root: Path | None,
    resume: bool,
    time_scale: float | None,
    as_json: bool,
) -> None:
    """Run the sweep PLAN on the rig: check every set point against the rig's limits, then move, settle and
    record each point. First Ctrl-C finishes the current point and stops; a second, SIGTERM or SIGHUP stops at
    once. Exit codes: 0 completed, 2 input error, 3 instrument failed, 4 incomplete, 5 rig or chain in use,
    130 Ctrl-C, 143 SIGTERM, 129 SIGHUP."""
    # imported here: `ornitail sweep --help` needs none of the recorder's libraries
    from ornitail.acquisition.catalog import default_data_root
    from ornitail.acquisition.sweep import SweepStop
    from ornitail.app.sweep_session import (
        SweepSignals,
        check_time_scale_option,
        exit_code_of,
        guarded,
        render_sweep_result,
        run_sweep_with_progress,
        sweep_result_record,
    )

    signals = SweepSignals(SweepStop()).install()  # kept to the end: later signals are only noted
    check_time_scale_option(time_scale)
    result = guarded(
        lambda: run_sweep_with_progress(
            plan,
            rig_path,
            data_root or default_data_root(),
            resume=resume,
            time_scale=time_scale,
            signals=signals,
        )
    )
    signals.closing()
    with contextlib.suppress(OSError):  # stdout may be a closed terminal (SIGHUP) or pipe
        emit(sweep_result_record(result), as_json, render_sweep_result)
    signals.ignore_from_now()
    sys.exit(exit_code_of(result))
