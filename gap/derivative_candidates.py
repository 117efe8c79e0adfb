"""Derivative-level candidates: one stability or control derivative, or one inertia, changed.

Each is a one-parameter family about the baseline (k = 0 is the baseline), the "where in the
model" counterpart of the measurement and simulator effects:

| name | simulator (states q, u, w, theta; dimensional, SI) | model file (its parameter or constant) |
|---|---|---|
| ``pitch_damping`` | M_q + k (N m s/rad) | ``Mq`` (or ``Cmq``) + k |
| ``static_stability`` | M_w + k (N s) | ``Mw`` (or ``Ma``, ``Malpha``, ``Cma``, ``Cmalpha``) + k |
| ``speed_stability`` | M_u + k (N s) | ``Mu`` (or ``Cmu``) + k |
| ``heave_damping`` | Z_w + k (N s/m) | ``Zw`` (or ``Za``, ``Zalpha``, ``CZa``, ``CZalpha``, ``Cza``, ``Czalpha``) + k |
| ``control_power`` | M_de + k (N m/rad) | ``Mde`` (or ``Mdeltae``, ``Mdelta``, ``Meta``, ``Cmde``, ``Cmdeltae``) + k |
| ``iyy_shift`` | q-row of A and B / (1 + k) | constant ``Iyy`` x (1 + k) |
| ``heave_added_mass`` | w-row of A and B / (1 + k) | the same, when the model has a state ``w`` |

A model file's parameter is matched with its underscores left out, so ``M_q``, ``M_alpha``, ``Cm_alpha`` or
``M_delta_e`` are found too; the first of the file's parameters that matches is the one acted on.

A derivative ranges over +-3 x its baseline value (a sign change and a tripling both inside); one
whose baseline value is zero has no scale to range over and is skipped, saying so. Heave added mass
m_a acts on the heave acceleration only: (m + m_a) dw/dt = Z + m (u0 q - g sin(theta0) theta), so
the whole w-row is divided by 1 + k, k = m_a / m (its pitching counterpart M_wdot is left out).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from functools import lru_cache

import numpy as np

from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.gap.flight_data import MODEL_UNIT
from ornitail.gap.flight_model import FlightCandidate, LinearFlightModel

INERTIA_BOUNDS = (-0.5, 2.0)  # fraction: an inertia from half to three times the baseline's
DERIVATIVE_RANGE = 3.0  # a derivative ranges over +- this many times its baseline value

MODEL_PARAMETERS: dict[str, tuple[str, ...]] = {
    "pitch_damping": ("Mq", "Cmq"),
    "static_stability": ("Mw", "Ma", "Malpha", "Cma", "Cmalpha"),
    "speed_stability": ("Mu", "Cmu"),
    "heave_damping": ("Zw", "Za", "Zalpha", "CZa", "CZalpha", "Cza", "Czalpha"),
    "control_power": ("Mde", "Mdeltae", "Mdelta", "Meta", "Cmde", "Cmdeltae"),
}
"""Candidate name -> the model-file parameter names it acts on, underscores left out (module
docstring)."""


def model_parameter_for(candidate: str, parameter_names: Sequence[str]) -> str | None:
    """The model file's parameter that ``candidate`` acts on (the first whose name, underscores
    left out, is one of :data:`MODEL_PARAMETERS`), or None."""
    spellings = MODEL_PARAMETERS[candidate]
    return next((name for name in parameter_names if name.replace("_", "") in spellings), None)


DERIVATIVE_LEVEL_CANDIDATES = (*MODEL_PARAMETERS, "iyy_shift", "heave_added_mass")
"""Every derivative-level candidate's name: a finding about the model's own parameters, not a named
unmodelled effect."""


SIMULATOR_ENTRIES: dict[str, tuple[str, str, int, int, str]] = {
    "pitch_damping": ("M_q", "a", 0, 0, "N m s/rad"),
    "static_stability": ("M_w", "a", 0, 2, "N s"),
    "speed_stability": ("M_u", "a", 0, 1, "N s"),
    "heave_damping": ("Z_w", "a", 2, 2, "N s/m"),
    "control_power": ("M_de", "b", 0, 0, "N m/rad"),
}
"""Candidate name -> (derivative, matrix, row, column, unit) in the simulator's linear model
(states q, u, w, theta; an M-row entry is the derivative over I_yy, a Z-row entry over m)."""


def _row_inertia(
    baseline: LinearFlightModel, name: str, state: str, description: str
) -> FlightCandidate:
    """``state``'s row of A and B divided by (1 + k): that equation's inertia times (1 + k)."""
    row = baseline.state_names.index(state)

    @lru_cache(maxsize=256)
    def build(k: float) -> LinearFlightModel:
        a_matrix, b_matrix = baseline.a_matrix.copy(), baseline.b_matrix.copy()
        a_matrix[row] /= 1.0 + k
        b_matrix[row] /= 1.0 + k
        return baseline.with_matrices(a_matrix, b_matrix)

    return FlightCandidate(name, description, "fraction", INERTIA_BOUNDS, build)


def _range(value: float) -> tuple[float, float]:
    reach = DERIVATIVE_RANGE * abs(value)
    return (-reach, reach)


def _heave_added_mass(
    baseline: LinearFlightModel,
) -> tuple[list[FlightCandidate], dict[str, str]]:
    if "w" not in baseline.state_names:
        return [], {"heave_added_mass": "the model has no state w (heave velocity)"}
    candidate = _row_inertia(
        baseline, "heave_added_mass", "w", "heave added mass: the w-row of A and B / (1 + k)"
    )
    return [candidate], {}


def simulator_derivatives(
    baseline: LinearFlightModel,
) -> tuple[list[FlightCandidate], dict[str, str]]:
    """Derivative-level candidates on the simulator's linearisation (module table)."""
    scales = {"M": baseline.iyy_kg_m2, "Z": baseline.mass_kg}
    candidates = [
        _row_inertia(baseline, "iyy_shift", "q", "pitch inertia: the q-row of A and B / (1 + k)")
    ]
    skipped = {}
    for name, (derivative, matrix, row, column, unit) in SIMULATOR_ENTRIES.items():
        scale = scales[derivative[0]]
        value = (baseline.a_matrix if matrix == "a" else baseline.b_matrix)[row, column] * scale
        if not (np.isfinite(value) and value != 0.0):
            skipped[name] = f"the baseline's {derivative} is {value:g}: no scale for its range"
            continue

        @lru_cache(maxsize=256)
        def build(k: float, matrix=matrix, row=row, column=column, scale=scale):
            a_matrix, b_matrix = baseline.a_matrix.copy(), baseline.b_matrix.copy()
            (a_matrix if matrix == "a" else b_matrix)[row, column] += k / scale
            return baseline.with_matrices(a_matrix, b_matrix)

        candidates.append(
            FlightCandidate(name, f"{derivative} changed by k", unit, _range(value), build)
        )
    added_mass, added_mass_skipped = _heave_added_mass(baseline)
    return candidates + added_mass, skipped | added_mass_skipped


def model_derivatives(
    model: StateSpaceModelSpec,
    constants: Mapping[str, float],
    baseline: LinearFlightModel,
    rebuilt: Callable[[Mapping[str, float], Mapping[str, float]], LinearFlightModel],
) -> tuple[list[FlightCandidate], dict[str, str]]:
    """Derivative-level candidates on a model file (module table): each only where the file names
    what it acts on. ``rebuilt(values, constants)`` is the baseline at other parameter values."""
    values = model.start_values()
    candidates, skipped = [], {}
    if "Iyy" in constants:
        candidates.append(
            FlightCandidate(
                "iyy_shift",
                "constant Iyy times (1 + k)",
                "fraction",
                INERTIA_BOUNDS,
                lru_cache(maxsize=256)(
                    lambda k: rebuilt(values, {**constants, "Iyy": constants["Iyy"] * (1 + k)})
                ),
            )
        )
    else:
        skipped["iyy_shift"] = f"{model.name} declares no constant Iyy (pitch inertia)"
    for name, parameters in MODEL_PARAMETERS.items():
        parameter = model_parameter_for(name, model.parameter_names)
        if parameter is None:
            skipped[name] = (
                f"{model.name} has no parameter {' or '.join(parameters[:3])} (or the like)"
            )
            continue
        if values[parameter] == 0.0:
            skipped[name] = f"{model.name}'s {parameter} starts at 0: no scale for its range"
            continue
        candidates.append(
            FlightCandidate(
                name,
                f"parameter {parameter} changed by k",
                model.parameter(parameter).unit or MODEL_UNIT,
                _range(values[parameter]),
                lru_cache(maxsize=256)(
                    lambda k, p=parameter: rebuilt({**values, p: values[p] + k}, constants)
                ),
            )
        )
    added_mass, added_mass_skipped = _heave_added_mass(baseline)
    return candidates + added_mass, skipped | added_mass_skipped
