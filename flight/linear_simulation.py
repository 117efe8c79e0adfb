"""Simulating a discrete linear model and its output sensitivities (exact, by the chain rule).

For x[k+1] = Ad x[k] + Bd u[k], y[k] = C x[k] + D u[k], the sensitivity of the state to a
parameter p obeys the same recursion driven by the derivative matrices,
dx[k+1]/dp = Ad dx[k]/dp + (dAd/dp) x[k] + (dBd/dp) u[k], and dx[0]/dx0 = I for an estimated
initial state; then dy[k]/dp = C dx[k]/dp + (dC/dp) x[k] + (dD/dp) u[k]. The derivative matrices
come from CasADi's differentiation of the discretisation (:mod:`ornitail.flight.discretisation`),
so the sensitivities are exact, not finite differences.
"""

from __future__ import annotations

import numpy as np

from ornitail.flight.discretisation import DiscreteModel


def simulate_states(model: DiscreteModel, initial_state: np.ndarray, inputs: np.ndarray) -> np.ndarray:
    """States x[0..N-1] (N, states) for inputs (N, inputs) from ``initial_state``."""
    forcing = inputs @ model.bd.T
    states = np.empty((len(inputs), model.ad.shape[0]))
    state = np.asarray(initial_state, dtype=float).copy()
    transition = model.ad
    for index in range(len(inputs)):
        states[index] = state
        state = transition @ state + forcing[index]
    return states


def simulate_outputs(
    model: DiscreteModel, initial_state: np.ndarray, inputs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Outputs (N, outputs) and states (N, states) of the discrete model."""
    states = simulate_states(model, initial_state, inputs)
    return states @ model.c.T + inputs @ model.d.T, states


def output_sensitivities(
    model: DiscreteModel,
    states: np.ndarray,
    inputs: np.ndarray,
    parameter_indices: np.ndarray,
    initial_state_columns: bool,
) -> np.ndarray:
    """dy[k]/dtheta, shape (N, outputs, len(theta)), theta = the selected parameters followed by
    the initial state when ``initial_state_columns``.
    """
    state_count = model.ad.shape[0]
    d_ad = model.d_ad[parameter_indices]
    d_bd = model.d_bd[parameter_indices]
    # forcing[k, i, j] = (dAd_j x[k] + dBd_j u[k])_i
    forcing = np.einsum("jab,kb->kaj", d_ad, states) + np.einsum("jab,kb->kaj", d_bd, inputs)
    columns = len(parameter_indices) + (state_count if initial_state_columns else 0)
    sensitivity = np.zeros((state_count, columns))
    if initial_state_columns:
        sensitivity[:, len(parameter_indices) :] = np.eye(state_count)
        forcing = np.concatenate(
            [forcing, np.zeros((len(states), state_count, state_count))], axis=2
        )
    state_sensitivities = np.empty((len(states), state_count, columns))
    transition = model.ad
    for index in range(len(states)):
        state_sensitivities[index] = sensitivity
        sensitivity = transition @ sensitivity + forcing[index]
    result = np.einsum("oa,kaj->koj", model.c, state_sensitivities)
    direct = np.einsum("joa,ka->koj", model.d_c[parameter_indices], states) + np.einsum(
        "joa,ka->koj", model.d_d[parameter_indices], inputs
    )
    result[:, :, : len(parameter_indices)] += direct
    return result
