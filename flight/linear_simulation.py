"""Simulating a discrete linear model and its output sensitivities (exact, by the chain rule).

For x[k+1] = Ad x[k] + Bd u[k] + Bn u[k+1], y[k] = C x[k] + D u[k] (Bn = 0 under a zero-order
hold; :mod:`ornitail.flight.discretisation`), the sensitivity of the state to a parameter p obeys
the same recursion driven by the derivative matrices,
dx[k+1]/dp = Ad dx[k]/dp + (dAd/dp) x[k] + (dBd/dp) u[k] + (dBn/dp) u[k+1], and dx[0]/dx0 = I
for an estimated initial state; then dy[k]/dp = C dx[k]/dp + (dC/dp) x[k] + (dD/dp) u[k]. The derivative matrices
come from CasADi's differentiation of the discretisation (:mod:`ornitail.flight.discretisation`),
so the sensitivities are exact, not finite differences.
"""

from __future__ import annotations

import numpy as np

from ornitail.flight.discretisation import DiscreteModel


def propagate(transition: np.ndarray, forcing: np.ndarray, initial: np.ndarray) -> np.ndarray:
    """z[0..N-1] of z[k+1] = T z[k] + forcing[k], z[0] = initial, for (N, n) or (N, n, m) forcing.

    Computed in blocks of L ~ sqrt(N) steps, which gives the same sums in about 2 sqrt(N) Python
    steps instead of N: every block's response from rest is stepped at once (L steps over all
    blocks), the block start values are chained (N/L steps with T^L), and each block adds
    T^j times its start value.
    """
    vector = np.ndim(initial) == 1
    forcing = forcing[..., None] if vector else forcing
    initial = np.asarray(initial, dtype=float)[:, None] if vector else np.asarray(initial, float)
    count = len(forcing)
    length = max(1, int(np.sqrt(count)))
    blocks = -(-count // length)
    padded = np.zeros((blocks * length, *forcing.shape[1:]))
    padded[:count] = forcing
    by_block = padded.reshape(blocks, length, *forcing.shape[1:])
    local = np.empty_like(by_block)
    value = np.zeros((blocks, *forcing.shape[1:]))
    for step in range(length):
        local[:, step] = value
        value = transition @ value + by_block[:, step]
    powers = np.empty((length + 1, *transition.shape))
    powers[0] = np.eye(len(transition))
    for step in range(length):
        powers[step + 1] = transition @ powers[step]
    starts = np.empty((blocks, *initial.shape))
    start = initial
    for block in range(blocks):
        starts[block] = start
        start = powers[length] @ start + value[block]
    result = local + powers[None, :length] @ starts[:, None]
    result = result.reshape(blocks * length, *forcing.shape[1:])[:count]
    return result[..., 0] if vector else result


def next_inputs(inputs: np.ndarray) -> np.ndarray:
    """u[k+1] for every k (the last sample repeated: it only drives a state past the record)."""
    return np.concatenate([inputs[1:], inputs[-1:]])


def simulate_outputs(
    model: DiscreteModel, initial_state: np.ndarray, inputs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Outputs (N, outputs) and states (N, states) of the discrete model for inputs (N, inputs)."""
    forcing = inputs @ model.bd.T + next_inputs(inputs) @ model.bd_next.T
    states = propagate(model.ad, forcing, initial_state)
    return states @ model.c.T + inputs @ model.d.T, states


def _times_stack(signals: np.ndarray, stack: np.ndarray) -> np.ndarray:
    """out[k, a, j] = sum_b stack[j, a, b] signals[k, b] for (N, b) signals, (J, a, b) stack."""
    count, rows = stack.shape[0], stack.shape[1]
    flat = stack.transpose(2, 1, 0).reshape(stack.shape[2], rows * count)
    return (signals @ flat).reshape(len(signals), rows, count)


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
    parameter_count = len(parameter_indices)
    forcing = (
        _times_stack(states, model.d_ad[parameter_indices])
        + _times_stack(inputs, model.d_bd[parameter_indices])
        + _times_stack(next_inputs(inputs), model.d_bd_next[parameter_indices])
    )
    initial = np.zeros((state_count, parameter_count))
    if initial_state_columns:
        initial = np.hstack([initial, np.eye(state_count)])
        forcing = np.concatenate(
            [forcing, np.zeros((len(states), state_count, state_count))], axis=2
        )
    state_sensitivities = propagate(model.ad, forcing, initial)  # (N, states, theta)
    count, columns = len(states), initial.shape[1]
    flat = state_sensitivities.transpose(1, 0, 2).reshape(state_count, count * columns)
    result = (model.c @ flat).reshape(-1, count, columns).transpose(1, 0, 2)
    result[:, :, :parameter_count] += _times_stack(
        states, model.d_c[parameter_indices]
    ) + _times_stack(inputs, model.d_d[parameter_indices])
    return result
