"""Trend fits: each quantity as a linear combination of basis features of tail geometry and position.

For one quantity with observations ``y_i`` at feature rows ``f_i`` (design/trend_basis.py) the fit is

    y_i = f_i . beta + e_i,    var(e_i) = kappa sigma_i^2

weighted least squares with weights ``1 / sigma_i^2`` when every observation has a sigma, ordinary least squares
(``sigma_i = 1``) otherwise. The scale ``kappa`` is estimated from the residuals, ``kappa = chi^2 / (n - p)``:
the sigmas are treated as *relative* weights, because published and per-model sigmas (e.g. Table 4's 0.5 %) are
estimation errors of single models, far below the flight-to-flight scatter about a trend (docs/background.md section 6).

- Parameter covariance ``C = kappa (F^T W F)^-1``.
- ``sigma_mean`` at a new point f: ``sqrt(f^T C f)``, the uncertainty of the *mean trend* there.
- ``sigma_new``: ``sqrt(sigma_mean^2 + residual_variance)``, the spread of *a new flight*, with
  ``residual_variance = kappa n / sum(1 / sigma_i^2)`` (a new flight as precise as the fitted ones on average;
  for OLS simply ``s^2``). Both 95 % intervals use Student's t with ``n - p`` degrees of freedom (exact for
  Gaussian scatter of known relative size).
- Leave-one-out: PRESS residuals ``r_i / (1 - h_ii)`` with the (weighted) hat matrix; ``loo_rmse`` is their
  root mean square in the quantity's unit.
- Extrapolation: the Mahalanobis distance of the prediction's features (without the intercept) from the fitted
  feature rows (their mean and sample covariance); fitted points themselves are at about sqrt(number of
  features). A feature that is constant in the data (x_h when every observation is at 57 mm) cannot be fitted:
  its coefficient is fixed at 0, and a prediction at another value is an unbounded extrapolation (distance inf).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from ornitail.core.errors import UserInputError
from ornitail.design.trend_basis import TrendBasis, trend_basis
from ornitail.design.trend_data import ALL_QUANTITIES, TrendObservation
from ornitail.vehicle.geometry import TailGeometry

_CONSTANT_FEATURE_RELATIVE_SPREAD = 1e-9
_RANK_TOLERANCE = 1e-10
_LEVERAGE_ONE = 1e-10
_RANGE_EDGE_RELATIVE_TOLERANCE = 1e-6
"""A design on the edge of the fitted range (where the range constraint holds it, to solver tolerance) is inside."""


@dataclass(frozen=True)
class TrendPrediction:
    """A trend's prediction at one geometry, with both intervals and the extrapolation measure.

    ``value`` in the quantity's SI unit; ``sigma_mean``: 1-sigma of the mean trend; ``sigma_new``: 1-sigma of a
    new flight (adds the residual scatter); ``interval_95_mean``/``interval_95_new``: Student-t 95 % intervals
    with ``degrees_of_freedom``; ``extrapolation``: Mahalanobis distance of the features from the fitted data;
    ``outside_fitted_range``: a feature lies outside the range of the fitted data (``extrapolation_note`` says
    which).
    """

    quantity: str
    value: float
    sigma_mean: float
    sigma_new: float
    degrees_of_freedom: int
    interval_95_mean: tuple[float, float]
    interval_95_new: tuple[float, float]
    extrapolation: float
    outside_fitted_range: bool
    extrapolation_note: str
    sources: tuple[str, ...]

    def as_dict(self) -> dict[str, Any]:
        """Plain dict for JSON output."""
        return {
            "quantity": self.quantity,
            "value": self.value,
            "sigma_mean": self.sigma_mean,
            "sigma_new": self.sigma_new,
            "degrees_of_freedom": self.degrees_of_freedom,
            "interval_95_mean": list(self.interval_95_mean),
            "interval_95_new": list(self.interval_95_new),
            "extrapolation_mahalanobis": self.extrapolation,
            "outside_fitted_range": self.outside_fitted_range,
            "extrapolation_note": self.extrapolation_note,
            "sources": list(self.sources),
        }


@dataclass
class QuantityTrend:
    """The fitted trend of one quantity.

    ``coefficients`` and ``covariance`` are over all of ``basis.feature_names`` (a feature fixed because the
    data hold it constant has coefficient 0 and zero covariance; ``fixed_features`` gives its value).
    """

    quantity: str
    basis: TrendBasis
    coefficients: np.ndarray
    covariance: np.ndarray
    residual_variance: float
    observation_count: int
    sources: tuple[str, ...]
    loo_rmse: float
    weighting: str = "ols"
    degrees_of_freedom: int = 0
    loo_residuals: np.ndarray = field(default_factory=lambda: np.zeros(0))
    configurations: tuple[str, ...] = ()
    fixed_features: dict[str, float] = field(default_factory=dict)
    feature_mean: np.ndarray = field(default_factory=lambda: np.zeros(0))
    feature_covariance_inverse: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    feature_min: np.ndarray = field(default_factory=lambda: np.zeros(0))
    feature_max: np.ndarray = field(default_factory=lambda: np.zeros(0))
    active_features: tuple[int, ...] = ()

    def predict(self, geometry_vector: Sequence[float]) -> TrendPrediction:
        """Prediction at ``(b, b_LE, c_r, c_t, x_h)`` (metres, hexagonal planform)."""
        return self.predict_features(np.asarray(self.basis.features(list(geometry_vector)), float))

    def predict_geometry(self, geometry: TailGeometry, x_h_m: float) -> TrendPrediction:
        """Prediction for a :class:`TailGeometry` (also the elliptical T2) at x_h (m)."""
        return self.predict_features(np.asarray(self.basis.features_of_geometry(geometry, x_h_m)))

    def predict_features(self, features: np.ndarray) -> TrendPrediction:
        """Prediction at a feature row (``basis.feature_names`` order)."""
        value = float(features @ self.coefficients)
        variance_mean = float(features @ self.covariance @ features)
        sigma_mean = float(np.sqrt(max(variance_mean, 0.0)))
        sigma_new = float(np.sqrt(max(variance_mean, 0.0) + self.residual_variance))
        quantile = float(stats.t.ppf(0.975, self.degrees_of_freedom))
        distance, outside, note = self._extrapolation(features)
        return TrendPrediction(
            quantity=self.quantity,
            value=value,
            sigma_mean=sigma_mean,
            sigma_new=sigma_new,
            degrees_of_freedom=self.degrees_of_freedom,
            interval_95_mean=(value - quantile * sigma_mean, value + quantile * sigma_mean),
            interval_95_new=(value - quantile * sigma_new, value + quantile * sigma_new),
            extrapolation=distance,
            outside_fitted_range=outside,
            extrapolation_note=note,
            sources=self.sources,
        )

    def _extrapolation(self, features: np.ndarray) -> tuple[float, bool, str]:
        names = self.basis.feature_names
        notes = [
            f"{name} = {features[names.index(name)]:.4g} but every fitted observation has {fixed:.4g}"
            for name, fixed in self.fixed_features.items()
            if abs(features[names.index(name)] - fixed)
            > _CONSTANT_FEATURE_RELATIVE_SPREAD * max(abs(fixed), 1e-12)
        ]
        leaves_fixed_feature = bool(notes)
        varying = np.asarray([index for index in self.active_features if index != 0], dtype=int)
        point = features[varying]
        for index, value, low, high in zip(
            varying, point, self.feature_min, self.feature_max, strict=True
        ):
            tolerance = _RANGE_EDGE_RELATIVE_TOLERANCE * max(abs(low), abs(high), 1e-12)
            if value < low - tolerance or value > high + tolerance:
                notes.append(
                    f"{names[index]} = {value:.4g} outside the fitted {low:.4g}..{high:.4g}"
                )
        if leaves_fixed_feature:
            distance = float("inf")
        else:
            offset = point - self.feature_mean
            distance = float(np.sqrt(max(offset @ self.feature_covariance_inverse @ offset, 0.0)))
        return distance, bool(notes), "; ".join(notes) if notes else "inside the fitted range"

    def casadi_value(self, geometry_vector_symbols: Sequence[Any]) -> Any:
        """``coefficients . features`` as an expression of the symbols (CasADi SX/MX, or floats)."""
        features = self.basis.features(list(geometry_vector_symbols))
        expression = 0.0
        for index in self.active_features:
            expression = expression + float(self.coefficients[index]) * features[index]
        return expression

    def summary(self) -> dict[str, Any]:
        """Coefficients with sigma, fit statistics and sources, for output."""
        sigmas = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        return {
            "quantity": self.quantity,
            "basis": self.basis.name,
            "weighting": self.weighting,
            "coefficients": {
                name: {"value": float(value), "sigma": float(sigma)}
                for name, value, sigma in zip(
                    self.basis.feature_names, self.coefficients, sigmas, strict=True
                )
            },
            "fixed_features": dict(self.fixed_features),
            "residual_sigma": float(np.sqrt(self.residual_variance)),
            "degrees_of_freedom": self.degrees_of_freedom,
            "observation_count": self.observation_count,
            "loo_rmse": self.loo_rmse,
            "loo_residuals": {
                name: float(value)
                for name, value in zip(self.configurations, self.loo_residuals, strict=True)
            },
            "sources": list(self.sources),
        }


@dataclass
class TrendModel:
    """Trends by quantity; ``unfitted`` says why a quantity present in the data got no trend."""

    trends: dict[str, QuantityTrend]
    unfitted: dict[str, str] = field(default_factory=dict)

    def predict(self, geometry_vector: Sequence[float]) -> dict[str, TrendPrediction]:
        """Every trend's prediction at ``(b, b_LE, c_r, c_t, x_h)`` (metres)."""
        return {name: trend.predict(geometry_vector) for name, trend in self.trends.items()}


def _sources_text(observations: Sequence[TrendObservation]) -> str:
    return ", ".join(sorted({observation.source for observation in observations})) or "no source"


def fit_quantity_trend(
    observations: Sequence[TrendObservation], quantity: str, basis: str | TrendBasis = "linear"
) -> QuantityTrend:
    """Fit one quantity's trend from the observations of that quantity (others are ignored)."""
    basis = trend_basis(basis)
    chosen = [observation for observation in observations if observation.quantity == quantity]
    where = f"trend of {quantity}"
    sources = tuple(sorted({observation.source for observation in chosen}))
    design = np.array(
        [basis.features_of_geometry(item.geometry, item.x_h_m) for item in chosen], dtype=float
    ).reshape(len(chosen), len(basis.feature_names))
    values = np.array([item.value for item in chosen], dtype=float)
    if not np.all(np.isfinite(design)) or not np.all(np.isfinite(values)):
        raise UserInputError(where, f"non-finite value or geometry in {_sources_text(chosen)}")
    active, fixed = _identifiable_features(design, basis)
    needed = len(active) + 1
    if len(chosen) < needed:
        raise UserInputError(
            where,
            f"{len(chosen)} observation(s) from {_sources_text(chosen)}, but basis {basis.name!r} needs "
            f"at least {needed} ({len(active)} coefficients identifiable from these data + 1 for the "
            f"scatter)",
        )
    reduced = design[:, active]
    scaled = reduced / np.max(np.abs(reduced), axis=0)
    if np.linalg.matrix_rank(scaled, tol=_RANK_TOLERANCE * np.sqrt(len(chosen))) < len(active):
        names = ", ".join(basis.feature_names[index] for index in active)
        raise UserInputError(
            where,
            f"features {names} are linearly dependent in the data from {_sources_text(chosen)}; "
            "choose a smaller basis or add configurations",
        )
    sigmas = [item.sigma for item in chosen]
    weighted = all(sigma is not None for sigma in sigmas)
    weights = np.array([1.0 / sigma**2 for sigma in sigmas]) if weighted else np.ones(len(chosen))
    return _weighted_fit(
        quantity=quantity,
        basis=basis,
        design=design,
        active=active,
        fixed=fixed,
        values=values,
        weights=weights,
        weighting="wls" if weighted else "ols",
        configurations=tuple(item.configuration for item in chosen),
        sources=sources,
    )


def _identifiable_features(
    design: np.ndarray, basis: TrendBasis
) -> tuple[list[int], dict[str, float]]:
    """Columns that vary in the data (plus the intercept), and the constant ones with their value."""
    active, fixed = [0], {}
    for index in range(1, design.shape[1]):
        column = design[:, index]
        spread = float(np.ptp(column))
        if spread <= _CONSTANT_FEATURE_RELATIVE_SPREAD * max(float(np.max(np.abs(column))), 1e-300):
            fixed[basis.feature_names[index]] = float(column[0])
        else:
            active.append(index)
    return active, fixed


def _weighted_fit(
    *,
    quantity: str,
    basis: TrendBasis,
    design: np.ndarray,
    active: list[int],
    fixed: dict[str, float],
    values: np.ndarray,
    weights: np.ndarray,
    weighting: str,
    configurations: tuple[str, ...],
    sources: tuple[str, ...],
) -> QuantityTrend:
    count, parameter_count = design.shape[0], len(active)
    reduced = design[:, active]
    root_weights = np.sqrt(weights)
    weighted_design = reduced * root_weights[:, None]
    normal_inverse = np.linalg.inv(weighted_design.T @ weighted_design)
    reduced_coefficients = normal_inverse @ (weighted_design.T @ (values * root_weights))
    residuals = values - reduced @ reduced_coefficients
    degrees_of_freedom = count - parameter_count
    scale = float(np.sum(weights * residuals**2) / degrees_of_freedom)
    coefficients = np.zeros(design.shape[1])
    coefficients[active] = reduced_coefficients
    covariance = np.zeros((design.shape[1], design.shape[1]))
    covariance[np.ix_(active, active)] = scale * normal_inverse
    leverage = np.einsum("ij,jk,ik->i", weighted_design, normal_inverse, weighted_design)
    with np.errstate(divide="ignore"):
        loo_residuals = np.where(
            1.0 - leverage > _LEVERAGE_ONE, residuals / (1.0 - leverage), np.inf
        )
    varying = [index for index in active if index != 0]
    features = design[:, varying]
    feature_covariance = (
        np.atleast_2d(np.cov(features, rowvar=False)) if varying else np.zeros((0, 0))
    )
    return QuantityTrend(
        quantity=quantity,
        basis=basis,
        coefficients=coefficients,
        covariance=covariance,
        residual_variance=scale * count / float(np.sum(weights)),
        observation_count=count,
        sources=sources,
        loo_rmse=float(np.sqrt(np.mean(loo_residuals**2))),
        weighting=weighting,
        degrees_of_freedom=degrees_of_freedom,
        loo_residuals=loo_residuals,
        configurations=configurations,
        fixed_features=fixed,
        feature_mean=features.mean(axis=0),
        feature_covariance_inverse=np.linalg.inv(feature_covariance)
        if varying
        else feature_covariance,
        feature_min=features.min(axis=0),
        feature_max=features.max(axis=0),
        active_features=tuple(active),
    )


def fit_trends(
    observations: Iterable[TrendObservation],
    basis: str | TrendBasis = "linear",
    quantities: Sequence[str] | None = None,
) -> TrendModel:
    """Fit a trend per quantity.

    With ``quantities`` given, each must be fittable (else :class:`UserInputError` naming it and its
    sources). Without, every quantity present is tried and the ones with too few or degenerate data are
    listed in ``TrendModel.unfitted`` with the reason.
    """
    observations = list(observations)
    basis = trend_basis(basis)
    if quantities is not None:
        unknown = [name for name in quantities if name not in ALL_QUANTITIES]
        if unknown:
            raise UserInputError(
                "quantities", f"unknown {', '.join(unknown)}; known: {', '.join(ALL_QUANTITIES)}"
            )
        return TrendModel(
            {name: fit_quantity_trend(observations, name, basis) for name in quantities}
        )
    present = [name for name in ALL_QUANTITIES if any(o.quantity == name for o in observations)]
    trends, unfitted = {}, {}
    for name in present:
        try:
            trends[name] = fit_quantity_trend(observations, name, basis)
        except UserInputError as error:
            unfitted[name] = error.problem
    if not trends:
        reasons = "; ".join(f"{name}: {reason}" for name, reason in unfitted.items())
        raise UserInputError(
            "trend fit", f"no quantity could be fitted ({reasons or 'no observations'})"
        )
    return TrendModel(trends, unfitted)


@dataclass(frozen=True)
class HeldOutPrediction:
    """One observation predicted by a trend fitted without it."""

    configuration: str
    measured: float
    measured_sigma: float | None
    prediction: TrendPrediction


def leave_one_out_predictions(
    observations: Sequence[TrendObservation], quantity: str, basis: str | TrendBasis = "linear"
) -> list[HeldOutPrediction]:
    """Refit without each observation of ``quantity`` in turn and predict it (explicit LOO)."""
    chosen = [observation for observation in observations if observation.quantity == quantity]
    held_out = []
    for index, observation in enumerate(chosen):
        trend = fit_quantity_trend(chosen[:index] + chosen[index + 1 :], quantity, basis)
        held_out.append(
            HeldOutPrediction(
                configuration=observation.configuration,
                measured=observation.value,
                measured_sigma=observation.sigma,
                prediction=trend.predict_geometry(observation.geometry, observation.x_h_m),
            )
        )
    return held_out
