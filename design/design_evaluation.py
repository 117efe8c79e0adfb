"""Predicted flight behaviour of one candidate tail: steady state, A matrix, poles, damping intervals.

This is the numpy side of a proposal: the CasADi problem (proposal.py) builds the same model
symbolically, and every solution it returns is re-evaluated here, with numpy eigenvalues, before it
is reported.

Quantities that enter A (``A_MODEL_QUANTITIES``) come from the trend model (value and variance for
the mean trend and for a new flight); mass and pitch inertia come from trends ``mass_kg`` and
``iyy_kg_m2`` when the trend model has them, otherwise from ``design/mass_model.py`` (no variance).
Trends of different quantities are fitted separately, so their errors are treated as independent.

Intervals on the damping ratio and natural frequency use the delta method: the gradient of (zeta,
omega) with respect to the predicted quantities (central differences of numpy eigenvalues) times
their variances. ``sigma_mean`` is the uncertainty of the mean trend (where the fitted line is);
``sigma_new`` adds the trends' residual scatter: what one new flight of the built tail may show.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.core.normal_quantiles import NORMAL_QUANTILE_95
from ornitail.design.linear_model import (
    A_MATRIX_DERIVATIVES,
    ModalSummary,
    a_matrix,
    a_matrix_entries,
    modal_summary,
)
from ornitail.vehicle.geometry import TailGeometry

STEADY_STATE_QUANTITIES = ("theta_ss_rad", "v_ss_m_s", "f_ss_hz")
MASS_QUANTITIES = ("mass_kg", "iyy_kg_m2")
A_MODEL_QUANTITIES = (*A_MATRIX_DERIVATIVES, "theta_ss_rad", "v_ss_m_s", *MASS_QUANTITIES)


@dataclass(frozen=True)
class MassInertiaModel:
    """Mass (kg) and pitch inertia (kg m^2) as functions of the geometry vector (b, b_LE, c_r, c_t,
    x_h) in metres; each works on floats and on CasADi symbols. ``source`` says where they come from.
    """

    mass_kg: Callable[[Sequence[Any]], Any]
    iyy_kg_m2: Callable[[Sequence[Any]], Any]
    source: str


def mass_inertia_model_for(trend_model: Any) -> MassInertiaModel | None:
    """The mass model used with ``trend_model``: None when the trend model itself has trends
    ``mass_kg`` and ``iyy_kg_m2`` (preferred), else the documented estimates of design/mass_model.py.
    """
    if all(name in trend_model.trends for name in MASS_QUANTITIES):
        return None
    from ornitail.design import mass_model

    return MassInertiaModel(
        mass_kg=mass_model.vehicle_mass_kg,
        iyy_kg_m2=mass_model.pitch_inertia_kg_m2,
        source="design/mass_model.py estimate",
    )


def require_model_quantities(trend_model: Any, mass_inertia: MassInertiaModel | None) -> None:
    """Raise :class:`UserInputError` when the trend model lacks a quantity the A matrix needs."""
    needed = A_MATRIX_DERIVATIVES + ("theta_ss_rad", "v_ss_m_s")
    if mass_inertia is None:
        needed = needed + MASS_QUANTITIES
    missing = [name for name in needed if name not in trend_model.trends]
    if missing:
        raise UserInputError(
            "trend data",
            f"no trend for {', '.join(missing)}; a proposal needs every derivative of A "
            "(Mq..Zw) and theta_ss, V_ss",
        )


@dataclass(frozen=True)
class PredictedQuantity:
    """A predicted value (SI) with its standard deviations for the mean trend and for a new flight,
    the extrapolation distance of the design from the fitted data (Mahalanobis, None when the
    quantity is not a trend) and where it came from."""

    value: float
    sigma_mean: float
    sigma_new: float
    extrapolation: float | None
    sources: tuple[str, ...]


def predicted_quantities(
    trend_model: Any, geometry_vector: Sequence[float], mass_inertia: MassInertiaModel | None
) -> dict[str, PredictedQuantity]:
    """Every trend prediction at ``geometry_vector`` plus mass and inertia (SI units)."""
    result: dict[str, PredictedQuantity] = {}
    for name, prediction in trend_model.predict(tuple(geometry_vector)).items():
        result[name] = PredictedQuantity(
            value=float(prediction.value),
            sigma_mean=float(prediction.sigma_mean),
            sigma_new=float(prediction.sigma_new),
            extrapolation=float(prediction.extrapolation),
            sources=tuple(prediction.sources),
        )
    if mass_inertia is not None:
        for name, function in (
            ("mass_kg", mass_inertia.mass_kg),
            ("iyy_kg_m2", mass_inertia.iyy_kg_m2),
        ):
            result[name] = PredictedQuantity(
                float(function(tuple(geometry_vector))), 0.0, 0.0, None, (mass_inertia.source,)
            )
    return result


def a_matrix_of_quantities(
    values: Mapping[str, Any],
    cos: Callable[[Any], Any] = math.cos,
    sin: Callable[[Any], Any] = math.sin,
) -> list[list[Any]]:
    """A-matrix rows from a mapping holding ``A_MODEL_QUANTITIES`` (floats or CasADi symbols)."""
    return a_matrix_entries(
        values,
        values["mass_kg"],
        values["iyy_kg_m2"],
        values["theta_ss_rad"],
        values["v_ss_m_s"],
        cos=cos,
        sin=sin,
    )


@dataclass(frozen=True)
class IntervalEstimate:
    """A value with standard deviations for the mean trend and a new flight (same units)."""

    value: float
    sigma_mean: float
    sigma_new: float

    def interval_95(self, kind: str) -> tuple[float, float]:
        """Two-sided 95 % interval, ``kind`` "mean" (mean trend) or "new" (a new flight)."""
        sigma = self.sigma_mean if kind == "mean" else self.sigma_new
        return (self.value - NORMAL_QUANTILE_95 * sigma, self.value + NORMAL_QUANTILE_95 * sigma)


@dataclass(frozen=True)
class DesignEvaluation:
    """Everything predicted for one tail at one position (SI units, radians)."""

    geometry: TailGeometry
    x_h_m: float
    area_m2: float
    aspect_ratio: float
    quantities: dict[str, PredictedQuantity]
    a_matrix: np.ndarray
    modes: ModalSummary
    damping_ratio: IntervalEstimate
    natural_frequency_rad_s: IntervalEstimate

    @property
    def max_extrapolation(self) -> float:
        distances = [
            q.extrapolation for q in self.quantities.values() if q.extrapolation is not None
        ]
        return max(distances) if distances else math.nan


def _modal_pair(values: Mapping[str, float]) -> tuple[float, float]:
    matrix = np.array(a_matrix_of_quantities(values), dtype=float)
    modes = modal_summary(matrix)
    return modes.damping_ratio, modes.natural_frequency_rad_s


def modal_sensitivities(values: Mapping[str, float]) -> dict[str, np.ndarray]:
    """d(zeta, omega)/d(quantity) for every A-model quantity by central differences (relative
    step 1e-6: truncation error ~1e-12 relative, round-off ~1e-10, far below the sigmas)."""
    gradients: dict[str, np.ndarray] = {}
    for name in A_MODEL_QUANTITIES:
        step = 1e-6 * max(abs(values[name]), 1e-9)
        plus = dict(values, **{name: values[name] + step})
        minus = dict(values, **{name: values[name] - step})
        gradients[name] = (np.array(_modal_pair(plus)) - np.array(_modal_pair(minus))) / (2 * step)
    return gradients


def evaluate_design(
    trend_model: Any,
    geometry: TailGeometry,
    x_h_m: float,
    mass_inertia: MassInertiaModel | None,
) -> DesignEvaluation:
    """Predict steady state, A, poles and the oscillatory mode with intervals for one design."""
    if geometry.leading_edge_span_m is None:
        raise UserInputError("tail geometry", "proposals use the hexagonal planform (b_LE given)")
    vector = (
        geometry.span_m,
        geometry.leading_edge_span_m,
        geometry.root_chord_m,
        geometry.tip_chord_m,
        x_h_m,
    )
    quantities = predicted_quantities(trend_model, vector, mass_inertia)
    values = {name: quantities[name].value for name in A_MODEL_QUANTITIES}
    matrix = a_matrix(
        values, values["mass_kg"], values["iyy_kg_m2"], values["theta_ss_rad"], values["v_ss_m_s"]
    )
    modes = modal_summary(matrix)
    variance_mean = np.zeros(2)
    variance_new = np.zeros(2)
    if modes.oscillatory_eigenvalue is not None:
        for name, gradient in modal_sensitivities(values).items():
            variance_mean += gradient**2 * quantities[name].sigma_mean ** 2
            variance_new += gradient**2 * quantities[name].sigma_new ** 2
    sigma_mean, sigma_new = np.sqrt(variance_mean), np.sqrt(variance_new)
    return DesignEvaluation(
        geometry=geometry,
        x_h_m=float(x_h_m),
        area_m2=geometry.area_m2,
        aspect_ratio=geometry.aspect_ratio,
        quantities=quantities,
        a_matrix=matrix,
        modes=modes,
        damping_ratio=IntervalEstimate(
            modes.damping_ratio, float(sigma_mean[0]), float(sigma_new[0])
        ),
        natural_frequency_rad_s=IntervalEstimate(
            modes.natural_frequency_rad_s, float(sigma_mean[1]), float(sigma_new[1])
        ),
    )
