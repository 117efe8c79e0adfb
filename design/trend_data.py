"""The observations trend fits learn from, and where each one came from.

One :class:`TrendObservation` is one measured value of one quantity for one configuration (a tail at a tail
position x_h). Sources (format of each: docs/design-trends.md):

- the study's published tables, shipped as package data with their citation (``vehicle/data/``): Table 3, steady
  states of six tails at x_h = 57 mm (source ``"study-table-3"``), and Table 4, derivatives of S1, S2, S3, S5 at
  x_h = 98 mm (``"study-table-4"``), read with the signs of Mu, Mw, Xq and Zq flipped into ornitail's frame
  (docs/frames.md);
- ``representative_models.csv``/``.json`` of ``ornitail flight campaign`` (``"flight-campaign:<file>"``);
- ``<cfg>-derivatives.csv``/``.json`` of ``ornitail process`` (``"tunnel:<file>"``);
- a user CSV with documented columns (``"user:<file>"``).

Values are SI (rad, m/s, Hz, N, N m, kg, kg m^2); derivatives in the body frame of docs/frames.md (positive M
nose-down). An empty cell (CSV) or ``null`` (JSON) means *not measured* and gives no observation; a written
``nan`` or ``inf`` is refused.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_input_text, read_json_file
from ornitail.vehicle.geometry import (
    TailGeometry,
    require_tail_position_mm,
    study_fuselages_x_h_m,
    study_tails,
)
from ornitail.vehicle.study_tables import (
    STUDY_SIGN_FLIPPED_DERIVATIVES,
    STUDY_TABLE_3,
    STUDY_TABLE_4,
    study_table_rows,
)

QUANTITIES = (
    "theta_ss_rad",
    "v_ss_m_s",
    "f_ss_hz",
    "Mq",
    "Mu",
    "Mw",
    "Xq",
    "Xu",
    "Xw",
    "Zq",
    "Zu",
    "Zw",
    "Mde",
    "Xde",
    "Zde",
)
"""Quantities a trend is fitted for: steady state (rad, m/s, Hz) and dimensional derivatives (SI)."""
MASS_QUANTITIES = ("mass_kg", "iyy_kg_m2")
"""Mass properties, fitted when a campaign table gives them (preferred by design/mass_model.py)."""
ALL_QUANTITIES = QUANTITIES + MASS_QUANTITIES

STUDY_FUSELAGE_X_H_MM = {letter: 1e3 * x_h_m for letter, x_h_m in study_fuselages_x_h_m().items()}
"""Fuselage letter -> x_h (mm), Table 1 of the study (``vehicle/data/fuselages.csv``)."""

_DERIVED_SIGMA_MAX_RELATIVE_ROUNDING = 0.5
_CAMPAIGN_STEADY_COLUMNS = {
    "theta0_rad": "theta_ss_rad",
    "airspeed_m_s": "v_ss_m_s",
    "flapping_frequency_hz": "f_ss_hz",
    "mass_kg": "mass_kg",
    "iyy_kg_m2": "iyy_kg_m2",
}
_CAMPAIGN_DERIVATIVES = ("Mq", "Mu", "Mw", "Xq", "Xu", "Xw", "Zq", "Zu", "Zw", "Mde", "Xde", "Zde")
_PLANFORM_COLUMNS = ("b_mm", "b_le_mm", "c_r_mm", "c_t_mm")
_TUNNEL_CONFIGURATION = re.compile(r"^\s*(?P<tail>\S+)\s+x_h=(?P<x_h_mm>[-+0-9.eE]+)\s*mm\s*$")
USER_CSV_REQUIRED_COLUMNS = ("tail", "x_h_mm", "quantity", "value")
USER_CSV_OPTIONAL_COLUMNS = ("configuration", "sigma", *_PLANFORM_COLUMNS)


@dataclass(frozen=True)
class TrendObservation:
    """One measured value: ``quantity`` (SI) of ``tail_id`` at ``x_h_m`` (m), 1-sigma error or None."""

    configuration: str
    tail_id: str
    geometry: TailGeometry
    x_h_m: float
    quantity: str
    value: float
    sigma: float | None
    source: str


def _study_geometry(tail_id: str, where: str) -> TailGeometry:
    tails = study_tails()
    if tail_id not in tails:
        raise UserInputError(
            where,
            f"tail {tail_id!r} is not a study tail and no planform (b_mm, b_le_mm, c_r_mm, c_t_mm) is "
            f"given; known tails: {', '.join(sorted(tails))}",
        )
    return tails[tail_id].geometry


def _split_study_configuration(configuration: str) -> tuple[str, float]:
    """``"S3b"`` -> ("S3", 0.098): tail name and x_h (m) from the fuselage letter."""
    return configuration[:-1], STUDY_FUSELAGE_X_H_MM[configuration[-1]] / 1000.0


def _decimals(text: str) -> int:
    return len(text.split(".")[1]) if "." in text else 0


def _sigma_from_published_ratio(measured: str, predicted: str, ratio: str) -> float | None:
    """sigma(meas) = |meas - pred| / ratio from Table 3's rounded numbers; None when rounding leaves it
    uncertain by more than 50 % (worst case: both values off by half a unit, the ratio by half a unit)."""
    difference = abs(float(measured) - float(predicted))
    ratio_value = float(ratio)
    if difference == 0.0 or ratio_value == 0.0:
        return None
    difference_rounding = 0.5 * 10.0 ** -_decimals(measured) + 0.5 * 10.0 ** -_decimals(predicted)
    ratio_rounding = 0.5 * 10.0 ** -_decimals(ratio)
    relative = difference_rounding / difference + ratio_rounding / ratio_value
    if relative > _DERIVED_SIGMA_MAX_RELATIVE_ROUNDING:
        return None
    return difference / ratio_value


def observations_from_study_table_3() -> list[TrendObservation]:
    """Table 3: measured steady states (theta, V, f) of six tails at x_h = 57 mm, one flight day.

    The table gives no sigma directly; it is recovered as ``|meas - pred| / sigma_ratio`` and left out (None)
    where the table's rounding makes it uncertain by more than 50 % (V of AR4 and S4).
    """
    columns = (
        ("theta_ss_rad", "theta", math.radians),
        ("v_ss_m_s", "v", float),
        ("f_ss_hz", "f", float),
    )
    observations = []
    for row in study_table_rows(STUDY_TABLE_3):
        tail_id, x_h_m = _split_study_configuration(row["tail"])
        geometry = _study_geometry(tail_id, "study table 3")
        for quantity, prefix, to_si in columns:
            unit = "_deg" if prefix == "theta" else ("_m_s" if prefix == "v" else "_hz")
            measured, predicted = row[f"{prefix}_meas{unit}"], row[f"{prefix}_pred{unit}"]
            sigma = _sigma_from_published_ratio(measured, predicted, row[f"{prefix}_sigma_ratio"])
            observations.append(
                TrendObservation(
                    configuration=row["tail"],
                    tail_id=tail_id,
                    geometry=geometry,
                    x_h_m=x_h_m,
                    quantity=quantity,
                    value=to_si(float(measured)),
                    sigma=None if sigma is None else to_si(sigma),
                    source="study-table-3",
                )
            )
    return observations


def observations_from_study_table_4() -> list[TrendObservation]:
    """Table 4: derivatives of S1, S2, S3, S5 at x_h = 98 mm in ornitail's frame (Mu, Mw, Xq, Zq flipped);
    sigma = rel_sigma_pct / 100 * |value|."""
    observations = []
    for row in study_table_rows(STUDY_TABLE_4):
        tail_id, x_h_m = _split_study_configuration(row["config"])
        published = float(row["value"])
        sign = -1.0 if row["parameter"] in STUDY_SIGN_FLIPPED_DERIVATIVES else 1.0
        observations.append(
            TrendObservation(
                configuration=row["config"],
                tail_id=tail_id,
                geometry=_study_geometry(tail_id, "study table 4"),
                x_h_m=x_h_m,
                quantity=row["parameter"],
                value=sign * published,
                sigma=float(row["rel_sigma_pct"]) / 100.0 * abs(published),
                source="study-table-4",
            )
        )
    return observations


def observations_from_study_tables() -> list[TrendObservation]:
    """Both published tables of the study (Rijks et al., AIAA 2018-0524, Tables 3 and 4)."""
    return observations_from_study_table_3() + observations_from_study_table_4()


def _number_or_missing(raw: Any, where: str) -> float | None:
    """A finite float; None for an empty cell / null; anything else (text, NaN, inf) is refused."""
    if raw is None or (isinstance(raw, str) and raw.strip() == ""):
        return None
    if isinstance(raw, bool):
        raise UserInputError(where, f"{raw!r} is not a number")
    try:
        value = float(raw)
    except (TypeError, ValueError):
        raise UserInputError(where, f"{raw!r} is not a number") from None
    if not math.isfinite(value):
        raise UserInputError(where, f"value {raw!r} is not a finite number")
    return value


def _sigma_or_missing(raw: Any, where: str) -> float | None:
    sigma = _number_or_missing(raw, where)
    if sigma is not None and sigma <= 0.0:
        raise UserInputError(where, f"sigma {sigma!r} must be positive (or the cell left empty)")
    return sigma


def _planform_from_row(row: dict[str, Any], where: str) -> TailGeometry | None:
    present = {name: row.get(name) for name in _PLANFORM_COLUMNS}
    if all(value in (None, "") for value in present.values()):
        return None
    dimensions = {}
    for name, raw in present.items():
        value = _number_or_missing(raw, f"{where}: {name}")
        if value is None and name != "b_le_mm":
            raise UserInputError(f"{where}: {name}", "planform dimension missing")
        dimensions[name] = value
    geometry = TailGeometry.from_mm(
        dimensions["b_mm"], dimensions["b_le_mm"], dimensions["c_r_mm"], dimensions["c_t_mm"]
    )
    return geometry.validate(f"{where}: planform")


def _geometry_of(row: dict[str, Any], tail_id: str, where: str) -> TailGeometry:
    return _planform_from_row(row, where) or _study_geometry(tail_id, f"{where}: tail")


def _x_h_m_from(raw: Any, where: str) -> float:
    value = _number_or_missing(raw, where)
    if value is None:
        raise UserInputError(where, "missing")
    return value


def _check_area(geometry: TailGeometry, row: dict[str, Any], where: str) -> None:
    """The campaign's area_m2 must match the planform the tail id names (catches a misused id)."""
    area = _number_or_missing(row.get("area_m2"), f"{where}: area_m2")
    if area is not None and abs(area - geometry.area_m2) > 0.01 * geometry.area_m2:
        raise UserInputError(
            f"{where}: area_m2",
            f"{area:.6g} m^2 does not match the planform of tail {row.get('tail')!r} "
            f"({geometry.area_m2:.6g} m^2)",
        )


def _campaign_records(path: Path) -> list[dict[str, Any]]:
    """Flat records (CSV layout) from a campaign table, CSV or JSON."""
    if path.suffix.lower() == ".json":
        document = _read_json(path)
        records = document.get("configurations") if isinstance(document, dict) else None
        if not isinstance(records, list) or document.get("format") != "ornitail flight campaign":
            raise UserInputError(
                str(path),
                "not a campaign table (format 'ornitail flight campaign', 'configurations')",
            )
        flat = []
        for record in records:
            row = {key: value for key, value in record.items() if key != "derivatives"}
            for name, estimate in (record.get("derivatives") or {}).items():
                row[name] = estimate.get("value")
                row[f"{name}_sigma"] = estimate.get("sigma")
            flat.append(row)
        return flat
    return _read_csv(path)


def _read_json(path: Path) -> Any:
    return read_json_file(path, finite=False)  # NaN/null cells are checked per field


def _read_csv(path: Path) -> list[dict[str, str]]:
    text = read_input_text(path)
    try:
        lines = (line for line in text.splitlines() if not line.startswith("#"))
        rows = list(csv.DictReader(lines))
    except csv.Error as error:
        raise UserInputError(str(path), f"not a readable CSV file ({error})") from None
    if not rows:
        raise UserInputError(str(path), "no data rows")
    return rows


def _require_columns(path: Path, row: dict[str, Any], columns: tuple[str, ...]) -> None:
    missing = [name for name in columns if name not in row]
    if missing:
        raise UserInputError(str(path), f"missing column(s) {', '.join(missing)}")


def observations_from_campaign(path: Path | str) -> list[TrendObservation]:
    """Observations from ``representative_models.csv``/``.json`` of ``ornitail flight campaign``: the steady
    state (theta0_rad, airspeed_m_s, flapping_frequency_hz), mass_kg, iyy_kg_m2 (no sigma) and every derivative
    with its ``_sigma``."""
    path = Path(path)
    source = f"flight-campaign:{path}"
    observations = []
    for row in _campaign_records(path):
        _require_columns(path, row, ("configuration", "tail", "x_h_m"))
        configuration = str(row["configuration"])
        where = f"{path}: configuration {configuration!r}"
        tail_id = str(row["tail"])
        geometry = _geometry_of(row, tail_id, where)
        _check_area(geometry, row, where)
        x_h_m = _x_h_m_from(row["x_h_m"], f"{where}: x_h_m")
        values = [
            (quantity, row.get(column), None)
            for column, quantity in _CAMPAIGN_STEADY_COLUMNS.items()
        ] + [(name, row.get(name), row.get(f"{name}_sigma")) for name in _CAMPAIGN_DERIVATIVES]
        for quantity, raw_value, raw_sigma in values:
            value = _number_or_missing(raw_value, f"{where}: {quantity}")
            if value is None:
                continue
            observations.append(
                TrendObservation(
                    configuration=configuration,
                    tail_id=tail_id,
                    geometry=geometry,
                    x_h_m=x_h_m,
                    quantity=quantity,
                    value=value,
                    sigma=_sigma_or_missing(raw_sigma, f"{where}: {quantity}_sigma"),
                    source=source,
                )
            )
    return observations


def _tunnel_configuration(label: str, where: str) -> tuple[str, float]:
    match = _TUNNEL_CONFIGURATION.match(label)
    if match is None:
        raise UserInputError(where, f"configuration {label!r} is not 'TAIL x_h=NNmm'")
    return match["tail"], float(match["x_h_mm"]) / 1000.0


def observations_from_tunnel(path: Path | str) -> list[TrendObservation]:
    """Observations from ``<cfg>-derivatives.csv``/``.json`` of ``ornitail process``: Xu, Xw, Zu, Zw, Mu, Mw
    with sigma (the tunnel cannot give the q-derivatives; frequency derivatives and steady loads are not
    trend quantities). The configuration label ``"S3 x_h=98mm"`` names a study tail."""
    path = Path(path)
    source = f"tunnel:{path}"
    if path.suffix.lower() == ".json":
        document = _read_json(path)
        if not isinstance(document, dict) or not isinstance(document.get("derivatives"), dict):
            raise UserInputError(str(path), "not a derivatives file of `ornitail process`")
        label = str(document.get("configuration"))
        rows = [
            {
                "configuration": label,
                "name": name,
                "value": item.get("value"),
                "sigma": item.get("sigma"),
            }
            for name, item in document["derivatives"].items()
        ]
    else:
        rows = _read_csv(path)
        _require_columns(path, rows[0], ("configuration", "name", "value", "sigma"))
    observations = []
    for row in rows:
        if row["name"] not in QUANTITIES:
            continue
        label = str(row["configuration"])
        where = f"{path}: {label} {row['name']}"
        tail_id, x_h_m = _tunnel_configuration(label, str(path))
        value = _number_or_missing(row["value"], f"{where}: value")
        if value is None:
            continue
        observations.append(
            TrendObservation(
                configuration=label,
                tail_id=tail_id,
                geometry=_study_geometry(tail_id, f"{path}: {label}"),
                x_h_m=x_h_m,
                quantity=row["name"],
                value=value,
                sigma=_sigma_or_missing(row["sigma"], f"{where}: sigma"),
                source=source,
            )
        )
    return observations


def observations_from_user_csv(path: Path | str) -> list[TrendObservation]:
    """Observations from a user CSV in long form: columns ``tail``, ``x_h_mm``, ``quantity`` (one of
    :data:`ALL_QUANTITIES`), ``value`` (SI), optional ``sigma``, ``configuration`` and planform ``b_mm``,
    ``b_le_mm``, ``c_r_mm``, ``c_t_mm`` (required for a tail that is not a study tail)."""
    path = Path(path)
    source = f"user:{path}"
    rows = _read_csv(path)
    _require_columns(path, rows[0], USER_CSV_REQUIRED_COLUMNS)
    observations = []
    for line_number, row in enumerate(rows, start=2):
        where = f"{path}: row {line_number}"
        quantity = row["quantity"].strip()
        if quantity not in ALL_QUANTITIES:
            raise UserInputError(
                f"{where}: quantity",
                f"unknown quantity {quantity!r}; known: {', '.join(ALL_QUANTITIES)}",
            )
        tail_id = row["tail"].strip()
        x_h_mm = _x_h_m_from(row["x_h_mm"], f"{where}: x_h_mm")
        require_tail_position_mm(f"{where}: x_h_mm", x_h_mm)
        value = _number_or_missing(row["value"], f"{where}: value")
        if value is None:
            raise UserInputError(f"{where}: value", "missing")
        observations.append(
            TrendObservation(
                configuration=(row.get("configuration") or "").strip() or f"{tail_id}@{x_h_mm:g}",
                tail_id=tail_id,
                geometry=_geometry_of(row, tail_id, where),
                x_h_m=x_h_mm / 1000.0,
                quantity=quantity,
                value=value,
                sigma=_sigma_or_missing(row.get("sigma"), f"{where}: sigma"),
                source=source,
            )
        )
    return observations
