"""Zero-order-hold discretisation of a model file's matrices, with exact parameter derivatives.

Ad = exp(A dt) and Bd = int_0^dt exp(A s) ds B come from the exponential of the augmented matrix
[[A, B], [0, 0]] dt, computed symbolically in CasADi by scaling and squaring: a degree-12 Taylor
polynomial of the matrix divided by 2^s (norm <= 0.5, truncation error below 1e-13 relative), then
s squarings. CasADi differentiates it exactly. One CasADi Function per (model, s) is built once and
re-used for every evaluation, manoeuvre and sample time (dt is an input).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi
import numpy as np

from ornitail.flight.model_file import StateSpaceModelSpec

TAYLOR_DEGREE = 12
SCALED_NORM_LIMIT = 0.5


@dataclass(frozen=True)
class DiscreteModel:
    """x[k+1] = ad x[k] + bd u[k], y[k] = c x[k] + d u[k], and the derivatives of the four
    matrices with respect to every parameter (first axis: parameter, in model file order).
    """

    ad: np.ndarray
    bd: np.ndarray
    c: np.ndarray
    d: np.ndarray
    d_ad: np.ndarray
    d_bd: np.ndarray
    d_c: np.ndarray
    d_d: np.ndarray


def _squarings_needed(a_matrix: np.ndarray, b_matrix: np.ndarray, time_step_s: float) -> int:
    augmented_norm = np.linalg.norm(np.hstack([a_matrix, b_matrix]), ord=1) * time_step_s
    if not math.isfinite(augmented_norm):
        return 0
    return max(0, math.ceil(math.log2(max(augmented_norm, 1e-300) / SCALED_NORM_LIMIT)))


def _symbolic_zero_order_hold(
    a: casadi.SX, b: casadi.SX, time_step: casadi.SX, squarings: int
) -> tuple[casadi.SX, casadi.SX]:
    states, inputs = a.shape[0], b.shape[1]
    size = states + inputs
    augmented = casadi.SX.zeros(size, size)
    augmented[:states, :states] = a * time_step / 2**squarings
    augmented[:states, states:] = b * time_step / 2**squarings
    exponential = casadi.SX.eye(size)
    term = casadi.SX.eye(size)
    for degree in range(1, TAYLOR_DEGREE + 1):
        term = casadi.mtimes(term, augmented) / degree
        exponential = exponential + term
    for _ in range(squarings):
        exponential = casadi.mtimes(exponential, exponential)
    return exponential[:states, :states], exponential[:states, states:]


def _discretisation_function(spec: StateSpaceModelSpec, squarings: int) -> casadi.Function:
    key = f"zoh_{squarings}"
    if key not in spec._functions:
        parameters = casadi.SX.sym("p", len(spec.parameters))
        constants = casadi.SX.sym("c", len(spec.constant_names))
        time_step = casadi.SX.sym("dt")
        a, b, c, d = spec.symbolic_matrices(parameters, constants)
        ad, bd = _symbolic_zero_order_hold(a, b, time_step, squarings)
        outputs = []
        for matrix in (ad, bd, c, d):
            outputs += [matrix, casadi.jacobian(casadi.vec(matrix), parameters)]
        spec._functions[key] = casadi.Function(key, [parameters, constants, time_step], outputs)
    return spec._functions[key]


def continuous_jacobian_function(spec: StateSpaceModelSpec) -> casadi.Function:
    """CasADi Function (parameters, constants) -> (A, B, C, D, dvec(A)/dp, ..., dvec(D)/dp)."""
    if "continuous_jacobian" not in spec._functions:
        parameters = casadi.SX.sym("p", len(spec.parameters))
        constants = casadi.SX.sym("c", len(spec.constant_names))
        matrices = spec.symbolic_matrices(parameters, constants)
        jacobians = [casadi.jacobian(casadi.vec(matrix), parameters) for matrix in matrices]
        spec._functions["continuous_jacobian"] = casadi.Function(
            "continuous_jacobian", [parameters, constants], [*matrices, *jacobians]
        )
    return spec._functions["continuous_jacobian"]


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
    """Zero-order-hold model and its exact parameter derivatives at ``parameter_vector``
    (all parameters, model file order) and ``constant_vector`` (:attr:`constant_names` order).
    """
    a, b, _, _ = (
        np.asarray(matrix) for matrix in spec.matrices_function()(parameter_vector, constant_vector)
    )
    squarings = _squarings_needed(a, b, time_step_s)
    values = _discretisation_function(spec, squarings)(
        parameter_vector, constant_vector, time_step_s
    )
    shapes = [spec.matrix_shape(name) for name in ("B", "B", "C", "D")]
    shapes[0] = spec.matrix_shape("A")
    matrices = [np.asarray(casadi.densify(values[2 * index])) for index in range(4)]
    derivatives = [_derivative_stack(values[2 * index + 1], shapes[index]) for index in range(4)]
    return DiscreteModel(*matrices, *derivatives)
