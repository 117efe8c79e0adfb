"""The decoupled longitudinal LTI model of docs/background.md section 5, for floats and for casadi symbols.

States are [q, u, w, theta] in the body frame of docs/frames.md (z_b along the fuselage towards the
tail, positive M nose-down). About a steady state at pitch attitude theta0 (rad) and airspeed V0
(m/s) in still air, u0 = -V0 cos(theta0) and w0 = -V0 sin(theta0).

Everything here uses only + - * / and the trigonometric functions handed in, so the same code builds
the numeric matrix (numpy) and the symbolic one inside the proposal's CasADi problem. The
characteristic polynomial is computed by the Faddeev-LeVerrier recursion, which needs only matrix
products and traces; the oscillatory pitch mode is then matched to a quadratic factor
(s^2 + 2 zeta omega s + omega^2)(s^2 + a s + p).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ornitail.vehicle.constants import STANDARD_GRAVITY_M_S2

STATE_NAMES = ("q", "u", "w", "theta")
A_MATRIX_DERIVATIVES = ("Mq", "Mu", "Mw", "Xq", "Xu", "Xw", "Zq", "Zu", "Zw")

Matrix = list[list[Any]]


def a_matrix_entries(
    derivatives: Mapping[str, Any],
    mass_kg: Any,
    iyy_kg_m2: Any,
    theta0_rad: Any,
    v0_m_s: Any,
    cos: Callable[[Any], Any] = math.cos,
    sin: Callable[[Any], Any] = math.sin,
) -> Matrix:
    """Rows of the 4x4 A matrix (docs/background.md section 5) as nested lists.

    Parameters
    ----------
    derivatives : mapping
        Dimensional derivatives ``Mq, Mu, Mw`` (N m per rad/s or per m/s), ``Xq, ..., Zw`` (N per
        rad/s or per m/s) in the body frame of docs/frames.md; floats or casadi expressions.
    mass_kg, iyy_kg_m2 : float or casadi expression
        Vehicle mass (kg) and pitch inertia (kg m^2).
    theta0_rad, v0_m_s : float or casadi expression
        Steady pitch attitude (rad) and airspeed (m/s).
    cos, sin : callable
        Trigonometric functions for the type of ``theta0_rad`` (``casadi.cos`` for symbols).
    """
    d, m, i = derivatives, mass_kg, iyy_kg_m2
    cos_theta, sin_theta = cos(theta0_rad), sin(theta0_rad)
    u0 = -v0_m_s * cos_theta
    w0 = -v0_m_s * sin_theta
    return [
        [d["Mq"] / i, d["Mu"] / i, d["Mw"] / i, 0.0],
        [d["Xq"] / m - w0, d["Xu"] / m, d["Xw"] / m, -STANDARD_GRAVITY_M_S2 * cos_theta],
        [d["Zq"] / m + u0, d["Zu"] / m, d["Zw"] / m, -STANDARD_GRAVITY_M_S2 * sin_theta],
        [1.0, 0.0, 0.0, 0.0],
    ]


def a_matrix(
    derivatives: Mapping[str, float],
    mass_kg: float,
    iyy_kg_m2: float,
    theta0_rad: float,
    v0_m_s: float,
) -> np.ndarray:
    """The numeric 4x4 A matrix (1/s and m/s^2 per rad entries), states [q, u, w, theta]."""
    return np.array(
        a_matrix_entries(derivatives, mass_kg, iyy_kg_m2, theta0_rad, v0_m_s), dtype=float
    )


def _matrix_product(left: Matrix, right: Matrix) -> Matrix:
    size = len(left)
    return [
        [
            sum((left[r][k] * right[k][c] for k in range(1, size)), left[r][0] * right[0][c])
            for c in range(size)
        ]
        for r in range(size)
    ]


def characteristic_polynomial(matrix: Sequence[Sequence[Any]]) -> list[Any]:
    """Coefficients [c1, ..., cn] of det(sI - A) = s^n + c1 s^(n-1) + ... + cn.

    Faddeev-LeVerrier: M_1 = I, c_k = -trace(A M_k) / k, M_(k+1) = A M_k + c_k I. Works on floats
    and on casadi scalars alike (only + - * /).
    """
    rows = [list(row) for row in matrix]
    size = len(rows)
    identity_like = [[1.0 if r == c else 0.0 for c in range(size)] for r in range(size)]
    current = identity_like
    coefficients: list[Any] = []
    for k in range(1, size + 1):
        product = _matrix_product(rows, current)
        trace = sum((product[j][j] for j in range(1, size)), product[0][0])
        coefficient = -trace / k
        coefficients.append(coefficient)
        current = [
            [product[r][c] + (coefficient if r == c else 0.0) for c in range(size)]
            for r in range(size)
        ]
    return coefficients


def quadratic_factor_coefficients(
    damping_ratio: Any, natural_frequency_rad_s: Any, second_linear: Any, second_constant: Any
) -> list[Any]:
    """Coefficients [c1, c2, c3, c4] of (s^2 + 2 zeta omega s + omega^2)(s^2 + a s + p)."""
    two_zeta_omega = 2 * damping_ratio * natural_frequency_rad_s
    omega_squared = natural_frequency_rad_s * natural_frequency_rad_s
    a, p = second_linear, second_constant
    return [
        two_zeta_omega + a,
        omega_squared + two_zeta_omega * a + p,
        two_zeta_omega * p + a * omega_squared,
        omega_squared * p,
    ]


@dataclass(frozen=True)
class ModalSummary:
    """Eigenvalues of A (1/s) with the oscillatory pitch mode picked out.

    ``oscillatory_eigenvalue`` has a positive imaginary part (None if all poles are real);
    ``other_poles`` are the remaining two eigenvalues.
    """

    eigenvalues: np.ndarray
    oscillatory_eigenvalue: complex | None
    damping_ratio: float
    natural_frequency_rad_s: float
    other_poles: np.ndarray


def modal_summary(matrix: np.ndarray) -> ModalSummary:
    """Eigen-decompose a numeric A; the oscillatory mode is the complex pair of smallest modulus."""
    values = np.linalg.eigvals(np.asarray(matrix, dtype=float))
    values = values[np.argsort(values.real)]
    complex_values = [value for value in values if value.imag > 1e-9]
    if not complex_values:
        return ModalSummary(values, None, math.nan, math.nan, values)
    pick = min(complex_values, key=abs)
    others = np.array(
        [
            value
            for value in values
            if abs(value - pick) > 1e-9 and abs(value - pick.conjugate()) > 1e-9
        ]
    )
    return ModalSummary(
        eigenvalues=values,
        oscillatory_eigenvalue=complex(pick),
        damping_ratio=float(-pick.real / abs(pick)),
        natural_frequency_rad_s=float(abs(pick)),
        other_poles=others,
    )
