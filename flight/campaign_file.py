"""What a campaign analyses: configurations, their flight logs or simulated flights (format:
docs/flight-campaign.md).

A configuration is a tail (a study tail id such as ``S3``, or any id with its planform in mm) at a
tail position x_h. Its data come from flight logs (each optionally restricted to a time range)
or from the simulator. Mass and pitch inertia are needed by the DelFly model to turn the
identified A-matrix entries into dimensional derivatives; for simulated flights they come from
the simulator's vehicle model. The campaign also names the rules it runs by: how the
representative model is selected, how elevator glitches are detected, and (optionally) the input
hold of the model's discretisation.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_toml_file
from ornitail.flight.manoeuvres import DEFAULT_GLITCH_RULE, GLITCH_RULES
from ornitail.flight.model_file import INPUT_HOLDS
from ornitail.flight.residual_statistics import COLORED_SIGMA_METHODS
from ornitail.flight.validation import DEFAULT_SELECTION_RULE, SELECTION_RULES
from ornitail.vehicle.geometry import TailGeometry, require_tail_position_mm, study_tails

CONFIGURATION_LABEL = re.compile(r"^(?P<tail>[A-Za-z][A-Za-z0-9_]*)@(?P<x_h_mm>[0-9.]+)$")
DEFAULT_SIMULATED_MANOEUVRES = 21
DEFAULT_CAMPAIGN_MODEL = "delfly_longitudinal_bias"
"""The campaign's default model: the study's DelFly model plus constant state-equation biases
(nuisance parameters; docs/flight-campaign.md, "Bias terms"). ``delfly_longitudinal`` is the
study's own model, without them."""
DEFAULT_CAMPAIGN_COLORED_SIGMA = "morelli"
"""The campaign's colored-residual sigma formula (docs/flight-campaign.md, "Sigma options")."""
DEFAULT_SEED = 2018
MAX_SEED = 2**32 - 1
"""Largest seed accepted (numpy's legacy seed range; seeds are 0..2**32 - 1)."""
MAX_SIMULATED_MANOEUVRES = 1000
"""Most doublet manoeuvres simulated per configuration."""
_RULE_CHOICES = {  # optional top-level keys of a campaign file and their allowed values
    "selection_rule": SELECTION_RULES,
    "glitch_rule": GLITCH_RULES,
    "input_hold": INPUT_HOLDS,
    "colored_sigma": COLORED_SIGMA_METHODS,
}


@dataclass(frozen=True)
class LogSource:
    """A flight log file and the part of it to use (log clock, s; None = all)."""

    path: Path
    time_range_s: tuple[float, float] | None = None


@dataclass(frozen=True)
class ConfigurationSpec:
    """One tail at one position with its data source (logs, or simulated manoeuvres)."""

    label: str
    tail: str
    x_h_m: float
    geometry: TailGeometry
    logs: tuple[LogSource, ...] = ()
    simulated_manoeuvres: int = 0
    mass_kg: float | None = None
    iyy_kg_m2: float | None = None

    @property
    def area_m2(self) -> float:
        return self.geometry.area_m2

    @property
    def aspect_ratio(self) -> float:
        return self.geometry.aspect_ratio


@dataclass(frozen=True)
class CampaignSpec:
    """Configurations to analyse, the split seed, the model (preset name or file path) and the
    rules: ``selection_rule`` (:data:`SELECTION_RULES`), ``glitch_rule`` (:data:`GLITCH_RULES`)
    ``input_hold`` (:data:`INPUT_HOLDS`; None keeps the model's own) and ``colored_sigma``
    (:data:`COLORED_SIGMA_METHODS`: the standard-error formula of every fit).
    """

    configurations: tuple[ConfigurationSpec, ...]
    seed: int = DEFAULT_SEED
    model: str = DEFAULT_CAMPAIGN_MODEL
    selection_rule: str = DEFAULT_SELECTION_RULE
    glitch_rule: str = DEFAULT_GLITCH_RULE
    input_hold: str | None = None
    colored_sigma: str = DEFAULT_CAMPAIGN_COLORED_SIGMA


def parse_configuration_label(label: str, where: str) -> tuple[str, float]:
    """``"S3@98"`` -> (``"S3"``, 0.098): tail id and x_h in metres (label in millimetres)."""
    match = CONFIGURATION_LABEL.match(label.strip())
    if not match:
        raise UserInputError(where, f"{label!r} is not TAIL@X_H_MM (e.g. S3@98)")
    x_h_mm = float(match.group("x_h_mm"))
    require_tail_position_mm(where, x_h_mm)
    return match.group("tail"), x_h_mm / 1000.0


def tail_geometry(tail: str, planform_mm: dict[str, Any] | None, where: str) -> TailGeometry:
    """Geometry of a study tail, or of a tail given as ``{b_mm, b_le_mm, c_r_mm, c_t_mm}``."""
    if planform_mm is None:
        tails = study_tails()
        if tail not in tails:
            raise UserInputError(
                where,
                f"unknown tail {tail!r}: use a study tail ({', '.join(sorted(tails))}) "
                "or give its planform (b_mm, b_le_mm, c_r_mm, c_t_mm)",
            )
        return tails[tail].geometry
    values = {}
    for key in ("b_mm", "c_r_mm", "c_t_mm"):
        values[key] = _number(planform_mm, key, f"{where}.planform")
    b_le = planform_mm.get("b_le_mm")
    b_le_mm = None if b_le is None else _number(planform_mm, "b_le_mm", f"{where}.planform")
    geometry = TailGeometry.from_mm(values["b_mm"], b_le_mm, values["c_r_mm"], values["c_t_mm"])
    return geometry.validate(f"{where}.planform")


def _number(table: dict[str, Any], key: str, where: str) -> float:
    value = table.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise UserInputError(f"{where}.{key}", f"must be a number, got {value!r}")
    if not math.isfinite(value):
        raise UserInputError(f"{where}.{key}", f"value {value!r} is not a finite number")
    return float(value)


def _positive_or_none(table: dict[str, Any], key: str, where: str) -> float | None:
    if key not in table:
        return None
    value = _number(table, key, where)
    if value <= 0:
        raise UserInputError(f"{where}.{key}", f"must be positive, got {value!r}")
    return value


def configuration_from_label(
    label: str,
    where: str,
    logs: tuple[LogSource, ...] = (),
    simulated_manoeuvres: int = 0,
    mass_kg: float | None = None,
    iyy_kg_m2: float | None = None,
) -> ConfigurationSpec:
    """A study-tail configuration from a ``TAIL@X_H_MM`` label."""
    tail, x_h_m = parse_configuration_label(label, where)
    return ConfigurationSpec(
        label=f"{tail}@{x_h_m * 1000:g}",
        tail=tail,
        x_h_m=x_h_m,
        geometry=tail_geometry(tail, None, where),
        logs=logs,
        simulated_manoeuvres=simulated_manoeuvres,
        mass_kg=mass_kg,
        iyy_kg_m2=iyy_kg_m2,
    )


def read_campaign_file(path: str | Path) -> CampaignSpec:
    """Read a campaign TOML file (docs/flight-campaign.md); log paths relative to the file."""
    path = Path(path)
    if not path.exists():
        raise UserInputError(str(path), "campaign file not found")
    document = read_toml_file(path)
    unknown = sorted(set(document) - {"seed", "model", "configuration", *_RULE_CHOICES})
    if unknown:
        raise UserInputError(f"{path}: {unknown[0]}", "unknown top-level key")
    seed = document.get("seed", DEFAULT_SEED)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise UserInputError(
            f"{path}: seed", f"must be a non-negative integer up to {MAX_SEED}, got {seed!r}"
        )
    model = document.get("model", DEFAULT_CAMPAIGN_MODEL)
    if not isinstance(model, str):
        raise UserInputError(f"{path}: model", "must be a preset name or a model-file path")
    if model.endswith(".toml") and not Path(model).is_absolute():
        model = str(path.parent / model)
    tables = document.get("configuration")
    if not isinstance(tables, list) or not tables:
        raise UserInputError(f"{path}: [[configuration]]", "no configuration listed")
    configurations = tuple(
        _configuration_from_table(table, f"{path}: configuration[{index + 1}]", path.parent)
        for index, table in enumerate(tables)
    )
    _require_unique_labels(configurations, str(path))
    rules = {key: _choice(document, key, str(path)) for key in _RULE_CHOICES}
    return CampaignSpec(
        configurations=configurations,
        seed=seed,
        model=model,
        selection_rule=rules["selection_rule"] or DEFAULT_SELECTION_RULE,
        glitch_rule=rules["glitch_rule"] or DEFAULT_GLITCH_RULE,
        input_hold=rules["input_hold"],
        colored_sigma=rules["colored_sigma"] or DEFAULT_CAMPAIGN_COLORED_SIGMA,
    )


def _choice(document: dict[str, Any], key: str, where: str) -> str | None:
    """The value of an optional top-level key that must be one of ``_RULE_CHOICES[key]``."""
    value = document.get(key)
    if value is not None and value not in _RULE_CHOICES[key]:
        raise UserInputError(
            f"{where}: {key}", f"must be one of {', '.join(_RULE_CHOICES[key])}, got {value!r}"
        )
    return value


def _configuration_from_table(table: Any, where: str, base: Path) -> ConfigurationSpec:
    if not isinstance(table, dict):
        raise UserInputError(where, "must be a table")
    allowed = {"tail", "x_h_mm", "label", "planform", "mass_kg", "iyy_kg_m2", "log", "simulate"}
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise UserInputError(f"{where}.{unknown[0]}", "unknown key")
    tail = table.get("tail")
    if not isinstance(tail, str) or not tail:
        raise UserInputError(f"{where}.tail", 'must name the tail (e.g. "S3")')
    x_h_mm = _number(table, "x_h_mm", where)
    require_tail_position_mm(f"{where}.x_h_mm", x_h_mm)
    planform = table.get("planform")
    if planform is not None and not isinstance(planform, dict):
        raise UserInputError(
            f"{where}.planform", "must be a table of b_mm, b_le_mm, c_r_mm, c_t_mm"
        )
    logs = []
    for index, entry in enumerate(table.get("log", [])):
        logs.append(_log_from_table(entry, f"{where}.log[{index + 1}]", base))
    simulate = table.get("simulate", 0)
    if (
        isinstance(simulate, bool)
        or not isinstance(simulate, int)
        or not 0 <= simulate <= MAX_SIMULATED_MANOEUVRES
    ):
        raise UserInputError(
            f"{where}.simulate",
            f"must be a number of manoeuvres in 0..{MAX_SIMULATED_MANOEUVRES}, got {simulate!r}",
        )
    if not logs and simulate == 0:
        raise UserInputError(where, "lists no [[configuration.log]] and simulate = 0: no data")
    if logs and simulate:
        raise UserInputError(where, "give either logs or simulate, not both")
    label = table.get("label", f"{tail}@{x_h_mm:g}")
    if not isinstance(label, str) or not label:
        raise UserInputError(f"{where}.label", "must be a non-empty string")
    return ConfigurationSpec(
        label=label,
        tail=tail,
        x_h_m=x_h_mm / 1000.0,
        geometry=tail_geometry(tail, planform, where),
        logs=tuple(logs),
        simulated_manoeuvres=simulate,
        mass_kg=_positive_or_none(table, "mass_kg", where),
        iyy_kg_m2=_positive_or_none(table, "iyy_kg_m2", where),
    )


def _log_from_table(entry: Any, where: str, base: Path) -> LogSource:
    if isinstance(entry, str):
        entry = {"path": entry}
    if not isinstance(entry, dict) or not isinstance(entry.get("path"), str):
        raise UserInputError(where, 'must give path = "log.csv" (and optionally time_range_s)')
    unknown = sorted(set(entry) - {"path", "time_range_s"})
    if unknown:
        raise UserInputError(f"{where}.{unknown[0]}", "unknown key")
    log_path = Path(entry["path"])
    if not log_path.is_absolute():
        log_path = base / log_path
    time_range = entry.get("time_range_s")
    if time_range is not None:
        if (
            not isinstance(time_range, list)
            or len(time_range) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in time_range)
            or not time_range[0] < time_range[1]
        ):
            raise UserInputError(f"{where}.time_range_s", f"{time_range!r} is not [start, end]")
        time_range = (float(time_range[0]), float(time_range[1]))
    return LogSource(log_path, time_range)


def _require_unique_labels(configurations: tuple[ConfigurationSpec, ...], where: str) -> None:
    seen: set[str] = set()
    for configuration in configurations:
        if configuration.label in seen:
            raise UserInputError(where, f"configuration {configuration.label!r} is listed twice")
        seen.add(configuration.label)
