"""Exact discretisation of a model file's matrices under the model's input hold, with exact
parameter derivatives.

The discrete model is x[k+1] = Ad x[k] + Bd u[k] + Bd_next u[k+1]:

- zero-order hold (the input constant over each interval, a held digital command):
  Ad = exp(A dt), Bd = G0 = int_0^dt exp(A s) ds B, Bd_next = 0;
- first-order hold (the input linear between samples, a sampled continuous signal such as a
  measured control surface): with G1 = (1/dt) int_0^dt exp(A s) (dt - s) ds B,
  Bd = G0 - G1 and Bd_next = G1. A zero-order hold on such a signal delays it by half a sample.

Both come from one matrix exponential: exp([[A, B], [0, 0]] dt) holds Ad and G0, and
exp([[A dt, B dt, 0], [0, 0, I], [0, 0, 0]]) holds Ad, G0 and G1 in its first block row (the
ramp input is the third block's state). The exponential is computed symbolically in CasADi by
scaling and squaring: a degree-12 Taylor polynomial of the matrix divided by 2^s (norm <= 0.5,
truncation error below 1e-13 relative), then s squarings. CasADi differentiates it exactly. One
CasADi Function per (model, hold, s) is built once and re-used for every evaluation, manoeuvre and
sample time (dt is an input).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi
import numpy as np
from scipy.linalg import expm

from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.model_functions import compiled_function, matrices_function, symbolic_matrices

TAYLOR_DEGREE = 12
SCALED_NORM_LIMIT = 0.5


@dataclass(frozen=True)
class DiscreteModel:
    """x[k+1] = ad x[k] + bd u[k] + bd_next u[k+1], y[k] = c x[k] + d u[k], and the derivatives
    of the five matrices with respect to every parameter (first axis: parameter, in model file
    order). ``bd_next`` is zero under a zero-order hold.
    """

    ad: np.ndarray
    bd: np.ndarray
    bd_next: np.ndarray
    c: np.ndarray
    d: np.ndarray
    d_ad: np.ndarray
    d_bd: np.ndarray
    d_bd_next: np.ndarray
    d_c: np.ndarray
    d_d: np.ndarray


def _squarings_needed(
    a_matrix: np.ndarray, b_matrix: np.ndarray, time_step_s: float, input_hold: str
) -> int:
    augmented_norm = np.linalg.norm(np.hstack([a_matrix, b_matrix]), ord=1) * time_step_s
    if input_hold == "first_order":
        augmented_norm = max(augmented_norm, 1.0)  # the identity block of the ramp
    if not math.isfinite(augmented_norm):
        return 0
    return max(0, math.ceil(math.log2(max(augmented_norm, 1e-300) / SCALED_NORM_LIMIT)))


def _symbolic_hold(
    a: casadi.SX, b: casadi.SX, time_step: casadi.SX, squarings: int, input_hold: str
) -> tuple[casadi.SX, casadi.SX, casadi.SX]:
    """Ad, Bd, Bd_next of the hold (module docstring) as SX of the matrices and ``time_step``."""
    states, inputs = a.shape[0], b.shape[1]
    ramp = input_hold == "first_order"
    size = states + (2 if ramp else 1) * inputs
    augmented = casadi.SX.zeros(size, size)
    augmented[:states, :states] = a * time_step / 2**squarings
    augmented[:states, states : states + inputs] = b * time_step / 2**squarings
    if ramp:
        augmented[states : states + inputs, states + inputs :] = casadi.SX.eye(inputs) / (
            2**squarings
        )
    exponential = casadi.SX.eye(size)
    term = casadi.SX.eye(size)
    for degree in range(1, TAYLOR_DEGREE + 1):
        term = casadi.mtimes(term, augmented) / degree
        exponential = exponential + term
    for _ in range(squarings):
        exponential = casadi.mtimes(exponential, exponential)
    ad = exponential[:states, :states]
    integral = exponential[:states, states : states + inputs]
    if not ramp:
        return ad, integral, casadi.SX.zeros(states, inputs)
    ramp_integral = exponential[:states, states + inputs :]
    return ad, integral - ramp_integral, ramp_integral


def _discretisation_function(spec: StateSpaceModelSpec, squarings: int) -> casadi.Function:
    key = f"{spec.input_hold}_{squarings}"

    def build() -> casadi.Function:
        parameters = casadi.SX.sym("p", len(spec.parameters))
        constants = casadi.SX.sym("c", len(spec.constant_names))
        time_step = casadi.SX.sym("dt")
        a, b, c, d = symbolic_matrices(spec, parameters, constants)
        ad, bd, bd_next = _symbolic_hold(a, b, time_step, squarings, spec.input_hold)
        outputs = []
        for matrix in (ad, bd, bd_next, c, d):
            outputs += [matrix, casadi.jacobian(casadi.vec(matrix), parameters)]
        return casadi.Function(key, [parameters, constants, time_step], outputs)

    return compiled_function(spec, key, build)


def continuous_jacobian_function(spec: StateSpaceModelSpec) -> casadi.Function:
    """CasADi Function (parameters, constants) -> (A, B, C, D, dvec(A)/dp, ..., dvec(D)/dp)."""

    def build() -> casadi.Function:
        parameters = casadi.SX.sym("p", len(spec.parameters))
        constants = casadi.SX.sym("c", len(spec.constant_names))
        matrices = symbolic_matrices(spec, parameters, constants)
        jacobians = [casadi.jacobian(casadi.vec(matrix), parameters) for matrix in matrices]
        return casadi.Function(
            "continuous_jacobian", [parameters, constants], [*matrices, *jacobians]
        )

    return compiled_function(spec, "continuous_jacobian", build)


def _derivative_stack(jacobian: casadi.DM, shape: tuple[int, int]) -> np.ndarray:
    """(rows*columns, parameters) column-major Jacobian -> (parameters, rows, columns)."""
    values = np.asarray(casadi.densify(jacobian))
    return values.T.reshape(values.shape[1], shape[1], shape[0]).transpose(0, 2, 1)


def discretise(
    spec: StateSpaceModelSpec,
    parameter_vector: np.ndarray,
    constant_vector: np.ndarray,
    time_step_s: float,
) -> DiscreteModel:
    """The model under its input hold and the exact parameter derivatives at
    ``parameter_vector`` (all parameters, model file order) and ``constant_vector``
    (:attr:`constant_names` order).
    """
    a, b, _, _ = (
        np.asarray(matrix) for matrix in matrices_function(spec)(parameter_vector, constant_vector)
    )
    squarings = _squarings_needed(a, b, time_step_s, spec.input_hold)
    values = _discretisation_function(spec, squarings)(
        parameter_vector, constant_vector, time_step_s
    )
    shapes = [spec.matrix_shape(name) for name in ("A", "B", "B", "C", "D")]
    matrices = [np.asarray(casadi.densify(values[2 * index])) for index in range(5)]
    derivatives = [_derivative_stack(values[2 * index + 1], shapes[index]) for index in range(5)]
    return DiscreteModel(*matrices, *derivatives)


def numeric_hold(
    a_matrix: np.ndarray, b_matrix: np.ndarray, time_step_s: float, input_hold: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ad, Bd, Bd_next of numeric A, B under ``input_hold`` (the module docstring), by one
    matrix exponential of the augmented matrix, for models without parameter derivatives.
    """
    states, inputs = b_matrix.shape
    ramp = input_hold == "first_order"
    size = states + (2 if ramp else 1) * inputs
    augmented = np.zeros((size, size))
    augmented[:states, :states] = a_matrix * time_step_s
    augmented[:states, states : states + inputs] = b_matrix * time_step_s
    if ramp:
        augmented[states : states + inputs, states + inputs :] = np.eye(inputs)
    exponential = expm(augmented)
    ad = exponential[:states, :states]
    integral = exponential[:states, states : states + inputs]
    if not ramp:
        return ad, integral, np.zeros_like(integral)
    ramp_integral = exponential[:states, states + inputs :]
    return ad, integral - ramp_integral, ramp_integral
