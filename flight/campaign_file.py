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

import re
from dataclasses import dataclass
from pathlib import Path

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_toml_file
from ornitail.core.toml_table import TomlTable
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
_TOP_LEVEL_KEYS = ("seed", "model", "configuration", *_RULE_CHOICES)
_CONFIGURATION_KEYS = (
    "tail",
    "x_h_mm",
    "label",
    "planform",
    "mass_kg",
    "iyy_kg_m2",
    "log",
    "simulate",
)
_LOG_KEYS = ("path", "time_range_s")


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


_PLANFORM_KEYS = ("b_mm", "b_le_mm", "c_r_mm", "c_t_mm")
"""Keys of a configuration's ``planform`` table, mm (``b_le_mm`` optional: an elliptical leading edge)."""


def tail_geometry(tail: str, planform: TomlTable | None, where: str) -> TailGeometry:
    """Geometry of a study tail (``planform`` None; ``where`` names the tail in messages), or of a tail given by
    its ``planform`` table."""
    if planform is None:
        tails = study_tails()
        if tail not in tails:
            raise UserInputError(
                where,
                f"unknown tail {tail!r}: use a study tail ({', '.join(sorted(tails))}) "
                "or give its planform (b_mm, b_le_mm, c_r_mm, c_t_mm)",
            )
        return tails[tail].geometry
    geometry = TailGeometry.from_mm(
        planform.number("b_mm"),
        planform.number("b_le_mm", None),
        planform.number("c_r_mm"),
        planform.number("c_t_mm"),
    )
    return geometry.validate(planform.where())


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
    document = TomlTable(path, "", read_toml_file(path), _TOP_LEVEL_KEYS)
    seed = document.integer("seed", DEFAULT_SEED, maximum=MAX_SEED)
    model = document.text("model", DEFAULT_CAMPAIGN_MODEL)
    if model.endswith(".toml") and not Path(model).is_absolute():
        model = str(path.parent / model)
    tables = document.tables("configuration", _CONFIGURATION_KEYS, default=[])
    if not tables:
        raise UserInputError(document.where("configuration"), "no [[configuration]] listed")
    configurations = tuple(_configuration_from_table(table) for table in tables)
    _require_unique_labels(configurations, str(path))
    rules = {key: document.text(key, None, choices) for key, choices in _RULE_CHOICES.items()}
    return CampaignSpec(
        configurations=configurations,
        seed=seed,
        model=model,
        selection_rule=rules["selection_rule"] or DEFAULT_SELECTION_RULE,
        glitch_rule=rules["glitch_rule"] or DEFAULT_GLITCH_RULE,
        input_hold=rules["input_hold"],
        colored_sigma=rules["colored_sigma"] or DEFAULT_CAMPAIGN_COLORED_SIGMA,
    )


def _configuration_from_table(table: TomlTable) -> ConfigurationSpec:
    """One ``[[configuration]]`` table: tail, position, planform, mass properties and its data source."""
    tail = table.text("tail")
    x_h_mm = table.number("x_h_mm")
    require_tail_position_mm(table.where("x_h_mm"), x_h_mm)
    planform = table.sub_table("planform", _PLANFORM_KEYS, None)
    entries = table.tables("log", _LOG_KEYS, default=[], text_key="path")
    logs = tuple(_log_from_table(entry) for entry in entries)
    simulate = table.integer("simulate", 0, maximum=MAX_SIMULATED_MANOEUVRES)
    if not logs and simulate == 0:
        raise UserInputError(
            table.where(), "lists no [[configuration.log]] and simulate = 0: no data"
        )
    if logs and simulate:
        raise UserInputError(table.where(), "give either logs or simulate, not both")
    return ConfigurationSpec(
        label=table.text("label", f"{tail}@{x_h_mm:g}"),
        tail=tail,
        x_h_m=x_h_mm / 1000.0,
        geometry=tail_geometry(tail, planform, table.where("tail")),
        logs=logs,
        simulated_manoeuvres=simulate,
        mass_kg=table.number("mass_kg", None, positive=True),
        iyy_kg_m2=table.number("iyy_kg_m2", None, positive=True),
    )


def _log_from_table(entry: TomlTable) -> LogSource:
    """One log of a configuration: its path (relative to the campaign file) and optional time range."""
    log_path = Path(entry.text("path"))
    if not log_path.is_absolute():
        log_path = entry.path.parent / log_path
    return LogSource(log_path, entry.interval("time_range_s", None, bounds=("start", "end")))


def _require_unique_labels(configurations: tuple[ConfigurationSpec, ...], where: str) -> None:
    seen: set[str] = set()
    for configuration in configurations:
        if configuration.label in seen:
            raise UserInputError(where, f"configuration {configuration.label!r} is listed twice")
        seen.add(configuration.label)
