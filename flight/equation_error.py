"""Equation-error estimation: least squares on the state equations with smoothed derivatives.

States, inputs and outputs are smoothed, and the state derivatives taken, with the same
Savitzky-Golay filter (local quadratic over ``derivative_window_s``), so regressors and
derivatives carry the same smoothing. Each state equation dx_i/dt = (A x + B u)_i, and each output
equation y_j = (C x + D u)_j whose row depends on a parameter, is a channel of a weighted least
squares problem in the free parameters; the channel weights (inverse residual variances) are
re-estimated and the problem re-solved until the parameters settle (one solve suffices when every
entry is affine in the parameters; Gauss-Newton handles the rest). Standard errors: ordinary
(s^2 (X^T W X)^-1 with the re-estimated weights) and corrected for colored residuals.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter

from ornitail.core.errors import UserInputError
from ornitail.flight.discretisation import continuous_jacobian_function
from ornitail.flight.fisher_information import fisher_information, weighted_score
from ornitail.flight.identification_result import IdentificationResult
from ornitail.flight.model_data import ModelData
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.residual_statistics import colored_residual_covariance
from ornitail.flight.result_assembly import assemble_result

DEFAULT_DERIVATIVE_WINDOW_S = 0.1
MAX_ITERATIONS = 20


def smoothed_with_derivative(
    values: np.ndarray, time_step_s: float, window_s: float = DEFAULT_DERIVATIVE_WINDOW_S
) -> tuple[np.ndarray, np.ndarray]:
    """Savitzky-Golay (quadratic) smoothed values and time derivatives (per second), along axis 0.
    The window is ``window_s`` rounded to an odd sample count, at least 5 samples.
    """
    window = max(5, int(round(window_s / time_step_s)) | 1)
    window = min(window, len(values) - (1 - len(values) % 2))
    smoothed = savgol_filter(values, window, 2, axis=0, mode="interp")
    derivative = savgol_filter(values, window, 2, deriv=1, delta=time_step_s, axis=0, mode="interp")
    return smoothed, derivative


def _matrix_stack(jacobian: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    return jacobian.T.reshape(-1, shape[1], shape[0]).transpose(0, 2, 1)


def _regressors(matrix_derivatives: np.ndarray, signals: np.ndarray) -> np.ndarray:
    """(samples, rows, parameters): d (matrix @ signal) / d parameter from d matrix / d parameter (parameters, rows,
    columns) and the signals (samples, columns)."""
    return np.tensordot(signals, matrix_derivatives, axes=([1], [2])).transpose(0, 2, 1)


def estimate_equation_error(
    spec: StateSpaceModelSpec,
    signals: ModelData,
    start_values: dict[str, float] | None = None,
    derivative_window_s: float = DEFAULT_DERIVATIVE_WINDOW_S,
) -> IdentificationResult:
    """Equation-error estimate of the free parameters (needs a data column for every state)."""
    if signals.states is None:
        missing = [state for state in spec.states if state not in spec.columns]
        raise UserInputError(
            f"{spec.source}: [columns]",
            f"equation error needs every state measured; no column for {', '.join(missing)}",
        )
    values = dict(start_values or spec.start_values())
    states, state_rates = smoothed_with_derivative(
        signals.states, signals.time_step_s, derivative_window_s
    )
    inputs, _ = smoothed_with_derivative(signals.inputs, signals.time_step_s, derivative_window_s)
    outputs, _ = smoothed_with_derivative(signals.outputs, signals.time_step_s, derivative_window_s)
    constants = np.array([signals.constants[name] for name in spec.constant_names])
    free_names = spec.free_parameter_names
    free_indices = np.array([spec.parameter_names.index(name) for name in free_names])
    function = continuous_jacobian_function(spec)
    shapes = [spec.matrix_shape(name) for name in ("A", "B", "C", "D")]

    def channels(parameters: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predictions (N, channels) and regressors (N, channels, free parameters)."""
        evaluated = [np.asarray(item) for item in function(parameters, constants)]
        a, b, c, d = evaluated[:4]
        d_a, d_b, d_c, d_d = (
            _matrix_stack(evaluated[4 + i], shapes[i])[free_indices] for i in range(4)
        )
        state_prediction = states @ a.T + inputs @ b.T
        state_regressors = _regressors(d_a, states) + _regressors(d_b, inputs)
        output_prediction = states @ c.T + inputs @ d.T
        output_regressors = _regressors(d_c, states) + _regressors(d_d, inputs)
        return (
            np.concatenate([state_prediction, output_prediction[:, used_outputs]], axis=1),
            np.concatenate([state_regressors, output_regressors[:, used_outputs]], axis=1),
        )

    parameters = np.array([values[name] for name in spec.parameter_names], dtype=float)
    used_outputs = np.arange(len(spec.outputs))
    _, regressors = channels(parameters)
    used_outputs = np.flatnonzero(np.any(regressors[:, len(spec.states) :] != 0, axis=(0, 2)))
    targets = np.concatenate([state_rates, outputs[:, used_outputs]], axis=1)
    variances = np.maximum(np.var(targets, axis=0), 1e-30)
    _, regressors = channels(parameters)
    informative = np.any(regressors != 0, axis=(0, 1))
    estimable = np.flatnonzero(informative)
    converged = False
    iterations = 0
    while iterations < MAX_ITERATIONS:
        iterations += 1
        prediction, regressors = channels(parameters)
        residuals = targets - prediction
        weights = 1.0 / variances
        design = regressors[:, :, estimable]
        information = fisher_information(design, weights)
        gradient = weighted_score(design, weights, residuals)
        try:
            step = np.linalg.solve(information, gradient)
        except np.linalg.LinAlgError:
            break
        parameters[free_indices[estimable]] += step
        new_residuals = targets - channels(parameters)[0]
        new_variances = np.maximum(np.mean(new_residuals**2, axis=0), 1e-30)
        sigma = np.sqrt(np.abs(np.diag(np.linalg.inv(information))))
        settled = np.all(np.abs(step) <= 1e-6 * sigma) and np.allclose(
            new_variances, variances, rtol=1e-6
        )
        variances = new_variances
        if settled:
            converged = True
            break

    prediction, regressors = channels(parameters)
    residuals = targets - prediction
    weights = 1.0 / variances
    design = regressors[:, :, estimable]
    information = fisher_information(design, weights)
    size = len(free_names)
    covariance = np.full((size, size), np.nan)
    covariance_colored = np.full((size, size), np.nan)
    if np.linalg.cond(information) < 1e14:
        block = np.ix_(estimable, estimable)
        covariance[block] = np.linalg.inv(information)
        covariance_colored[block] = colored_residual_covariance(
            design * weights[None, :, None], residuals, information
        )
    else:
        converged = False
    silent = [free_names[i] for i in np.flatnonzero(~informative)]
    message = "converged" if converged else "did not settle"
    if silent:
        message += f"; equation error cannot estimate {', '.join(silent)} (kept at start values)"
    values = dict(zip(spec.parameter_names, map(float, parameters), strict=True))
    initial_state = states[0] if spec.initial_state != "zero" else np.zeros(len(spec.states))
    cost = 0.5 * float(np.sum(residuals**2 / np.var(targets, axis=0)))
    result = assemble_result(
        spec,
        signals,
        "equation_error",
        values,
        free_names,
        covariance,
        covariance_colored,
        initial_state,
        np.zeros(len(spec.states)),
        np.zeros((len(spec.outputs), len(spec.outputs))),
        cost,
        iterations,
        converged,
        message,
    )
    simulated_residuals = signals.outputs - result.simulated_outputs
    result.noise_covariance = np.diag(np.mean(simulated_residuals**2, axis=0))
    return result
