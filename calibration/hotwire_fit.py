"""Fitting hot-wire laws to calibration points, with a residual report in m/s.

King's law is fitted in two steps: first with ``n = 0.5`` by linear least squares of ``E_corr^2``
on ``sqrt(U)``, then (unless ``free_exponent=False``) with ``A, B, n`` free by nonlinear least
squares of the voltage residual ``sqrt(A + B U^n) - E_corr``, started from the first fit. Fitting
in volts weights every point by the anemometer's (roughly constant) voltage noise. The
polynomial law is a linear least-squares fit of ``U`` on powers of ``E_corr``.

Temperatures are kelvin; the reference temperature defaults to the mean of the points'.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ornitail.calibration.hotwire_laws import (
    HotwireFitProvenance,
    HotwireLaw,
    KingsLaw,
    PolynomialHotwireLaw,
)
from ornitail.calibration.hotwire_points import (
    HotwireCalibrationPoints,
    temperature_corrected_voltage,
)
from ornitail.core.errors import UserInputError

DEFAULT_POLYNOMIAL_ORDER = 4
KING_EXPONENT_FIRST_GUESS = 0.5
KING_EXPONENT_BOUNDS = (0.05, 2.0)


@dataclass(frozen=True, eq=False)
class HotwireFitReport:
    """Per-point residuals of a fitted law (m/s) and, for King's law, parameter standard errors.

    ``residual_m_s = fitted - measured`` velocity at each calibration point.
    ``parameter_standard_errors`` maps ``a_v2``, ``b``, ``exponent_n`` to their standard errors
    from the Jacobian at the solution (King's law with free exponent only; else empty).
    """

    velocity_m_s: np.ndarray
    fitted_velocity_m_s: np.ndarray
    residual_m_s: np.ndarray
    rms_residual_m_s: float
    max_abs_residual_m_s: float
    parameter_standard_errors: dict[str, float]


@dataclass(frozen=True, eq=False)
class HotwireFit:
    """A fitted law and its residual report."""

    law: HotwireLaw
    report: HotwireFitReport


def _residual_report(
    law: HotwireLaw, points: HotwireCalibrationPoints, standard_errors: dict[str, float]
) -> HotwireFitReport:
    fitted = law.velocity_from_voltage(points.voltage_v, points.temperature_k)
    residual = fitted - points.velocity_m_s
    return HotwireFitReport(
        velocity_m_s=points.velocity_m_s,
        fitted_velocity_m_s=fitted,
        residual_m_s=residual,
        rms_residual_m_s=float(np.sqrt(np.mean(residual**2))),
        max_abs_residual_m_s=float(np.max(np.abs(residual))),
        parameter_standard_errors=standard_errors,
    )


def _with_provenance(
    law: HotwireLaw, report: HotwireFitReport, points: HotwireCalibrationPoints
) -> HotwireLaw:
    provenance = HotwireFitProvenance(
        points_content_hash=points.content_hash,
        point_count=int(points.velocity_m_s.size),
        rms_residual_m_s=report.rms_residual_m_s,
        max_abs_residual_m_s=report.max_abs_residual_m_s,
    )
    return dataclasses.replace(law, provenance=provenance, content_hash="")


def _reference_and_corrected(
    points: HotwireCalibrationPoints,
    wire_temperature_k: float,
    reference_temperature_k: float | None,
) -> tuple[float, np.ndarray]:
    reference = (
        float(np.mean(points.temperature_k))
        if reference_temperature_k is None
        else float(reference_temperature_k)
    )
    corrected = temperature_corrected_voltage(
        points.voltage_v, points.temperature_k, reference, wire_temperature_k
    )
    return reference, corrected


def fit_kings_law(
    points: HotwireCalibrationPoints,
    wire_temperature_k: float,
    reference_temperature_k: float | None = None,
    free_exponent: bool = True,
) -> HotwireFit:
    """Fit ``E_corr^2 = A + B U^n``: first ``n = 0.5`` (linear), then ``n`` free (nonlinear)."""
    reference, corrected = _reference_and_corrected(
        points, wire_temperature_k, reference_temperature_k
    )
    velocity = points.velocity_m_s
    _require_distinct(points.path, velocity, 3 if free_exponent else 2, "velocities", "King's law")
    _require_distinct(points.path, corrected, 2, "voltages", "King's law")
    design = np.column_stack([np.ones_like(velocity), np.sqrt(velocity)])
    (a_v2, b), *_ = np.linalg.lstsq(design, corrected**2, rcond=None)
    exponent = KING_EXPONENT_FIRST_GUESS
    if b <= 0.0:
        raise UserInputError(
            str(points.path), "voltage does not rise with velocity; cannot fit King's law"
        )
    standard_errors: dict[str, float] = {}
    if free_exponent:

        def voltage_residual(parameters: np.ndarray) -> np.ndarray:
            a, b_, n = parameters
            return np.sqrt(np.maximum(a + b_ * velocity**n, 0.0)) - corrected

        # Imported here: `ornitail calibration --help` needs no scipy.
        from scipy.optimize import least_squares

        start = np.array([max(a_v2, 1e-6), b, exponent])
        solution = least_squares(
            voltage_residual,
            start,
            bounds=([0.0, 0.0, KING_EXPONENT_BOUNDS[0]], [np.inf, np.inf, KING_EXPONENT_BOUNDS[1]]),
            x_scale="jac",
            xtol=1e-12,
            ftol=1e-12,
        )
        a_v2, b, exponent = solution.x
        degrees_of_freedom = velocity.size - 3
        if degrees_of_freedom > 0:
            residual_variance = float(np.sum(solution.fun**2)) / degrees_of_freedom
            covariance = np.linalg.pinv(solution.jac.T @ solution.jac) * residual_variance
            standard_errors = dict(
                zip(("a_v2", "b", "exponent_n"), np.sqrt(np.diag(covariance)).tolist(), strict=True)
            )
    law = KingsLaw(
        a_v2=float(a_v2),
        b=float(b),
        exponent_n=float(exponent),
        reference_temperature_k=reference,
        wire_temperature_k=float(wire_temperature_k),
        provenance=HotwireFitProvenance(points.content_hash, int(velocity.size), 0.0, 0.0),
    )
    report = _residual_report(law, points, standard_errors)
    _require_finite_fit(points.path, report)
    return HotwireFit(_with_provenance(law, report, points), report)


def _require_distinct(
    path: Path | None, values: np.ndarray, needed: int, what: str, law: str
) -> None:
    """Refuse points with fewer than ``needed`` distinct ``values``: the fit is undetermined."""
    distinct = int(np.unique(values).size)
    if distinct < needed:
        raise UserInputError(
            str(path),
            f"the points have {distinct} distinct {what}; {law} needs at least {needed} "
            "(calibrate over a range of velocities)",
        )


def _require_finite_fit(path: Path | None, report: HotwireFitReport) -> None:
    """Refuse a fit whose fitted velocities are not finite (points far outside a hot wire's range)."""
    if not np.all(np.isfinite(report.fitted_velocity_m_s)):
        raise UserInputError(
            str(path), "the fit gives non-finite velocities; check the points' values and units"
        )


def fit_polynomial_law(
    points: HotwireCalibrationPoints,
    wire_temperature_k: float,
    order: int = DEFAULT_POLYNOMIAL_ORDER,
    reference_temperature_k: float | None = None,
) -> HotwireFit:
    """Fit ``U = sum_k c_k E_corr^k`` of the given ``order`` by linear least squares."""
    if order < 1:
        raise UserInputError("polynomial order", f"must be at least 1, got {order}")
    if points.velocity_m_s.size <= order:
        raise UserInputError(
            str(points.path),
            f"a polynomial of order {order} needs more than {order} points, "
            f"got {points.velocity_m_s.size}",
        )
    reference, corrected = _reference_and_corrected(
        points, wire_temperature_k, reference_temperature_k
    )
    _require_distinct(
        points.path, corrected, order + 1, "voltages", f"a polynomial of order {order}"
    )
    _require_distinct(points.path, points.velocity_m_s, 2, "velocities", "a polynomial law")
    coefficients = np.polynomial.polynomial.polyfit(corrected, points.velocity_m_s, order)
    law = PolynomialHotwireLaw(
        coefficients=coefficients,
        reference_temperature_k=reference,
        wire_temperature_k=float(wire_temperature_k),
        provenance=HotwireFitProvenance(
            points.content_hash, int(points.velocity_m_s.size), 0.0, 0.0
        ),
    )
    report = _residual_report(law, points, {})
    _require_finite_fit(points.path, report)
    return HotwireFit(_with_provenance(law, report, points), report)
