"""Export recordings and processed tables to MATLAB (.mat), Parquet or NetCDF, with units (docs/export.md).

A recording (a run directory) becomes two tables, ``samples`` (sample counter, time and one column per channel in
its raw unit) and ``set_points`` (the journal's set-point table); a CSV file (``cycle-averages.csv``,
``<cfg>-tail-contribution.csv``, ``<cfg>-derivatives.csv``, ``<cfg>-phase-average.csv``,
``representative_models.csv``, ...) becomes one table. A column's unit is read from its name
(:func:`unit_from_column_name`); a column whose name carries no unit is written without one.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import check_input_file, read_csv_table

FORMATS = ("mat", "parquet", "netcdf")
"""Export formats: MATLAB 5 ``.mat`` (scipy), Parquet (pyarrow), NetCDF-4 (xarray with h5netcdf)."""

_UNIT_SUFFIXES: dict[tuple[str, ...], str] = {
    ("n", "m"): "N m",
    ("m", "s"): "m/s",
    ("rad", "s"): "rad/s",
    ("deg", "s"): "deg/s",
    ("kg", "m2"): "kg m^2",
    ("1", "s"): "1/s",
    ("n",): "N",
    ("m",): "m",
    ("mm",): "mm",
    ("m2",): "m^2",
    ("s",): "s",
    ("kg",): "kg",
    ("deg",): "deg",
    ("rad",): "rad",
    ("hz",): "Hz",
    ("v",): "V",
    ("rpm",): "rpm",
    ("pa",): "Pa",
}
"""Name suffixes (tokens between underscores, lower case) and the unit they stand for."""

_SAME_UNIT_QUALIFIERS = frozenset(
    {
        "2sigma",
        "sigma",
        "se",
        "std",
        "mean",
        "tare",
        "before",
        "after",
        "terms",
        "cycle",
        "tailed",
        "tailless",
    }
)
"""Name tokens after the unit that keep the quantity's unit (``x_n_2sigma``, ``theta_measured_deg_tailed``)."""


def unit_from_column_name(name: str) -> str | None:
    """The unit a column's name says, e.g. ``"N m"`` for ``m_n_m_se``, ``"m/s"`` for ``v_measured_m_s``.

    The name's last tokens (split at ``_``) are read after dropping qualifiers that keep the unit (``2sigma``,
    ``se``, ``sigma``, ``std``, ``mean``, ``tare``, ``before``, ``after``, ``terms``, ``cycle``, ``tailed``,
    ``tailless``); a unit suffix must follow at least one token naming the quantity. ``None`` when the name
    carries no unit: a count, a flag, text, a ratio (``x_n_repeat_inflation_tailed``), or a quantity whose unit
    the name does not say (``Xu`` of the campaign table): dimensionless or not known from the name.
    """
    tokens = name.lower().split("_")
    while tokens and tokens[-1] in _SAME_UNIT_QUALIFIERS:
        tokens.pop()
    for length in (2, 1):
        if len(tokens) > length and tuple(tokens[-length:]) in _UNIT_SUFFIXES:
            return _UNIT_SUFFIXES[tuple(tokens[-length:])]
    return None


@dataclass
class ExportTable:
    """One table to export: columns of equal length, their units and the table's attributes.

    Attributes
    ----------
    name : str
        Table name (a MATLAB struct name, a NetCDF group, part of a Parquet file name).
    frame : pandas.DataFrame
        The columns, numeric, boolean or text.
    units : dict
        Column name -> unit, for the columns that have one.
    dimension : str
        Name of the row dimension (NetCDF), e.g. ``sample`` or ``row``.
    attributes : dict
        Table attributes (source file, run id, sample rate in Hz ...).
    """

    name: str
    frame: pd.DataFrame
    units: dict[str, str]
    dimension: str = "row"
    attributes: dict[str, str | float | int] = field(default_factory=dict)


def _plain_column(column: pd.Series) -> pd.Series:
    """A column as numbers, booleans or text: missing text is ``""`` (text formats have no missing value)."""
    if column.dtype != object and not pd.api.types.is_string_dtype(column):
        return column
    values = [value for value in column if value is not None and not _is_nan(value)]
    if values and all(isinstance(value, bool | np.bool_) for value in values):
        if len(values) == len(column):
            return column.astype(bool)
        return column.map(
            lambda value: float(value) if isinstance(value, bool | np.bool_) else math.nan
        )
    if all(
        isinstance(value, int | float | np.number) and not isinstance(value, bool)
        for value in values
    ):
        return pd.to_numeric(column.map(lambda value: math.nan if value is None else value))
    return column.map(lambda value: "" if value is None or _is_nan(value) else str(value)).astype(
        object
    )


def _is_nan(value: Any) -> bool:
    return isinstance(value, float) and math.isnan(value)


def _table_name(stem: str) -> str:
    """A MATLAB-safe name for a table: letters, digits and ``_``, starting with a letter."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", stem)
    return name if re.match(r"[A-Za-z]", name) else f"t_{name}"


def table_from_frame(
    name: str,
    frame: pd.DataFrame,
    source: str,
    units: Mapping[str, str] | None = None,
    dimension: str = "row",
    attributes: Mapping[str, str | float | int] | None = None,
) -> ExportTable:
    """An :class:`ExportTable` of ``frame``: units from the column names unless ``units`` gives them."""
    frame = pd.DataFrame({str(column): _plain_column(frame[column]) for column in frame.columns})
    given = dict(units or {})
    column_units = {}
    for column in frame.columns:
        unit = given[column] if column in given else unit_from_column_name(column)
        if unit:
            column_units[column] = unit
    return ExportTable(
        name=_table_name(name),
        frame=frame,
        units=column_units,
        dimension=dimension,
        attributes={"source": source, **dict(attributes or {})},
    )


def csv_tables(path: Path) -> list[ExportTable]:
    """A CSV table (e.g. one ``ornitail process`` or ``ornitail flight campaign`` wrote) as one table."""
    frame = read_csv_table(path)
    return [table_from_frame(path.stem, frame, str(path))]


def recording_tables(run_directory: Path) -> list[ExportTable]:
    """A run directory's ``samples`` (channels in their raw units) and ``set_points`` tables."""
    from ornitail.acquisition.recording_reader import load_recording

    recording = load_recording(run_directory)
    samples = recording.samples_frame()  # a missing samples.h5 is refused naming it
    units = {"sample_counter": "count", "time_s": "s"}
    units.update({channel.name: channel.unit for channel in recording.channels})
    attributes = {
        "run_id": recording.run_id,
        "sample_rate_hz": recording.sample_rate_hz,
        "status": recording.status,
    }
    return [
        table_from_frame(
            "samples",
            samples.reset_index(drop=True),
            str(recording.samples_path),
            units,
            "sample",
            attributes,
        ),
        table_from_frame(
            "set_points",
            recording.set_points_frame(),
            str(run_directory / "journal.jsonl"),
            dimension="set_point",
            attributes={"run_id": recording.run_id},
        ),
    ]


def input_tables(path: Path) -> list[ExportTable]:
    """The tables of one input: a CSV file (``.csv``) or a run directory (a folder with ``run.json``)."""
    path = Path(path)
    if path.suffix.lower() == ".csv":
        return csv_tables(path)
    if path.is_dir():
        return recording_tables(path)
    check_input_file(path)  # a missing path or a device is named as such
    raise UserInputError(str(path), "not a run directory or a CSV table (.csv)")


def _matlab_fields(table: ExportTable) -> dict[str, Any]:
    """A table as a MATLAB struct: one field per column, ``units`` and ``attributes`` structs."""
    struct: dict[str, Any] = {}
    units: dict[str, str] = {}
    for column in table.frame.columns:
        field_name = _table_name(column)[:63]
        if field_name in struct or field_name in ("units", "attributes"):
            raise UserInputError(
                str(table.attributes["source"]),
                f"column {column!r} becomes the MATLAB field {field_name!r}, which another column or the "
                "table's units or attributes already use",
            )
        values = table.frame[column].to_numpy()
        struct[field_name] = values.astype(object) if values.dtype == object else values
        units[field_name] = table.units.get(column, "")
    struct["units"] = units
    struct["attributes"] = dict(table.attributes)
    return struct


def _write_mat(tables: Sequence[ExportTable], path: Path) -> list[Path]:
    import scipy.io

    scipy.io.savemat(
        path,
        {table.name: _matlab_fields(table) for table in tables},
        long_field_names=True,
        oned_as="column",
        do_compression=True,
    )
    return [path]


def _arrow_table(table: ExportTable) -> Any:
    import pyarrow as pa

    arrow = pa.Table.from_pandas(table.frame, preserve_index=False)
    fields = [
        arrow.schema.field(name).with_metadata(
            {"units": table.units[name]} if name in table.units else None
        )
        for name in arrow.column_names
    ]
    metadata = {**(arrow.schema.metadata or {}), b"ornitail_table": table.name.encode()}
    metadata.update({key.encode(): str(value).encode() for key, value in table.attributes.items()})
    return arrow.cast(pa.schema(fields, metadata=metadata))


def _write_parquet(tables: Sequence[ExportTable], stem: Path) -> list[Path]:
    import pyarrow.parquet as pq

    paths = []
    for table in tables:
        path = stem.with_name(
            f"{stem.name}.parquet" if len(tables) == 1 else f"{stem.name}-{table.name}.parquet"
        )
        pq.write_table(_arrow_table(table), path)
        paths.append(path)
    return paths


def _dataset(table: ExportTable) -> Any:
    import xarray as xr

    variables = {}
    for column in table.frame.columns:
        values = table.frame[column].to_numpy()
        if values.dtype == object:
            values = values.astype(str)
        attributes = {"units": table.units[column]} if column in table.units else {}
        variables[column] = xr.Variable((table.dimension,), values, attributes)
    return xr.Dataset(variables, attrs={"ornitail_table": table.name, **table.attributes})


def _write_netcdf(tables: Sequence[ExportTable], path: Path) -> list[Path]:
    for index, table in enumerate(tables):
        dataset = _dataset(table)
        compressed = {  # long numeric variables deflated (short ones would grow; text stays as it is)
            name: {"zlib": True, "complevel": 4}
            for name, variable in dataset.variables.items()
            if variable.dtype.kind in "biuf" and variable.size >= 4096
        }
        dataset.to_netcdf(
            path,
            mode="w" if index == 0 else "a",
            engine="h5netcdf",
            group=None if len(tables) == 1 else table.name,
            encoding=compressed,
        )
    return [path]


_SUFFIXES = {"mat": ".mat", "parquet": "", "netcdf": ".nc"}


def export_inputs(inputs: Sequence[Path], export_format: str, out: Path) -> list[Path]:
    """Write every input (run directory or CSV table) to ``out`` in ``export_format``; return the files written.

    One file per input (``<run id>.mat``, ``cycle-averages.nc``), except Parquet: one file per table
    (``<run id>-samples.parquet``, ``<run id>-set_points.parquet``, ``cycle-averages.parquet``).

    Raises
    ------
    UserInputError
        An input that is not a recording or a readable CSV table, two inputs with the same name, or columns
        that collide as MATLAB field names.
    """
    if export_format not in FORMATS:
        raise UserInputError(export_format, f"unknown export format (one of {', '.join(FORMATS)})")
    stems: dict[str, Path] = {}
    for path in inputs:
        stem = Path(path).name if Path(path).is_dir() else Path(path).stem
        if stem in stems:
            raise UserInputError(
                str(path), f"has the same name as {stems[stem]}; export them one at a time"
            )
        stems[stem] = Path(path)
    writers = {"mat": _write_mat, "parquet": _write_parquet, "netcdf": _write_netcdf}
    written: list[Path] = []
    for stem, path in stems.items():
        tables = input_tables(path)
        target = Path(out) / f"{stem}{_SUFFIXES[export_format]}"
        written += writers[export_format](tables, target)
    return written
