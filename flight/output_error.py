"""Output-error maximum-likelihood estimation of a model file's parameters.

The model is discretised exactly under its input hold (first-order by default, zero-order on
request; :mod:`ornitail.flight.discretisation`), simulated on the measured inputs, and its
parameters (and initial state, if the model estimates it) are adjusted by Levenberg-Marquardt steps
with exact output sensitivities on the ML cost N/2 log det R(theta), where the diagonal noise
covariance R(theta) is re-estimated from the residuals at every iterate.
Its Gauss-Newton Hessian is the Fisher information minus a term for R's dependence on theta;
keeping that term makes the iteration converge in a few steps where the plain relaxation
(re-estimate R, then a Gauss-Newton step with R fixed, as SIDPAC's ``oe``) converges linearly.
Where that Hessian is not positive definite (far from the optimum) M itself is used. Standard
errors: Cramer-Rao (inverse of M = sum S^T R^-1 S) and corrected for colored residuals as SIDPAC's
``m_colores`` does (or tapered, as an option).

Divergence is reported, never hidden: a non-finite simulation, no step that lowers the cost, a
parameter stuck on a bound, a singular information matrix or the iteration limit all end the
estimation with ``converged = False`` and a message saying which.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.flight.discretisation import DiscreteModel, discretise
from ornitail.flight.fisher_information import fisher_information
from ornitail.flight.identification_result import IdentificationResult
from ornitail.flight.linear_simulation import output_sensitivities, simulate_outputs
from ornitail.flight.model_data import ModelData
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.residual_statistics import colored_residual_covariance
from ornitail.flight.result_assembly import assemble_result


@dataclass(frozen=True)
class OutputErrorOptions:
    """Iteration controls and the colored-residual sigma formula. Converged when every
    component of the undamped Gauss-Newton step is below ``step_tolerance`` times its Cramer-Rao
    sigma. ``colored_sigma``: ``morelli`` (SIDPAC's ``m_colores``, the default), ``tapered``, or
    ``morelli_small_sample`` (``m_colores`` times N_eff / (N_eff - p) for short records)
    (:mod:`ornitail.flight.residual_statistics`).
    """

    max_iterations: int = 100
    step_tolerance: float = 1e-3
    bound_iterations_allowed: int = 3
    max_damping: float = 1e10
    colored_sigma: str = "morelli"


_Simulation = tuple[DiscreteModel, np.ndarray, np.ndarray]
"""A discrete model, its simulated outputs and states."""


class OutputErrorProblem:
    """One model on one manoeuvre: outputs and exact sensitivities as functions of theta =
    (free parameters in file order, then the initial state if the model estimates it).
    """

    def __init__(
        self, spec: StateSpaceModelSpec, signals: ModelData, values: dict[str, float]
    ) -> None:
        self.spec = spec
        self.signals = signals
        self.free_names = spec.free_parameter_names
        self.free_indices = np.array([spec.parameter_names.index(n) for n in self.free_names])
        self.estimates_initial_state = spec.initial_state == "estimate"
        self.all_parameters = np.array([values[name] for name in spec.parameter_names])
        self.constants = np.array([signals.constants[name] for name in spec.constant_names])
        state_count = len(spec.states)
        extra = state_count if self.estimates_initial_state else 0
        self.lower = np.concatenate(
            [[spec.parameter(n).lower for n in self.free_names], np.full(extra, -np.inf)]
        )
        self.upper = np.concatenate(
            [[spec.parameter(n).upper for n in self.free_names], np.full(extra, np.inf)]
        )
        self.fixed_initial_state = np.zeros(state_count)
        self._last_simulation: tuple[bytes, _Simulation] | None = None
        self._last_sensitivities: tuple[bytes, np.ndarray] | None = None

    def split(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """All parameters (model file order) and the initial state for a theta."""
        parameters = self.all_parameters.copy()
        parameters[self.free_indices] = theta[: len(self.free_indices)]
        if self.estimates_initial_state:
            return parameters, theta[len(self.free_indices) :]
        return parameters, self.fixed_initial_state

    def _simulation(self, theta: np.ndarray) -> _Simulation:
        """The discrete model, simulated outputs (N, outputs; NaN when unbounded) and states at
        theta. The last theta's are kept: an accepted trial step is simulated again as the next
        iterate, and the last iterate once more for the standard errors.
        """
        key = np.asarray(theta, dtype=float).tobytes()
        if self._last_simulation is not None and self._last_simulation[0] == key:
            return self._last_simulation[1]
        parameters, initial_state = self.split(theta)
        discrete = discretise(self.spec, parameters, self.constants, self.signals.time_step_s)
        with np.errstate(invalid="ignore", over="ignore"):
            outputs, states = simulate_outputs(discrete, initial_state, self.signals.inputs)
        simulation = (discrete, self._unless_unbounded(outputs), states)
        self._last_simulation = (key, simulation)
        return simulation

    def outputs(self, theta: np.ndarray) -> np.ndarray:
        """Simulated outputs (N, outputs) at theta."""
        return self._simulation(theta)[1]

    def _unless_unbounded(self, outputs: np.ndarray) -> np.ndarray:
        """NaN for a simulation that grows beyond 1e6 times the largest measured value (an
        unstable model), so that it is treated like a non-finite one.
        """
        limit = 1e6 * max(np.abs(self.signals.outputs).max(), 1e-300)
        with np.errstate(invalid="ignore", over="ignore"):
            if not np.all(np.abs(outputs) <= limit):
                return np.full_like(outputs, np.nan)
        return outputs

    def outputs_and_sensitivities(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Outputs (N, outputs) and dy/dtheta (N, outputs, len(theta))."""
        discrete, outputs, states = self._simulation(theta)
        if not np.all(np.isfinite(outputs)):
            return outputs, np.full((*outputs.shape, len(theta)), np.nan)
        key = np.asarray(theta, dtype=float).tobytes()
        if self._last_sensitivities is not None and self._last_sensitivities[0] == key:
            return outputs, self._last_sensitivities[1]
        sensitivities = output_sensitivities(
            discrete, states, self.signals.inputs, self.free_indices, self.estimates_initial_state
        )
        self._last_sensitivities = (key, sensitivities)
        return outputs, sensitivities


def noise_variances(residuals: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Diagonal of R: mean squared residual per output, floored at 1e-12 of the output's variance
    (or 1e-30) so that a perfectly fitted output cannot make R singular.
    """
    floor = np.maximum(1e-12 * np.var(measured, axis=0), 1e-30)
    return np.maximum(np.mean(residuals**2, axis=0), floor)


def maximum_likelihood_cost(variances: np.ndarray, sample_count: int) -> float:
    """N/2 log det R: the negative log-likelihood with R at its estimate, constants dropped."""
    return float(0.5 * sample_count * np.sum(np.log(variances)))


def estimate_output_error(
    spec: StateSpaceModelSpec,
    signals: ModelData,
    start_values: dict[str, float],
    initial_state_start: np.ndarray,
    options: OutputErrorOptions | None = None,
) -> IdentificationResult:
    """Output-error ML estimate started at ``start_values`` (every parameter by name) and
    ``initial_state_start`` (the initial state itself when the model does not estimate it).
    """
    options = options or OutputErrorOptions()
    problem = OutputErrorProblem(spec, signals, start_values)
    measured = signals.outputs
    count = signals.sample_count
    theta = np.array([start_values[name] for name in problem.free_names], dtype=float)
    if problem.estimates_initial_state:
        theta = np.concatenate([theta, initial_state_start])
    else:
        problem.fixed_initial_state = np.asarray(initial_state_start, dtype=float)
    theta = np.clip(theta, problem.lower, problem.upper)
    parameter_count = len(problem.free_names)

    damping = 1e-3
    iterations = 0
    converged = False
    message = ""
    bound_streak = 0
    outputs, sensitivities = problem.outputs_and_sensitivities(theta)
    while True:
        residuals = measured - outputs
        if not np.all(np.isfinite(residuals)) or not np.all(np.isfinite(sensitivities)):
            message = (
                "the simulation diverges at the start values (unstable model)"
                if iterations == 0
                else "the simulation diverged (unstable model)"
            )
            break
        variances = noise_variances(residuals, measured)
        cost = maximum_likelihood_cost(variances, count)
        if iterations >= options.max_iterations:
            message = f"no convergence within {options.max_iterations} iterations"
            break
        information, hessian, gradient = _newton_terms(sensitivities, residuals, variances)
        scale = np.sqrt(np.diag(information))
        silent = np.flatnonzero(scale <= 1e-12 * max(scale.max(), 1e-300))
        if len(silent):
            names = ", ".join(_theta_name(problem, int(index)) for index in silent)
            message = f"the data carry no information on {names}"
            break
        scaled_hessian = hessian / np.outer(scale, scale)
        if np.linalg.eigvalsh(scaled_hessian).min() <= 1e-10:
            # Far from the optimum the R-term can make the Hessian indefinite: use M there.
            scaled_hessian = information / np.outer(scale, scale)
        sigma = np.sqrt(np.abs(np.diag(np.linalg.pinv(information))))
        if _newton_step_is_small(scaled_hessian, gradient, scale, sigma, options.step_tolerance):
            converged = True
            message = "converged"
            break
        accepted = False
        while damping <= options.max_damping:
            try:
                factor = np.linalg.cholesky(scaled_hessian + damping * np.eye(len(theta)))
            except np.linalg.LinAlgError:
                damping *= 10
                continue
            step = np.linalg.solve(factor.T, np.linalg.solve(factor, gradient / scale)) / scale
            trial = np.clip(theta + step, problem.lower, problem.upper)
            trial_outputs = problem.outputs(trial)
            trial_residuals = measured - trial_outputs
            if np.all(np.isfinite(trial_residuals)):
                trial_cost = maximum_likelihood_cost(
                    noise_variances(trial_residuals, measured), count
                )
                if trial_cost <= cost:
                    accepted = True
                    damping = max(damping / 10, 1e-9)
                    break
            damping *= 10
        iterations += 1
        if not accepted:
            message = "no step lowers the cost (diverging or ill-conditioned problem)"
            break
        on_bound = np.flatnonzero(trial[:parameter_count] != (theta + step)[:parameter_count])
        theta = trial
        bound_streak = bound_streak + 1 if len(on_bound) else 0
        if bound_streak >= options.bound_iterations_allowed:
            names = ", ".join(problem.free_names[i] for i in on_bound)
            message = (
                f"parameter(s) {names} pushed against their bounds for {bound_streak} iterations"
            )
            break
        outputs, sensitivities = problem.outputs_and_sensitivities(theta)

    return _finish(problem, theta, iterations, converged, message, options.colored_sigma)


def _newton_terms(
    sensitivities: np.ndarray, residuals: np.ndarray, variances: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fisher information M = sum S^T R^-1 S, the Gauss-Newton Hessian of N/2 log det R(theta)
    (M minus the term from R's dependence on theta: (2/N) sum_o g_o g_o^T / R_o^2 with
    g_o = sum_k S_ok v_ok), and the descent direction sum_o g_o / R_o.
    """
    count = sensitivities.shape[0]
    information = fisher_information(sensitivities, 1.0 / variances)
    per_output = np.einsum("koi,ko->oi", sensitivities, residuals)
    gradient = (per_output / variances[:, None]).sum(axis=0)
    correction = (per_output / variances[:, None]).T @ (per_output / variances[:, None])
    return information, information - (2.0 / count) * correction, gradient


def _newton_step_is_small(
    scaled_hessian: np.ndarray,
    gradient: np.ndarray,
    scale: np.ndarray,
    sigma: np.ndarray,
    tolerance: float,
) -> bool:
    """True when the undamped Gauss-Newton step is below ``tolerance`` sigma in every component
    (a damped step can be small far from the optimum, so it is not the test).
    """
    try:
        factor = np.linalg.cholesky(scaled_hessian)
    except np.linalg.LinAlgError:
        return False
    step = np.linalg.solve(factor.T, np.linalg.solve(factor, gradient / scale)) / scale
    return bool(np.all(np.abs(step) <= tolerance * sigma))


def _theta_name(problem: OutputErrorProblem, index: int) -> str:
    if index < len(problem.free_names):
        return problem.free_names[index]
    return f"x0_{problem.spec.states[index - len(problem.free_names)]}"


def _finish(
    problem: OutputErrorProblem,
    theta: np.ndarray,
    iterations: int,
    converged: bool,
    message: str,
    colored_sigma: str,
) -> IdentificationResult:
    spec, signals = problem.spec, problem.signals
    count = len(problem.free_names)
    outputs, sensitivities = problem.outputs_and_sensitivities(theta)
    residuals = signals.outputs - outputs
    size = len(theta)
    if np.all(np.isfinite(residuals)) and np.all(np.isfinite(sensitivities)):
        variances = noise_variances(residuals, signals.outputs)
        weights = 1.0 / variances
        information = fisher_information(sensitivities, weights)
        condition = np.linalg.cond(information)
        if condition < 1e14:
            covariance = np.linalg.inv(information)
            covariance_colored = colored_residual_covariance(
                sensitivities * weights[None, :, None], residuals, information, colored_sigma
            )
        else:
            covariance = covariance_colored = np.full((size, size), np.nan)
            converged = False
            message += f"; information matrix singular (condition {condition:.1e})"
        cost = maximum_likelihood_cost(variances, signals.sample_count)
    else:
        variances = np.full(len(spec.outputs), np.nan)
        covariance = covariance_colored = np.full((size, size), np.nan)
        cost = np.nan
    parameters, initial_state = problem.split(theta)
    values = dict(zip(spec.parameter_names, map(float, parameters), strict=True))
    state_sigma = (
        np.sqrt(np.abs(np.diag(covariance)[count:]))
        if problem.estimates_initial_state
        else np.zeros(len(spec.states))
    )
    return assemble_result(
        spec,
        signals,
        "output_error",
        values,
        problem.free_names,
        covariance[:count, :count],
        covariance_colored[:count, :count],
        initial_state,
        state_sigma,
        np.diag(variances),
        cost,
        iterations,
        converged,
        message,
    )
