"""Steady-state tables (one row per flown configuration) as the gap diagnosis reads them.

Two layouts are recognised by their header:

- the campaign table ``representative_models.csv`` of ``ornitail flight campaign``
  (docs/flight-campaign.md): ``tail``, ``x_h_m``, ``theta0_deg``, ``airspeed_m_s``, optional
  ``flapping_frequency_hz``, optional ``configuration`` (row label);
- a plain table: ``tail``, ``x_h_mm``, ``theta_ss_deg``, ``v_ss_m_s``, optional ``f_ss_hz``.

Either may carry the standard error of each value as ``<column>_sigma`` (same unit); without it
the channel's :data:`DEFAULT_SIGMA` applies. A frequency column that is empty in every row counts
as absent. Tails are study tails (vehicle/data/tails.csv; ``AR3`` is read as ``S3``, the same tail).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_csv_table
from ornitail.gap.table_checks import csv_header, finite_column
from ornitail.vehicle.geometry import study_tails

CHANNELS = ("theta_ss", "v_ss", "f_ss")
CHANNEL_UNITS = ("rad", "m/s", "Hz")
# Standard error of a steady state averaged over a flight's run-ins (SI: rad, m/s, Hz), the
# scatter of ``ornitail gap example --kind steady``. docs/background.md section 6: steady states drift
# between days; the study's single-flight scatter (reference/steady_state_validation.csv) is
# about 2 deg, 0.1 m/s, 0.5 Hz, so give *_sigma columns when the table is not averaged.
DEFAULT_SIGMA = np.array([math.radians(0.5), 0.02, 0.05])
MINIMUM_CONFIGURATIONS = 5
TAIL_ALIASES = {"AR3": "S3"}


@dataclass(frozen=True)
class Layout:
    """Column names of one layout per channel, and the unit factor to SI."""

    x_h: str
    x_h_to_m: float
    values: tuple[str, str, str]
    to_si: tuple[float, float, float]


CAMPAIGN = Layout(
    "x_h_m", 1.0, ("theta0_deg", "airspeed_m_s", "flapping_frequency_hz"), (math.pi / 180, 1, 1)
)
PLAIN = Layout("x_h_mm", 1e-3, ("theta_ss_deg", "v_ss_m_s", "f_ss_hz"), (math.pi / 180, 1, 1))


def _layout_of(header: set[str]) -> Layout | None:
    for layout in (CAMPAIGN, PLAIN):
        if {"tail", layout.x_h, *layout.values[:2]} <= header:
            return layout
    return None


def is_steady_table(path: str | Path) -> bool:
    """True for a CSV whose header holds a steady-state layout's tail, x_h, theta and V columns."""
    return _layout_of(csv_header(path)) is not None


def _within(path: Path, column: str, values: np.ndarray, low: float, high: float) -> None:
    bad = np.flatnonzero((values <= low) | (values >= high))
    if bad.size:
        raise UserInputError(
            f"{path}: column {column}",
            f"value {values[bad[0]]:g} in data row {bad[0] + 1} is outside {low:g}-{high:g}",
        )


def _tails(path: Path, table: pd.DataFrame) -> list[str]:
    known = study_tails()
    names = []
    for row, raw in enumerate(table["tail"].astype(str).str.strip()):
        name = TAIL_ALIASES.get(raw, raw)
        if name not in known:
            raise UserInputError(
                f"{path}: column tail",
                f"unknown tail {raw!r} in data row {row + 1}; known: {', '.join(sorted(known))}",
            )
        names.append(name)
    return names


def read_steady_table(path: Path) -> pd.DataFrame:
    """Rows ``label, tail, x_h_m`` and per channel its value and ``<channel>_sigma`` in SI.

    Channels without a column (frequency only) are left out. Every mistake names file, column, row.
    """
    table = read_csv_table(path)
    layout = _layout_of(set(table.columns))
    if layout is None:
        raise UserInputError(
            str(path),
            "steady-state table needs columns tail, x_h_mm, theta_ss_deg, v_ss_m_s (or the "
            "campaign's tail, x_h_m, theta0_deg, airspeed_m_s)",
        )
    if len(table) < MINIMUM_CONFIGURATIONS:
        raise UserInputError(
            str(path),
            f"{len(table)} configuration(s); the diagnosis needs at least {MINIMUM_CONFIGURATIONS}",
        )
    x_h_m = finite_column(path, table, layout.x_h) * layout.x_h_to_m
    _within(
        path, layout.x_h, x_h_m / layout.x_h_to_m, 0.02 / layout.x_h_to_m, 0.3 / layout.x_h_to_m
    )
    tails = _tails(path, table)
    labels = (
        table["configuration"].astype(str)
        if "configuration" in table.columns
        else [f"{t}@{1000 * x:g}" for t, x in zip(tails, x_h_m, strict=True)]
    )
    rows = pd.DataFrame({"label": list(labels), "tail": tails, "x_h_m": x_h_m})
    limits = ((0.0, 90.0), (0.0, 10.0), (0.0, 100.0))
    for index, (channel, column) in enumerate(zip(CHANNELS, layout.values, strict=True)):
        if column not in table.columns or table[column].isna().all():
            continue
        values = finite_column(path, table, column)
        _within(path, column, values, *limits[index])
        sigma = np.full(len(table), DEFAULT_SIGMA[index])
        if f"{column}_sigma" in table.columns:
            sigma = finite_column(path, table, f"{column}_sigma") * layout.to_si[index]
            _within(path, f"{column}_sigma", sigma / layout.to_si[index], 0.0, math.inf)
        rows[channel] = values * layout.to_si[index]
        rows[f"{channel}_sigma"] = sigma
    return rows
