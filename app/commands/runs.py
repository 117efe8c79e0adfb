"""``ornitail runs``: list and filter the recorded runs of a data root."""

from __future__ import annotations

import math
from datetime import datetime
from pathlib import Path
from typing import Any

import click

from ornitail.acquisition.catalog import (
    DATA_ROOT_ENVIRONMENT_VARIABLE,
    CatalogEntry,
    RunCatalog,
    RunFilter,
    default_data_root,
    run_file_problems,
)
from ornitail.app.cli_output import emit, json_option
from ornitail.core.errors import UserInputError

_TABLE_COLUMNS = (
    ("run_id", 34),
    ("status", 9),
    ("tail", 6),
    ("x_h_mm", 7),
    ("tailed", 8),
    ("plan", 14),
    ("start_utc", 19),
    ("samples", 10),
    ("set_pts", 7),
    ("lost", 8),
    ("crc", 5),
    ("sat_pts", 7),
)


def parse_x_h_mm(text: str) -> float:
    """Parse ``--x-h-mm`` and return x_h in metres; a non-number or NaN is a user error."""
    try:
        value_mm = float(text)
    except ValueError:
        raise UserInputError("--x-h-mm", f"{text!r} is not a number of millimetres") from None
    if not math.isfinite(value_mm):
        raise UserInputError("--x-h-mm", f"value {text!r} is not a finite number")
    return value_mm * 1e-3


def parse_since(text: str) -> datetime:
    """Parse ``--since`` (ISO 8601 date or date-time); a time without zone is local time."""
    try:
        moment = datetime.fromisoformat(text)
    except ValueError:
        raise UserInputError(
            "--since", f"{text!r} is not an ISO 8601 date or time (e.g. 2024-06-07T14:00)"
        ) from None
    return moment if moment.tzinfo is not None else moment.astimezone()


def _lost_samples(run: dict[str, Any]) -> int:
    """Samples lost, each once: those the sample counters say are missing in the run's file (queue and link
    losses are causes of these, not additions to them)."""
    return run["lost_samples"]


def _render_table(result: dict[str, Any]) -> str:
    runs = result["runs"]
    unreadable = [
        f"unreadable run: {item['run_directory']}: {item['problem']}"
        for item in result.get("unreadable", [])
    ]
    if not runs:
        return "\n".join(["no runs match", *unreadable])
    header = " ".join(f"{name:<{width}}" for name, width in _TABLE_COLUMNS).rstrip()
    lines = [header, "-" * len(header)]
    for run in runs:
        x_h_mm = "-" if run["x_h_m"] is None else f"{run['x_h_m'] * 1e3:.1f}"
        cells = (
            run["run_id"],
            run["exit_status"],
            run["tail_id"] or "-",
            x_h_mm,
            "tailed" if run["tailed"] else "tailless",
            run["plan_name"] or "-",
            run["start_time_utc"][:19],
            str(run["sample_count"]),
            str(run["set_point_count"]),
            str(_lost_samples(run)),
            str(run["crc_errors"]),
            str(run["saturated_set_points"]),
        )
        widths = [width for _, width in _TABLE_COLUMNS]
        row = " ".join(f"{cell:<{w}}" for cell, w in zip(cells, widths, strict=True))
        lines.append(row.rstrip())
        if run.get("problems"):
            lines.append(
                f"    damaged (recorded as {run['recorded_exit_status']}): "
                + "; ".join(run["problems"])
            )
        if run["failure_reason"] and run["exit_status"] != "completed":
            lines.append(f"    reason: {run['failure_reason']}")
        if run["saturated_set_points"]:
            lines.append(
                f"    saturation: {run['saturated_set_points']} set point(s): "
                f"{run['saturated_samples']} samples at the ADC limit, {run['over_range_samples']} over "
                "the sensor's rated load"
            )
        if run["garbage_bytes"] or run["foreign_frames"]:
            lines.append(
                f"    link: {run['garbage_bytes']} garbage bytes in {run['resyncs']} resync(s), "
                f"{run['foreign_frames']} foreign CAN frame(s)"
            )
    return "\n".join([*lines, *unreadable])


@click.command("runs")
@click.option(
    "--data-root",
    type=click.Path(path_type=Path, file_okay=False),
    default=None,
    help=f"Folder of runs and catalog.sqlite [default: ${DATA_ROOT_ENVIRONMENT_VARIABLE} "
    "or ./ornitail-data].",
)
@click.option("--tail", "tail_id", default=None, help="Tail id, e.g. S3 (case-insensitive).")
@click.option("--x-h-mm", "x_h_mm_text", default=None, help="Tail position x_h in mm (±0.05 mm).")
@click.option("--tailed/--tailless", default=None, help="Only runs with / without the tail.")
@click.option(
    "--status",
    "exit_status",
    default=None,
    help="completed, incomplete, aborted, failed, crashed or running.",
)
@click.option("--since", "since_text", default=None, help="Runs started at or after (ISO 8601).")
@click.option(
    "--plot",
    "plot_run",
    default=None,
    help="Draw this run's signals instead of listing runs: a run id under the data root, or a run folder.",
)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(path_type=Path),
    default=None,
    help="Folder for the --plot picture (signals_<run id>.png and .pdf).",
)
@click.option(
    "--hotwire-law",
    "hotwire_law_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Hot-wire law (.toml/.json of `calibration hotwire-fit`) to draw the hot wire in m/s with --plot "
    "[default: its bridge voltage].",
)
@json_option
def runs_command(
    data_root: Path | None,
    tail_id: str | None,
    x_h_mm_text: str | None,
    tailed: bool | None,
    exit_status: str | None,
    since_text: str | None,
    plot_run: str | None,
    out_dir: Path | None,
    hotwire_law_path: Path | None,
    as_json: bool,
) -> None:
    """List recorded runs, oldest first; runs whose process died are shown as crashed. The catalog is first
    brought up to date from the run directories; if another process keeps it locked, the runs are listed as
    their directories say and a note on stderr says so. With --plot RUN --out DIR: draw that run's signals
    (loads in N and N m, flow in m/s, temperature in degC, flapping frequency in Hz, pitch in deg)."""
    if plot_run is None and (out_dir is not None or hotwire_law_path is not None):
        raise UserInputError(
            "--out" if out_dir is not None else "--hotwire-law", "only used with --plot RUN"
        )
    if plot_run is not None:
        _plot_run(plot_run, data_root, out_dir, hotwire_law_path, as_json)
        return
    run_filter = RunFilter(
        tail_id=tail_id,
        x_h_m=None if x_h_mm_text is None else parse_x_h_mm(x_h_mm_text),
        tailed=tailed,
        exit_status=exit_status,
        started_since_utc=None if since_text is None else parse_since(since_text),
    )
    run_filter.validate()
    catalog = RunCatalog(data_root if data_root is not None else default_data_root())
    entries, report = catalog.runs_reconciled(run_filter)
    if report.write_error is not None:
        click.echo(
            f"ornitail: note: the catalog {catalog.path} is locked by another process "
            f"({report.write_error}); {len(report.unwritten_entries)} run(s) listed from their run "
            "directories, the catalog catches up on the next `ornitail runs`",
            err=True,
        )
    runs = [_with_file_problems(catalog.data_root, entry) for entry in entries]
    unreadable = [
        {
            "run_directory": directory,
            "problem": report.unreadable_reasons.get(directory, "unreadable"),
        }
        for directory in report.unreadable_run_directories
    ]
    result: dict[str, Any] = {"runs": runs}
    if unreadable:  # run directories whose run.json cannot be read are listed, never hidden
        result["unreadable"] = unreadable
    emit(result, as_json, _render_table)


def _with_file_problems(data_root: Path, entry: CatalogEntry) -> dict[str, Any]:
    """The entry's JSON record; a run whose files are damaged (samples file gone) is listed with
    ``exit_status`` ``"damaged"``, its recorded status in ``recorded_exit_status`` and ``problems``."""
    run = entry.to_json_dict()
    problems = run_file_problems(data_root, entry)
    run["problems"] = problems
    if problems:
        run["recorded_exit_status"] = run["exit_status"]
        run["exit_status"] = "damaged"
    return run


def _render_plot(result: dict[str, Any]) -> str:
    lines = [
        f"run {result['run_id']} ({result['set_points']} set points): {result['run_directory']}"
    ]
    return "\n".join([*lines, *(f"wrote {path}" for path in result["written"])])


def _plot_run(
    run: str, data_root: Path | None, out_dir: Path | None, law_path: Path | None, as_json: bool
) -> None:
    """Draw one run's signals into ``out_dir`` (balance/run_signal_plots.py)."""
    from ornitail.acquisition.recording_layout import RUN_METADATA_FILE_NAME, RUNS_FOLDER_NAME
    from ornitail.acquisition.recording_reader import load_recording
    from ornitail.balance.run_signal_plots import run_signals, write_run_signals_picture
    from ornitail.calibration.hotwire_laws import load_hotwire_law
    from ornitail.core.input_files import check_input_file, prepare_output_directory

    if out_dir is None:
        raise UserInputError("--out", "give the folder for the --plot picture")
    if not run.strip():
        raise UserInputError("--plot", "give a run id or a run folder")
    given = Path(run)
    root = data_root if data_root is not None else default_data_root()
    directory = given if given.is_dir() else root / RUNS_FOLDER_NAME / run
    if not directory.is_dir():
        raise UserInputError(
            "--plot",
            f"{run!r} is neither a run folder (with {RUN_METADATA_FILE_NAME}) nor a run id under "
            f"{root / RUNS_FOLDER_NAME}",
        )
    law = None if law_path is None else load_hotwire_law(check_input_file(law_path))
    prepare_output_directory(out_dir)
    recording = load_recording(directory)
    written = write_run_signals_picture(run_signals(recording, hotwire_law=law), out_dir)
    result = {
        "run_id": recording.run_id,
        "run_directory": str(directory),
        "set_points": len(recording.set_points),
        "hotwire_law": None if law_path is None else str(law_path),
        "written": [str(path) for path in written],
    }
    emit(result, as_json, _render_plot)
