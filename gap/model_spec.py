"""The baseline-model file of a gap diagnosis (TOML, docs/gap-diagnosis.md).

```toml
[baseline]
kind = "simulator"              # or "linear_model"
tail = "S3"                     # study tail (simulator; also names the flight configuration)
x_h_mm = 98                     # tail position, mm
effects_off = ["added_mass"]    # simulator effects the baseline leaves out
# model = "delfly_longitudinal" # linear_model: preset or flight model file (its start values)
# candidates = ["added_mass", "input_delay"]   # optional: restrict the library
# segment_s = 1.0               # linear_model: cut logs into segments of this many seconds
# derivative_refit = false      # linear_model: skip the re-fit of the model's own derivatives (default: true)
# validation = "first-fold"     # rank and detect on the first fold's validation runs only (default: all-folds)
# null_directions = "any"        # flight: the detection rule's null directions as drawn (default
#                                # "top-set-orthogonal": stripped of the best candidates' responses;
#                                # "library-orthogonal": of every candidate's change; docs/gap-diagnosis.md)
# validation_weighting = "none"  # flight: every validation run by its energy (default for manoeuvres
#                                # "winsorised": a disturbed run counts as at most 3 x the median run's)
```

``tail`` and ``x_h_mm`` are required for the simulator and optional for a model file (they then
only label the report).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_toml_file
from ornitail.core.toml_table import REQUIRED, TomlTable
from ornitail.flight.model_file import load_model
from ornitail.sim.effects import EFFECT_NAMES
from ornitail.vehicle.geometry import require_tail_position_mm, study_tail_geometry

BASELINE_KINDS = ("simulator", "linear_model")
VALIDATION_DESIGNS = ("first-fold", "all-folds")
"""Which validation runs rank the candidates and calibrate the detection rule: every fold's pooled
("all-folds", the default), or the first fold's alone ("first-fold", the design before: docs/gap-diagnosis.md)."""
NULL_DIRECTIONS = ("any", "library-orthogonal", "top-set-orthogonal")
"""The detection rule's random directions of A and B (flight): as drawn ("any", the default until stop 37),
stripped of their part along the changes the library's candidates make ("library-orthogonal"), or drawn after the
ranking and stripped of the top set's candidates' first-order output responses ("top-set-orthogonal", the default:
docs/gap-diagnosis.md)."""
VALIDATION_WEIGHTINGS = ("none", "winsorised")
"""How much each validation run counts (flight): by its energy ("none"), or with a run's energy capped at a
multiple of the median run's ("winsorised", the default for manoeuvres since stop 43; segments get "none":
gap/validation_weighting.py)."""
FLIGHT_NULL_DIRECTIONS = "top-set-orthogonal"
"""The flight diagnosis' null directions when the baseline file names none."""


@dataclass(frozen=True)
class BaselineSpec:
    """What the diagnosis compares the data with (see the module docstring)."""

    kind: str
    tail: str = ""
    x_h_mm: float = math.nan
    effects_off: tuple[str, ...] = ()
    model: str = ""
    candidates: tuple[str, ...] = ()
    source: str = "baseline"
    segment_s: float | None = None  # linear_model: logs cut into segments of this length (s)
    # re-fit the model's derivatives too; None: yes for a linear_model
    derivative_refit: bool | None = None
    validation: str = "all-folds"  # one of VALIDATION_DESIGNS
    # one of NULL_DIRECTIONS; None: FLIGHT_NULL_DIRECTIONS (flight)
    null_directions: str | None = None
    # one of VALIDATION_WEIGHTINGS; None: winsorised for manoeuvres, none for segments (flight)
    validation_weighting: str | None = None

    def __post_init__(self) -> None:
        if self.derivative_refit is None:
            object.__setattr__(self, "derivative_refit", self.kind == "linear_model")


def require_flight_only_keys(spec: BaselineSpec, data: str) -> None:
    """Refuse the flight-only keys for ``data`` (tunnel or steady-state tables): a ``null_directions`` other than
    "any" (their null is drawn from the configuration variables, not from a flight model's A and B) and a
    ``validation_weighting`` other than "none" (their rule weighs points as they are)."""
    if spec.null_directions not in (None, "any"):
        raise UserInputError(
            f"{spec.source}: [baseline].null_directions",
            f"{spec.null_directions!r} is only for flight logs; {data} draw their null from the configuration "
            "variables",
        )
    if spec.validation_weighting not in (None, "none"):
        raise UserInputError(
            f"{spec.source}: [baseline].validation_weighting",
            f"{spec.validation_weighting!r} is only for flight logs; {data} weigh every point as it is",
        )


def _names(table: TomlTable, key: str, known: tuple[str, ...] | None) -> tuple[str, ...]:
    value = table.get(key, [])
    if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
        raise UserInputError(table.where(key), f"{value!r} must be a list of names")
    if known is not None:
        for item in value:
            if item not in known:
                raise UserInputError(
                    table.where(key), f"unknown effect {item!r}; known: {', '.join(known)}"
                )
    return tuple(value)


def read_baseline_spec(path: str | Path) -> BaselineSpec:
    """Read and check a baseline-model file; every mistake names the file and key."""
    path = Path(path)
    if not path.exists():
        raise UserInputError(str(path), "baseline model file not found")
    document = read_toml_file(path)
    unknown = sorted(set(document) - {"baseline"})
    if unknown:
        raise UserInputError(f"{path}: [{unknown[0]}]", "unknown table; expected [baseline]")
    table = TomlTable(
        path,
        "baseline",
        document.get("baseline"),
        (
            "kind",
            "tail",
            "x_h_mm",
            "effects_off",
            "model",
            "candidates",
            "segment_s",
            "derivative_refit",
            "validation",
            "null_directions",
            "validation_weighting",
        ),
    )
    kind = table.text("kind", choices=BASELINE_KINDS)
    optional = None if kind == "linear_model" else REQUIRED
    x_h_mm = table.number("x_h_mm", optional, positive=True)
    if x_h_mm is not None:
        require_tail_position_mm(table.where("x_h_mm"), x_h_mm)
    tail = table.text("tail", optional)
    if tail is not None:
        study_tail_geometry(tail, where=table.where("tail"))
    segment_s = table.number("segment_s", None, positive=True)
    refit = table.boolean("derivative_refit", None)
    validation = table.text("validation", "all-folds", choices=VALIDATION_DESIGNS)
    null_directions = table.text("null_directions", None, choices=NULL_DIRECTIONS)
    weighting = table.text("validation_weighting", None, choices=VALIDATION_WEIGHTINGS)
    for key, given in (("segment_s", segment_s is not None), ("derivative_refit", bool(refit))):
        if given and kind != "linear_model":
            raise UserInputError(table.where(key), "only for kind = linear_model (a model file)")
    model = ""
    if kind == "linear_model":
        model = table.text("model")
        candidate_file = (path.parent / model).resolve()
        if candidate_file.exists():
            model = str(candidate_file)
        load_model(model)  # a missing, unreadable or malformed model is refused here, by name
    return BaselineSpec(
        kind=kind,
        tail=tail or "",
        x_h_mm=math.nan if x_h_mm is None else x_h_mm,
        segment_s=segment_s,
        derivative_refit=refit,
        validation=validation,
        null_directions=null_directions,
        validation_weighting=weighting,
        effects_off=_names(table, "effects_off", EFFECT_NAMES),
        model=model,
        candidates=_names(table, "candidates", None),
        source=str(path),
    )


def write_baseline_spec(spec: BaselineSpec, path: str | Path) -> Path:
    """Write ``spec`` as a baseline-model file (the inverse of :func:`read_baseline_spec`)."""
    lines = ["[baseline]", f'kind = "{spec.kind}"']
    if spec.tail:
        lines.append(f'tail = "{spec.tail}"')
    if math.isfinite(spec.x_h_mm):
        lines.append(f"x_h_mm = {spec.x_h_mm:g}")
    lines.append("effects_off = [" + ", ".join(f'"{name}"' for name in spec.effects_off) + "]")
    if spec.segment_s is not None:
        lines.append(f"segment_s = {spec.segment_s:g}")
    if spec.kind == "linear_model" and not spec.derivative_refit:
        lines.append("derivative_refit = false")
    if spec.validation != "all-folds":
        lines.append(f'validation = "{spec.validation}"')
    if spec.null_directions is not None:
        lines.append(f'null_directions = "{spec.null_directions}"')
    if spec.validation_weighting is not None:
        lines.append(f'validation_weighting = "{spec.validation_weighting}"')
    if spec.model:
        lines.append(f'model = "{spec.model}"')
    if spec.candidates:
        lines.append("candidates = [" + ", ".join(f'"{n}"' for n in spec.candidates) + "]")
    path = Path(path)
    path.write_text("\n".join(lines) + "\n")
    return path
