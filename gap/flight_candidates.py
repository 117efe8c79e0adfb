"""The baseline flight model and the library of candidate effects, each a one-parameter family.

A candidate turns a magnitude ``k`` into a :class:`LinearFlightModel`; ``k = 0`` is the baseline.

Simulator effects (only when the baseline is the simulator with that effect switched off):

- ``added_mass``, ``flapping_frequency_coupling``: the effect switched on with its magnitude
  parameter (``coefficient``, ``gain``) set to ``k``, linearised about its own trim;
- ``wake_profile``, ``cg_shift_with_x_h``, ``day_to_day_drift``: no single magnitude knob, so
  ``k`` blends the linearisations with the effect off (0) and on (1).

Low-order augmentations of any linear model:

- ``iyy_shift``: pitch inertia times (1 + k): the q-row of A and B divided by (1 + k);
- ``pitch_damping``: M_q changed by k (N m s/rad);
- ``input_delay``: the elevator acts k seconds after it is logged;
- ``theta_drift``: the measured pitch attitude drifts by k rad/s.

``added_mass`` and ``iyy_shift`` change the model in the same way (added inertia *is* inertia to
the rigid-body equations): the data cannot tell them apart, and the ranking reports them together.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.flight.model_file import load_model
from ornitail.gap.flight_model import LinearFlightModel
from ornitail.gap.model_spec import BaselineSpec
from ornitail.sim.configuration import VehicleConfiguration, study_configuration
from ornitail.sim.dynamics import TrimNotFoundError, linearise
from ornitail.sim.effects import EFFECT_SCOPES, EffectSet

MODEL_STATES = ("q", "u", "w", "theta")
SIMULATOR_MAGNITUDES = {"added_mass": "coefficient", "flapping_frequency_coupling": "gain"}
SIMULATOR_BLENDS = ("wake_profile", "cg_shift_with_x_h", "day_to_day_drift")


@dataclass(frozen=True)
class FlightCandidate:
    """One candidate effect: ``build(k)`` is the model with the effect at magnitude ``k``."""

    name: str
    description: str
    unit: str
    bounds: tuple[float, float]
    build: Callable[[float], LinearFlightModel]


def _simulator_model(configuration: VehicleConfiguration, effects: EffectSet) -> LinearFlightModel:
    try:
        linear = linearise(configuration, effects)
    except TrimNotFoundError as error:
        raise UserInputError(configuration.name, str(error)) from error
    return LinearFlightModel(
        a_matrix=linear.a_matrix,
        b_matrix=linear.b_matrix,
        iyy_kg_m2=linear.iyy_kg_m2,
        theta0_rad=linear.trim.theta_rad,
        airspeed_m_s=linear.trim.airspeed_m_s,
    )


def baseline_effects(spec: BaselineSpec) -> EffectSet:
    return EffectSet().without(*spec.effects_off)


def baseline_flight_model(spec: BaselineSpec) -> LinearFlightModel:
    """The baseline as a linear model: the simulator linearised, or a model file's start values."""
    if spec.kind == "simulator":
        configuration = study_configuration(spec.tail, spec.x_h_mm)
        return _simulator_model(configuration, baseline_effects(spec))
    model = load_model(spec.model)
    if model.states != MODEL_STATES or model.inputs != ("elevator",):
        raise UserInputError(
            f"{spec.source}: model",
            f"{model.name} has states {list(model.states)} and inputs {list(model.inputs)}; "
            "the flight diagnosis needs states q, u, w, theta and input elevator",
        )
    if model.data_constants:
        raise UserInputError(
            f"{spec.source}: model", "constants taken from data are not supported here"
        )
    numeric = model.state_space(model.start_values(), model.constants)
    if not (np.allclose(numeric.c_matrix, np.eye(4)) and np.allclose(numeric.d_matrix, 0.0)):
        raise UserInputError(f"{spec.source}: model", "outputs must be the four states (C = I)")
    constants = model.constants
    airspeed = math.hypot(constants.get("u0", math.nan), constants.get("w0", math.nan))
    return LinearFlightModel(
        a_matrix=numeric.a_matrix,
        b_matrix=numeric.b_matrix,
        iyy_kg_m2=float(constants.get("Iyy", math.nan)),
        theta0_rad=float(constants.get("theta0", math.nan)),
        airspeed_m_s=airspeed,
        input_hold=model.input_hold,
    )


def _simulator_candidates(spec: BaselineSpec, baseline: LinearFlightModel) -> list[FlightCandidate]:
    configuration = study_configuration(spec.tail, spec.x_h_mm)
    effects = baseline_effects(spec)
    candidates = []
    for name in spec.effects_off:
        if EFFECT_SCOPES[name] == "tunnel":
            continue
        if name in SIMULATOR_MAGNITUDES:
            parameter = SIMULATOR_MAGNITUDES[name]

            @lru_cache(maxsize=256)
            def build(k: float, name: str = name, parameter: str = parameter):
                switched = effects.with_enabled(name).replace_effect(name, **{parameter: k})
                return _simulator_model(configuration, switched)

            candidates.append(
                FlightCandidate(
                    name,
                    f"simulator effect {name} with {parameter} = k",
                    parameter,
                    (0.0, 8.0) if name == "added_mass" else (0.0, 25.0),
                    build,
                )
            )
        elif name in SIMULATOR_BLENDS:
            switched_on = _simulator_model(configuration, effects.with_enabled(name))
            a_step = switched_on.a_matrix - baseline.a_matrix
            b_step = switched_on.b_matrix - baseline.b_matrix
            if np.max(np.abs(a_step)) < 1e-9 and np.max(np.abs(b_step)) < 1e-9:
                continue  # e.g. cg_shift_with_x_h at its reference position: nothing to see

            def blend(k: float, a_step=a_step, b_step=b_step) -> LinearFlightModel:
                return baseline.with_matrices(
                    baseline.a_matrix + k * a_step, baseline.b_matrix + k * b_step
                )

            candidates.append(
                FlightCandidate(
                    name,
                    f"simulator effect {name}, blended off (0) to on (1)",
                    "x effect",
                    (-1.0, 3.0),
                    blend,
                )
            )
    return candidates


def _augmentations(baseline: LinearFlightModel) -> list[FlightCandidate]:
    def iyy_shift(k: float) -> LinearFlightModel:
        a_matrix, b_matrix = baseline.a_matrix.copy(), baseline.b_matrix.copy()
        a_matrix[0] /= 1.0 + k
        b_matrix[0] /= 1.0 + k
        return baseline.with_matrices(a_matrix, b_matrix)

    inertia = baseline.iyy_kg_m2 if math.isfinite(baseline.iyy_kg_m2) else 1.0
    damping_unit = "N m s/rad" if math.isfinite(baseline.iyy_kg_m2) else "1/s"
    damping_range = 3.0 * abs(baseline.a_matrix[0, 0]) * inertia + 1e-12

    def pitch_damping(k: float) -> LinearFlightModel:
        a_matrix = baseline.a_matrix.copy()
        a_matrix[0, 0] += k / inertia
        return baseline.with_matrices(a_matrix, baseline.b_matrix)

    return [
        FlightCandidate(
            "iyy_shift", "pitch inertia times (1 + k)", "fraction", (-0.5, 2.0), iyy_shift
        ),
        FlightCandidate(
            "pitch_damping",
            "M_q changed by k",
            damping_unit,
            (-damping_range, damping_range),
            pitch_damping,
        ),
        FlightCandidate(
            "input_delay",
            "elevator acts k s after it is logged",
            "s",
            (-0.1, 0.25),
            lambda k: replace(baseline, delay_s=k),
        ),
        FlightCandidate(
            "theta_drift",
            "measured theta drifts by k",
            "rad/s",
            (-0.05, 0.05),
            lambda k: replace(baseline, theta_drift_rad_s=k),
        ),
    ]


def flight_candidates(spec: BaselineSpec, baseline: LinearFlightModel) -> list[FlightCandidate]:
    """The candidate library for this baseline, restricted to ``spec.candidates`` when given."""
    library = _augmentations(baseline)
    if spec.kind == "simulator":
        library = _simulator_candidates(spec, baseline) + library
    if spec.candidates:
        known = {candidate.name for candidate in library}
        unknown = [name for name in spec.candidates if name not in known]
        if unknown:
            raise UserInputError(
                f"{spec.source}: [baseline].candidates",
                f"{unknown[0]!r} is not available for this baseline; available: "
                f"{', '.join(sorted(known))}",
            )
        library = [candidate for candidate in library if candidate.name in spec.candidates]
    return library
