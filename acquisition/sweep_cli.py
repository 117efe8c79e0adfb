"""``ornitail sweep PLAN --rig RIG``: run a sweep plan headless, with progress, Ctrl-C handling and resume."""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click

from ornitail.acquisition.catalog import default_data_root
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.acquisition.sweep import (
    SweepEvent,
    SweepResult,
    SweepStop,
    check_plan_against_rig,
    run_sweep,
)
from ornitail.acquisition.sweep_plan import load_plan
from ornitail.core.output import emit, json_option

EXIT_ABORTED = 130
EXIT_FAILED = 3


@contextmanager
def first_interrupt_finishes_the_point(stop: SweepStop) -> Iterator[None]:
    """First Ctrl-C: finish the current set point and stop; second Ctrl-C: stop at once."""

    def handler(signum: int, frame: Any) -> None:
        if stop.requested:
            raise KeyboardInterrupt
        stop.request()
        click.echo(
            "\nornitail: finishing the current set point, then stopping (Ctrl-C again to stop now)",
            err=True,
        )

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _operator_prompt(instruction: str) -> None:
    click.pause(f"ornitail: {instruction} Press any key when done.", err=True)


def run_sweep_with_progress(
    plan_path: Path,
    rig_path: Path,
    data_root: Path,
    *,
    resume: bool = False,
    time_scale: float | None = None,
) -> SweepResult:
    """Load plan and rig, connect, run the sweep with a progress bar on stderr; the rig is always closed."""
    plan = load_plan(plan_path)
    rig = Rig.from_file(rig_path, time_scale=time_scale)
    check_plan_against_rig(plan, rig)  # before connecting: connecting homes the strut
    stop = SweepStop()
    with (
        first_interrupt_finishes_the_point(stop),
        rig,
        click.progressbar(
            length=len(plan.set_points),
            label=f"sweep {plan.name}",
            file=sys.stderr,
            show_eta=True,
            show_pos=True,
            item_show_func=lambda point: point.label if point else "",
        ) as bar,
    ):

        def on_event(event: SweepEvent) -> None:
            if event.stage == "recorded":
                bar.update(event.completed - bar.pos, event.set_point)
            elif event.stage == "moving" and bar.pos < event.completed:
                bar.update(event.completed - bar.pos)

        return run_sweep(
            plan,
            rig,
            data_root,
            resume=resume,
            stop=stop,
            on_event=on_event,
            operator_prompt=_operator_prompt,
        )


def run_link_health(run_directory: Path) -> dict[str, Any]:
    """Link health of one run from its files: samples lost (counter gaps), CRC errors, retaken set points."""
    recording = load_recording(run_directory)
    metadata = recording.effective_metadata
    return {
        "run_directory": str(run_directory),
        "samples_lost": int(metadata["counter_gaps"]["missing_samples"]),
        "crc_errors": int(metadata["link_health"]["crc_errors"]),
        "set_points_retaken": sum(
            1 for record in recording.set_points if record.extra.get("retakes")
        ),
    }


def sweep_result_record(result: SweepResult) -> dict[str, Any]:
    """The JSON record of a sweep result, with the link health of each run."""
    return {
        "status": result.status,
        "message": result.message,
        "completed_points": result.completed_points,
        "total_points": result.total_points,
        "run_directories": [str(path) for path in result.run_directories],
        "link_health": [run_link_health(path) for path in result.run_directories],
    }


def exit_code_of(result: SweepResult) -> int:
    """0 completed, 130 aborted, 3 failed."""
    return {"completed": 0, "aborted": EXIT_ABORTED}.get(result.status, EXIT_FAILED)


def _render(record: dict[str, Any]) -> str:
    lines = [f"sweep {record['status']}: {record['message']}"]
    for health in record["link_health"]:
        lines.append(f"  run: {health['run_directory']}")
        if health["samples_lost"] or health["crc_errors"] or health["set_points_retaken"]:
            lines.append(
                f"    link: {health['samples_lost']} samples lost, {health['crc_errors']} CRC "
                f"errors; {health['set_points_retaken']} set point(s) recorded again after losing samples"
            )
    return "\n".join(lines)


def guarded(action: Callable[[], SweepResult]) -> SweepResult:
    """Run ``action``; a second Ctrl-C ends the command with exit code 130 after the rig was made safe."""
    try:
        return action()
    except KeyboardInterrupt:
        click.echo("ornitail: sweep stopped at once; every recorded set point is kept", err=True)
        sys.exit(EXIT_ABORTED)


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
    record each point. First Ctrl-C finishes the current point and stops; a second stops at once."""
    result = guarded(
        lambda: run_sweep_with_progress(
            plan, rig_path, data_root or default_data_root(), resume=resume, time_scale=time_scale
        )
    )
    emit(sweep_result_record(result), as_json, _render)
    sys.exit(exit_code_of(result))
