"""A model per manoeuvre, and simulating any parameter vector on a manoeuvre.

Each manoeuvre is identified on its own (docs/background.md section 5): equation error (least squares on
smoothed derivatives) first, then output-error maximum likelihood started from it. The model's
trim constants (``theta0``, ``u0``, ``w0``) are set to the manoeuvre's steady state, ``m`` and
``Iyy`` to the configuration's mass properties, for every such constant the model file declares.

A model may carry nuisance parameters (``nuisance = true`` in its file: the constant biases of
``delfly_longitudinal_bias``). They are estimated with everything else, and the manoeuvre's own
response errors use them, but a :class:`ManoeuvreModel`'s ``values`` and ``covariance`` hold only
the derivatives (the marginal covariance of the derivatives: the nuisance rows and columns
dropped), so nothing downstream averages, rejects on or tabulates a bias as if it were a
derivative.

Uncertainties are the standard errors corrected for colored residuals (``covariance_colored``):
after the 5 Hz filter the residuals are strongly correlated from sample to sample, and the
Cramer-Rao bound would understate the scatter between manoeuvres several times.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ornitail.flight.discretisation import discretise
from ornitail.flight.identification_result import IdentificationResult
from ornitail.flight.identify import identify
from ornitail.flight.linear_simulation import simulate_outputs
from ornitail.flight.manoeuvres import Manoeuvre, SteadyState
from ornitail.flight.model_data import model_data
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.output_error import OutputErrorOptions
from ornitail.flight.state_space import NumericStateSpace
from ornitail.flight.validation import ResponseErrors, response_errors


@dataclass(frozen=True)
class MassProperties:
    """Mass (kg) and pitch inertia about y_b (kg m^2) of a configuration."""

    mass_kg: float
    iyy_kg_m2: float


@dataclass(frozen=True)
class ManoeuvreModel:
    """The output-error model of one manoeuvre and its response errors on that manoeuvre.

    ``values`` and ``covariance`` follow ``parameter_names``: the estimated derivatives (the free
    parameters that are not nuisance parameters; ``result`` holds every estimate).
    ``errors`` compares the model simulated from the measured initial state on the measured
    input with the measured states (model units). ``converged`` is False when output error
    diverged; such a model is not used further.
    """

    manoeuvre: Manoeuvre
    result: IdentificationResult
    parameter_names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    errors: ResponseErrors
    converged: bool
    message: str

    @property
    def sigmas(self) -> np.ndarray:
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    @property
    def relative_sigmas(self) -> np.ndarray:
        """|sigma / value| per parameter (inf for a zero estimate)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.values != 0, np.abs(self.sigmas / self.values), np.inf)

    def state_space(self) -> NumericStateSpace:
        return self.result.model_with_parameters()


def trim_constants(
    spec: StateSpaceModelSpec, steady_state: SteadyState, mass: MassProperties
) -> dict[str, float]:
    """The model's trim and mass constants that it declares, from a steady state (SI)."""
    available = {
        "theta0": steady_state.theta_rad,
        "u0": steady_state.u_m_s,
        "w0": steady_state.w_m_s,
        "m": mass.mass_kg,
        "Iyy": mass.iyy_kg_m2,
    }
    return {name: value for name, value in available.items() if name in spec.constant_names}


def derivative_part(
    spec: StateSpaceModelSpec, result: IdentificationResult
) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """Names, values and colored covariance (marginal) of the derivatives of a fit of ``spec``:
    its free parameters without the nuisance parameters (SI units of the model file).
    """
    names = tuple(name for name in result.parameter_names if name in spec.derivative_names)
    indices = np.array([result.parameter_names.index(name) for name in names], dtype=int)
    values = result.parameter_vector()[indices]
    covariance = np.asarray(result.covariance_colored, dtype=float)[np.ix_(indices, indices)]
    return names, values, covariance


def simulate_parameters(
    spec: StateSpaceModelSpec, parameter_values: Mapping[str, float], data: pd.DataFrame
) -> tuple[np.ndarray, np.ndarray]:
    """Measured and simulated outputs (samples, outputs) of ``spec`` at ``parameter_values``.

    The simulation starts from the measured state at the first sample (states with columns) and
    is driven by the measured input, with the discretisation (input hold) the estimator uses.
    Parameters not given (e.g. the nuisance biases of an averaged model) are at their start
    values.
    """
    signals = model_data(spec, data)
    values = {**spec.start_values(), **parameter_values}
    parameters = np.array([values[name] for name in spec.parameter_names])
    constants = np.array([signals.constants[name] for name in spec.constant_names])
    discrete = discretise(spec, parameters, constants, signals.time_step_s)
    start = signals.states[0] if signals.states is not None else np.zeros(len(spec.states))
    simulated, _ = simulate_outputs(discrete, start, signals.inputs)
    return signals.outputs, simulated


def fit_manoeuvre_model(
    spec: StateSpaceModelSpec,
    manoeuvre: Manoeuvre,
    mass: MassProperties,
    colored_sigma: str = "morelli",
) -> ManoeuvreModel:
    """Equation error, then output error started from it, on one manoeuvre's deviations
    (standard errors by ``colored_sigma``: :data:`~ornitail.flight.residual_statistics.
    COLORED_SIGMA_METHODS`).
    """
    model = spec.with_constants(trim_constants(spec, manoeuvre.steady_state, mass))
    first_guess = identify(model, manoeuvre.deviations, method="equation_error")
    start = {name: first_guess.parameters[name].value for name in first_guess.parameter_names}
    options = OutputErrorOptions(colored_sigma=colored_sigma)
    result = identify(
        model, manoeuvre.deviations, method="output_error", start=start, options=options
    )
    names, values, covariance = derivative_part(model, result)
    measured, simulated = simulate_parameters(
        model, result.parameter_values(), manoeuvre.deviations
    )
    converged = bool(
        result.converged
        and np.all(np.isfinite(result.parameter_vector()))
        and np.all(np.isfinite(simulated))
    )
    return ManoeuvreModel(
        manoeuvre=manoeuvre,
        result=result,
        parameter_names=names,
        values=values,
        covariance=covariance,
        errors=response_errors(measured, simulated),
        converged=converged,
        message=result.message,
    )
