"""``ornitail process``: cycle-averaged table, tail contribution, derivatives and figures from recorded runs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ornitail.acquisition.calibration_copies import CalibrationSources
from ornitail.app.cli_output import emit, json_option
from ornitail.app.progress import Progress
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import prepare_output_directory

PROGRESS_DELAY_S = 1.0
"""In a terminal the progress bar appears only once processing has taken this long (s); in a log, progress lines
are timestamped and start at once (``ornitail.app.progress``)."""


def _render(result: dict[str, Any]) -> str:
    lines = [f"cycle-averaged table: {result['table_csv']}"]
    for configuration in result["configurations"]:
        lines.append("")
        lines.append(f"== {configuration['configuration']} ==")
        derivatives = configuration.get("derivatives")
        if derivatives:
            lines += derivatives["statements"][:1]
            lines.append(f"{'':6s}{'value':>14s}{'sigma':>12s}  unit")
            for name, entry in derivatives["derivatives"].items():
                if entry["value"] is None or entry["value"] != entry["value"]:
                    continue
                lines.append(
                    f"{name:6s}{entry['value']:>+14.6g}{entry['sigma']:>12.2g}  {entry['unit']}"
                )
            lines += derivatives["statements"][1:]
        lines += [configuration["drift_statement"]] if "drift_statement" in configuration else []
        lines += configuration.get("tail_statements", [])
    lines.append("")
    lines += [f"wrote {path}" for path in result["written"]]
    return "\n".join(lines)


@click.command("process")
@click.argument("runs", nargs=-1, type=click.Path(path_type=Path))
@click.option(
    "--plan",
    "plan_name",
    default=None,
    help="Process the newest sweep (chain of runs) of the plan with this name in the catalog.",
)
@click.option(
    "--data-root",
    type=click.Path(path_type=Path),
    default=None,
    help="Where runs and the catalog live, for --plan [default: $ORNITAIL_DATA or ./ornitail-data].",
)
@click.option(
    "--out",
    "out",
    type=click.Path(path_type=Path),
    required=True,
    help="Folder for the tables (CSV, JSON) and figures (PNG, PDF).",
)
@click.option(
    "--keep-saturated",
    is_flag=True,
    help="Process set points whose record or tare has samples at the ADC limit or over the sensor's "
    "rated load (refused by default), flagged in the table and named in the warnings.",
)
@click.option(
    "--search-path",
    "search_path",
    multiple=True,
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    help="Folder to search (not its subfolders) for a balance calibration file with the content a run was "
    "recorded with, when neither the run folder's copy nor the recorded path has it. Repeatable.",
)
@click.option(
    "--cal",
    "calibration_override",
    type=click.Path(path_type=Path),
    default=None,
    help="Balance calibration file to use for every run instead of the recorded one; a file whose content "
    "differs from the recorded one is used with a warning.",
)
@json_option
def process_command(
    runs: tuple[Path, ...],
    plan_name: str | None,
    data_root: Path | None,
    out: Path,
    keep_saturated: bool,
    search_path: tuple[Path, ...],
    calibration_override: Path | None,
    as_json: bool,
) -> None:
    """Cycle-average recorded runs; write tail contribution, stability derivatives and figures."""
    from ornitail.acquisition.catalog import default_data_root  # imported here: --help stays fast
    from ornitail.balance.process_runs import newest_sweep_chain, process_runs

    if runs and plan_name:
        raise UserInputError("--plan", "give run directories or --plan, not both")
    prepare_output_directory(out)
    run_directories = (
        newest_sweep_chain(data_root or default_data_root(), plan_name) if plan_name else list(runs)
    )
    progress = Progress("process", 0, "set points", bar_delay_s=PROGRESS_DELAY_S)
    try:
        result = process_runs(
            run_directories,
            out,
            on_progress=lambda done, total: progress.update(done, total=total),
            keep_saturated=keep_saturated,
            calibration_sources=CalibrationSources(
                search_path=search_path,
                overrides={} if calibration_override is None else {"balance": calibration_override},
            ),
        )
    finally:
        progress.close()
    for warning in result["warnings"]:
        click.echo(warning, err=True)
    emit(result, as_json, _render)
