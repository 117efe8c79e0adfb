"""Turning an estimate into an :class:`IdentificationResult`: simulation fit, residual tests,
modes with delta-method standard errors.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ornitail.flight.discretisation import continuous_jacobian_function, discretise
from ornitail.flight.identification_result import (
    IdentificationResult,
    ModeEstimate,
    ParameterEstimate,
)
from ornitail.flight.linear_simulation import simulate_outputs
from ornitail.flight.model_data import ModelData
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.residual_statistics import fit_per_output, residual_tests
from ornitail.flight.state_space import modes_of


def _standard_errors(covariance: np.ndarray) -> np.ndarray:
    diagonal = np.diag(covariance) if covariance.size else np.zeros(0)
    return np.sqrt(np.where(diagonal >= 0, diagonal, np.nan))


def mode_estimates(
    spec: StateSpaceModelSpec,
    all_parameters: np.ndarray,
    constants: np.ndarray,
    estimated_indices: np.ndarray,
    covariance: np.ndarray,
    covariance_colored: np.ndarray,
) -> tuple[np.ndarray, list[ModeEstimate]]:
    """Eigenvalues of A and each mode's standard errors by first-order propagation of the two
    covariances (of the parameters at ``estimated_indices``): d lambda = w^H dA v / (w^H v).
    """
    values = continuous_jacobian_function(spec)(all_parameters, constants)
    a_matrix = np.asarray(values[0])
    size = a_matrix.shape[0]
    d_a = np.asarray(values[4]).T.reshape(-1, size, size).transpose(0, 2, 1)[estimated_indices]
    eigenvalues, left, right = scipy.linalg.eig(a_matrix, left=True, right=True)
    order = np.lexsort((eigenvalues.imag, eigenvalues.real))
    eigenvalues, left, right = eigenvalues[order], left[:, order], right[:, order]
    estimates = []
    for mode in modes_of(eigenvalues):
        index = int(np.argmin(np.abs(eigenvalues - mode.eigenvalue)))
        w, v = left[:, index], right[:, index]
        gradient = np.einsum("a,jab,b->j", np.conj(w), d_a, v) / (np.conj(w) @ v)
        real, imag = gradient.real, gradient.imag
        magnitude = abs(mode.eigenvalue)
        if mode.oscillatory and magnitude > 0:
            lam = mode.eigenvalue
            d_frequency = (lam.real * real + lam.imag * imag) / magnitude
            d_damping = -real / magnitude + lam.real * d_frequency / magnitude**2
        else:
            d_frequency = np.sign(mode.eigenvalue.real) * real
            d_damping = np.zeros_like(real)
            imag = np.zeros_like(real)

        gradients = (real, imag, d_damping, d_frequency)
        sigmas = [
            float(np.sqrt(max(gradient @ matrix @ gradient, 0.0)))
            for matrix in (covariance, covariance_colored)
            for gradient in gradients
        ]
        estimates.append(ModeEstimate(mode, *sigmas))
    return eigenvalues, estimates


def assemble_result(
    spec: StateSpaceModelSpec,
    signals: ModelData,
    method: str,
    values: dict[str, float],
    estimated_names: tuple[str, ...],
    covariance: np.ndarray,
    covariance_colored: np.ndarray,
    initial_state: np.ndarray,
    initial_state_sigma: np.ndarray,
    noise_covariance: np.ndarray,
    cost: float,
    iterations: int,
    converged: bool,
    message: str,
) -> IdentificationResult:
    """Build the result; simulates the model on the data for fit and residual tests."""
    all_parameters = np.array([values[name] for name in spec.parameter_names])
    constants = np.array([signals.constants[name] for name in spec.constant_names])
    discrete = discretise(spec, all_parameters, constants, signals.time_step_s)
    with np.errstate(invalid="ignore", over="ignore"):
        simulated, _ = simulate_outputs(discrete, initial_state, signals.inputs)
        if not np.all(np.abs(simulated) <= 1e6 * max(np.abs(signals.outputs).max(), 1e-300)):
            simulated = np.full_like(simulated, np.nan)  # diverged: no fit to report
    residuals = signals.outputs - simulated
    sigma = _standard_errors(covariance)
    sigma_colored = _standard_errors(covariance_colored)
    parameters = {}
    for parameter in spec.parameters:
        if parameter.name in estimated_names:
            index = estimated_names.index(parameter.name)
            parameters[parameter.name] = ParameterEstimate(
                values[parameter.name], float(sigma[index]), float(sigma_colored[index])
            )
        else:
            parameters[parameter.name] = ParameterEstimate(values[parameter.name], 0.0, 0.0, True)
    estimated_indices = np.array(
        [spec.parameter_names.index(name) for name in estimated_names], dtype=int
    )
    if np.all(np.isfinite(all_parameters)):
        eigenvalues, modes = mode_estimates(
            spec,
            all_parameters,
            constants,
            estimated_indices,
            np.nan_to_num(covariance),
            np.nan_to_num(covariance_colored),
        )
    else:
        eigenvalues, modes = np.full(len(spec.states), np.nan + 0j), []
    finite = np.all(np.isfinite(residuals))
    return IdentificationResult(
        model=spec,
        method=method,
        parameters=parameters,
        parameter_names=estimated_names,
        covariance=covariance,
        covariance_colored=covariance_colored,
        constants=dict(signals.constants),
        initial_state=np.asarray(initial_state, dtype=float),
        initial_state_sigma=np.asarray(initial_state_sigma, dtype=float),
        fit=dict(
            zip(spec.outputs, map(float, fit_per_output(signals.outputs, simulated)), strict=True)
        ),
        eigenvalues=eigenvalues,
        modes=modes,
        residual_tests=residual_tests(
            residuals if finite else np.zeros_like(residuals),
            signals.inputs,
            spec.outputs,
            spec.inputs,
        ),
        noise_covariance=noise_covariance,
        cost=float(cost),
        iterations=iterations,
        converged=converged,
        message=message,
        time_step_s=signals.time_step_s,
        sample_count=signals.sample_count,
        simulated_outputs=simulated,
    )
