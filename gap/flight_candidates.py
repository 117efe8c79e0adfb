"""The baseline flight model and the library of candidate effects, each a one-parameter family.

A candidate turns a magnitude ``k`` into a :class:`LinearFlightModel`; ``k = 0`` is the baseline.

Simulator effects (only when the baseline is the simulator with that effect switched off):

- ``added_mass``, ``flapping_frequency_coupling``: the effect switched on with its magnitude
  parameter (``coefficient``, ``gain``) set to ``k``, linearised about its own trim;
- ``wake_profile``, ``cg_shift_with_x_h``, ``day_to_day_drift``: no single magnitude knob, so
  ``k`` blends the linearisations with the effect off (0) and on (1).

Low-order augmentations of any linear model, each only where the model has what it acts on
(otherwise it is skipped, and the report says why: :attr:`CandidateLibrary.skipped`):

- derivative level (:mod:`ornitail.gap.derivative_candidates`): ``pitch_damping``,
  ``static_stability``, ``speed_stability``, ``heave_damping`` and ``control_power`` (M_q, M_w,
  M_u, Z_w, M_de changed by k), ``iyy_shift`` (pitch inertia times 1 + k) and
  ``heave_added_mass`` (heave inertia times 1 + k);
- ``input_delay``, ``input_filter``: an input (each one not held constant by the model file)
  acts k seconds after it is logged, or is logged through a first-order low-pass of time
  constant k (s); with one such input the names are plain, with several they end in
  ``_<input>``;
- ``theta_drift``: the measured output ``theta`` drifts by k (rad/s);
- ``<output>_bias``: the output is measured with a constant offset k (its unit), for every output
  the runs hold as absolute values (in deviations from a run-in an offset cancels).

``added_mass`` and ``iyy_shift`` change the model in the same way (added inertia *is* inertia to
the rigid-body equations): the data cannot tell them apart, and the ranking reports them together.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.flight.model_file import StateSpaceModelSpec, load_model
from ornitail.gap.derivative_candidates import model_derivatives, simulator_derivatives
from ornitail.gap.flight_model import FlightCandidate, LinearFlightModel
from ornitail.gap.model_spec import BaselineSpec
from ornitail.sim.configuration import VehicleConfiguration, study_configuration
from ornitail.sim.dynamics import TrimNotFoundError, linearise
from ornitail.sim.effects import EFFECT_SCOPES, EffectSet

SIMULATOR_MAGNITUDES = {"added_mass": "coefficient", "flapping_frequency_coupling": "gain"}
SIMULATOR_BLENDS = ("wake_profile", "cg_shift_with_x_h", "day_to_day_drift")
DELAY_BOUNDS_S = (-0.1, 0.25)
FILTER_BOUNDS_S = (0.0, 0.25)
BIAS_RANGE_SPREADS = 3.0  # an output bias may reach 3 x the output's spread over the runs


@dataclass(frozen=True)
class CandidateLibrary:
    """The candidates a diagnosis fits, and the augmentations it skipped with the reason."""

    candidates: list[FlightCandidate]
    skipped: dict[str, str]


def _simulator_model(configuration: VehicleConfiguration, effects: EffectSet) -> LinearFlightModel:
    try:
        linear = linearise(configuration, effects)
    except TrimNotFoundError as error:
        raise UserInputError(configuration.name, str(error)) from error
    return LinearFlightModel(
        a_matrix=linear.a_matrix,
        b_matrix=linear.b_matrix,
        iyy_kg_m2=linear.iyy_kg_m2,
        mass_kg=linear.mass_kg,
        theta0_rad=linear.trim.theta_rad,
        airspeed_m_s=linear.trim.airspeed_m_s,
    )


def baseline_effects(spec: BaselineSpec) -> EffectSet:
    return EffectSet().without(*spec.effects_off)


def model_constants(
    spec: BaselineSpec, data_constants: Mapping[str, float] | None
) -> dict[str, float]:
    """The model file's constants, with those it takes from data from ``data_constants``."""
    model = load_model(spec.model)
    if model.data_constants and data_constants is None:
        raise UserInputError(
            f"{spec.source}: model", "constants taken from data need the flight logs"
        )
    return {**model.constants, **(data_constants or {})}


def model_matrices(
    model: StateSpaceModelSpec, values: Mapping[str, float], constants: Mapping[str, float]
) -> dict[str, np.ndarray]:
    """A, B, C, D of ``model`` at these parameter and constant values, as model fields."""
    numeric = model.state_space(values, constants)
    return {
        "a_matrix": numeric.a_matrix,
        "b_matrix": numeric.b_matrix,
        "c_matrix": numeric.c_matrix,
        "d_matrix": numeric.d_matrix,
    }


def _dynamic_rows(model: StateSpaceModelSpec, constants: Mapping[str, float]) -> tuple[int, ...]:
    """State equations whose A or B entries depend on the model's parameters."""

    def joined(values: Mapping[str, float]) -> np.ndarray:
        numeric = model.state_space(values, constants)
        return np.hstack([numeric.a_matrix, numeric.b_matrix])

    values = model.start_values()
    moved = {name: 1.37 * value + 0.0123 for name, value in values.items()}  # every one moves
    changed = np.any(joined(values) != joined(moved), axis=1)
    return tuple(int(row) for row in np.flatnonzero(changed))


def baseline_flight_model(
    spec: BaselineSpec, data_constants: Mapping[str, float] | None = None
) -> LinearFlightModel:
    """The baseline as a linear model: the simulator linearised, or a model file's start values
    (with the constants it takes from data from ``data_constants``)."""
    if spec.kind == "simulator":
        configuration = study_configuration(spec.tail, spec.x_h_mm)
        return _simulator_model(configuration, baseline_effects(spec))
    model = load_model(spec.model)
    constants = model_constants(spec, data_constants)
    airspeed = math.hypot(constants.get("u0", math.nan), constants.get("w0", math.nan))
    return LinearFlightModel(
        **model_matrices(model, model.start_values(), constants),
        iyy_kg_m2=float(constants.get("Iyy", math.nan)),
        mass_kg=float(constants.get("m", math.nan)),
        theta0_rad=float(constants.get("theta0", math.nan)),
        airspeed_m_s=airspeed,
        input_hold=model.input_hold,
        state_names=model.states,
        input_names=model.inputs,
        output_names=model.outputs,
        dynamic_rows=_dynamic_rows(model, constants),
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


def _model_derivatives(
    spec: BaselineSpec, baseline: LinearFlightModel, data_constants: Mapping[str, float] | None
) -> tuple[list[FlightCandidate], dict[str, str]]:
    """The derivative-level candidates of a model-file baseline
    (:func:`ornitail.gap.derivative_candidates.model_derivatives`)."""
    model = load_model(spec.model)
    constants = model_constants(spec, data_constants)

    def rebuilt(
        new_values: Mapping[str, float], new_constants: Mapping[str, float]
    ) -> LinearFlightModel:
        return replace(baseline, **model_matrices(model, new_values, new_constants))

    return model_derivatives(model, constants, baseline, rebuilt)


def _input_candidates(baseline: LinearFlightModel, varying: Sequence[int]) -> list[FlightCandidate]:
    """``input_delay`` and ``input_filter`` on every input in ``varying`` (indices)."""
    candidates = []
    for index in varying:
        name = baseline.input_names[index]
        suffix = "" if len(varying) == 1 else f"_{name}"
        candidates += [
            FlightCandidate(
                f"input_delay{suffix}",
                f"{name} acts k s after it is logged",
                "s",
                DELAY_BOUNDS_S,
                lambda k, index=index: baseline.with_input_change(index, delay_s=k),
            ),
            FlightCandidate(
                f"input_filter{suffix}",
                f"{name} is logged through a first-order low-pass of time constant k",
                "s",
                FILTER_BOUNDS_S,
                lambda k, index=index: baseline.with_input_change(index, filter_s=k),
            ),
        ]
    return candidates


def _output_candidates(
    baseline: LinearFlightModel, absolute: Sequence[bool], spreads: Sequence[float]
) -> tuple[list[FlightCandidate], dict[str, str]]:
    """``theta_drift`` on an output ``theta``; ``<output>_bias`` on every absolute output."""
    candidates, skipped = [], {}
    names = baseline.output_names
    if "theta" in names:
        candidates.append(
            FlightCandidate(
                "theta_drift",
                "measured theta drifts by k",
                "rad/s",
                (-0.05, 0.05),
                lambda k: baseline.with_output_change(names.index("theta"), drift_per_s=k),
            )
        )
    else:
        skipped["theta_drift"] = "the model has no output theta"
    for index, name in enumerate(names):
        if not absolute[index]:
            skipped[f"{name}_bias"] = (
                f"the runs hold {name} as deviations from their start, in which a constant "
                "sensor offset cancels"
            )
            continue
        reach = BIAS_RANGE_SPREADS * spreads[index] + 1e-12
        candidates.append(
            FlightCandidate(
                f"{name}_bias",
                f"{name} measured with a constant offset k",
                "unit of " + name,
                (-reach, reach),
                lambda k, index=index: baseline.with_output_change(index, bias=k),
            )
        )
    return candidates, skipped


def flight_candidates(
    spec: BaselineSpec,
    baseline: LinearFlightModel,
    absolute_outputs: Sequence[bool] | None = None,
    output_spreads: Sequence[float] | None = None,
    data_constants: Mapping[str, float] | None = None,
    varying_inputs: Sequence[int] = (0,),
) -> CandidateLibrary:
    """The candidate library for this baseline, restricted to ``spec.candidates`` when given.

    ``absolute_outputs`` (per output; default none) and ``output_spreads`` (each output's
    standard deviation over the runs, its unit) decide the output-bias candidates;
    ``varying_inputs`` the inputs that get a delay and a filter; ``data_constants`` complete a
    model file's constants.
    """
    outputs = len(baseline.output_names)
    absolute = absolute_outputs if absolute_outputs is not None else (False,) * outputs
    spreads = output_spreads if output_spreads is not None else (0.0,) * outputs
    if spec.kind == "simulator":
        derivatives, skipped = simulator_derivatives(baseline)
        library = _simulator_candidates(spec, baseline) + derivatives
    else:
        library, skipped = _model_derivatives(spec, baseline, data_constants)
    library += _input_candidates(baseline, varying_inputs)
    measured, measured_skipped = _output_candidates(baseline, absolute, spreads)
    library += measured
    skipped |= measured_skipped
    if spec.candidates:
        known = {candidate.name for candidate in library}
        unknown = [name for name in spec.candidates if name not in known]
        if unknown:
            reason = skipped.get(unknown[0])
            raise UserInputError(
                f"{spec.source}: [baseline].candidates",
                f"{unknown[0]!r} is not available for this baseline"
                + (f" ({reason})" if reason else "")
                + f"; available: {', '.join(sorted(known))}",
            )
        library = [candidate for candidate in library if candidate.name in spec.candidates]
    return CandidateLibrary(library, skipped)
