"""Tunnel cycle-averaged tables (``cycle-averages.csv`` of ``ornitail process``,
docs/processed-tables.md) as the gap diagnosis reads them; recorded run directories (docs/recordings.md) are
cycle-averaged here first, all together, exactly as ``ornitail process`` does.

Only tailed rows are used: their loads are about the tailed vehicle's CG, the point the simulator
reports its aerodynamic loads about. Columns used: ``tail_id``, ``x_h_mm``, ``tailed``,
``theta_deg``, ``v_m_s``, ``f_set_hz`` (or ``f_hall_hz`` when present), ``x_n``, ``z_n``,
``m_n_m``, and optionally ``sweep``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.acquisition.recording_layout import RUN_METADATA_FILE_NAME
from ornitail.balance.sweep_table import cycle_averaged_table
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_csv_table
from ornitail.gap.table_checks import csv_header, finite_column

LOAD_COLUMNS = ("x_n", "z_n", "m_n_m")
LOAD_UNITS = ("N", "N", "N m")
REQUIRED_COLUMNS = ("tail_id", "x_h_mm", "tailed", "theta_deg", "v_m_s", "f_set_hz", *LOAD_COLUMNS)
MINIMUM_POINTS = 6


def is_tunnel_table(path: str | Path) -> bool:
    """True for a recorded run directory, or a CSV whose header holds the cycle-average table's load and
    set-point columns."""
    path = Path(path)
    if is_run_directory(path):
        return True
    return {"x_n", "m_n_m", "theta_deg", "tail_id"} <= csv_header(path)


def _as_bool(value: object) -> bool:
    if isinstance(value, bool | np.bool_):
        return bool(value)
    return str(value).strip().lower() in ("true", "1", "yes")


def is_run_directory(path: Path) -> bool:
    """True for a recording's run directory (it holds ``run.json``)."""
    return path.is_dir() and (path / RUN_METADATA_FILE_NAME).is_file()


def _tables(paths: list[Path]) -> list[tuple[str, pd.DataFrame]]:
    """(label, cycle-average table) per CSV, and one for all run directories together (a tailless run's tares
    and a tailed run's points may sit in different runs of one sweep)."""
    runs = [path for path in paths if is_run_directory(Path(path))]
    tables = [
        (str(path), read_csv_table(path)) for path in paths if not is_run_directory(Path(path))
    ]
    if runs:
        tables.append((", ".join(str(run) for run in runs), cycle_averaged_table(runs)))
    return tables


def read_tunnel_points(paths: list[Path]) -> pd.DataFrame:
    """Tailed set points of every table or run directory, checked: finite numbers, known ranges, enough
    points."""
    frames = []
    for path, table in _tables(paths):
        missing = [column for column in REQUIRED_COLUMNS if column not in table.columns]
        if missing:
            raise UserInputError(
                str(path),
                f"tunnel table lacks column(s) {', '.join(missing)} (see docs/processed-tables.md)",
            )
        table = table[table["tailed"].map(_as_bool)].copy()
        frequency = "f_hall_hz" if "f_hall_hz" in table.columns else "f_set_hz"
        for column in ("x_h_mm", "theta_deg", "v_m_s", frequency, *LOAD_COLUMNS):
            table[column] = finite_column(path, table, column)
        if ((table["v_m_s"] <= 0) | (table[frequency] <= 0)).any():
            raise UserInputError(
                str(path), "tailed rows need wind on and motor on (v_m_s > 0, frequency > 0)"
            )
        points = pd.DataFrame(
            {
                "source": str(path),
                "tail_id": table["tail_id"].astype(str),
                "x_h_mm": table["x_h_mm"],
                "theta_rad": np.radians(table["theta_deg"]),
                "v_m_s": table["v_m_s"],
                "f_hz": table[frequency],
                "sweep": table["sweep"].astype(str) if "sweep" in table.columns else "",
                **{column: table[column] for column in LOAD_COLUMNS},
            }
        )
        frames.append(points)
    points = pd.concat(frames, ignore_index=True)
    if len(points) < MINIMUM_POINTS:
        raise UserInputError(
            ", ".join(str(p) for p in paths),
            f"{len(points)} tailed set point(s); the diagnosis needs at least {MINIMUM_POINTS}",
        )
    if not math.isfinite(float(points["x_h_mm"].min())):
        raise UserInputError(str(paths[0]), "x_h_mm must be given for every row")
    return points
