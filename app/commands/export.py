"""``ornitail export``: recordings and processed tables to MATLAB, Parquet or NetCDF, with units."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.core.input_files import prepare_output_directory


def _render(result: dict[str, Any]) -> str:
    return "\n".join(f"wrote {path}" for path in result["written"])


@click.command("export")
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option(
    "--format",
    "export_format",
    type=click.Choice(["mat", "parquet", "netcdf"]),
    required=True,
    help="mat: MATLAB struct per table with a units struct; parquet: units in the schema's field metadata; "
    "netcdf: units as variable attributes.",
)
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="Folder for the exported files (created if needed).",
)
@json_option
def export_command(inputs: tuple[Path, ...], export_format: str, out: Path, as_json: bool) -> None:
    """Export run directories or processed tables (CSV) to MATLAB, Parquet or NetCDF with units.

    Each INPUT is a run directory (its samples and set-point table) or a CSV table that `ornitail process` or
    `ornitail flight campaign` wrote (docs/export.md).
    """
    from ornitail.app.export import export_inputs  # imported here: --help stays fast

    prepare_output_directory(out)
    written = export_inputs(list(inputs), export_format, out)
    emit({"written": [str(path) for path in written]}, as_json, _render)
