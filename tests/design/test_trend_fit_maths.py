"""Trend-fit maths: hand calculations, leave-one-out, interval coverage, CasADi equals numpy."""

from __future__ import annotations

import math

import casadi
import numpy as np
import pytest
from scipy import stats

from ornitail.core.errors import UserInputError
from ornitail.design.trend_basis import BASES
from ornitail.design.trend_data import TrendObservation
from ornitail.design.trends import fit_quantity_trend, fit_trends, leave_one_out_predictions
from ornitail.vehicle.geometry import study_tails

TAILS = study_tails()


def _observation(tail: str, x_h_mm: float, value: float, sigma: float | None = None, quantity="Mq"):
    return TrendObservation(
        configuration=f"{tail}@{x_h_mm:g}",
        tail_id=tail,
        geometry=TAILS[tail].geometry,
        x_h_m=x_h_mm / 1000.0,
        quantity=quantity,
        value=value,
        sigma=sigma,
        source="user:test",
    )


THREE_POINT_TAILS = ("S1", "S2", "S3")
THREE_POINT_VALUES = (1.0, 2.0, 4.0)


@pytest.fixture
def three_point_line():
    observations = [
        _observation(tail, 98.0, value)
        for tail, value in zip(THREE_POINT_TAILS, THREE_POINT_VALUES, strict=True)
    ]
    x = np.array([TAILS[tail].geometry.area_m2 for tail in THREE_POINT_TAILS])
    return observations, x, np.array(THREE_POINT_VALUES)


def test_three_point_line_matches_the_textbook_formulas(three_point_line):
    observations, x, y = three_point_line
    trend = fit_quantity_trend(observations, "Mq", "linear-area")  # [1, S, x_h]; x_h constant
    n, x_mean, y_mean = 3, x.mean(), y.mean()
    sxx = np.sum((x - x_mean) ** 2)
    slope = np.sum((x - x_mean) * (y - y_mean)) / sxx
    intercept = y_mean - slope * x_mean
    residual_variance = np.sum((y - intercept - slope * x) ** 2) / (n - 2)
    assert trend.weighting == "ols"
    assert trend.fixed_features == {"x_h_m": pytest.approx(0.098)}
    # Exact arithmetic both ways: only rounding (1e-9 relative) separates them.
    assert trend.coefficients == pytest.approx([intercept, slope, 0.0], rel=1e-9)
    assert trend.residual_variance == pytest.approx(residual_variance, rel=1e-9)
    assert trend.covariance[1, 1] == pytest.approx(residual_variance / sxx, rel=1e-9)
    assert trend.covariance[0, 0] == pytest.approx(
        residual_variance * (1 / n + x_mean**2 / sxx), rel=1e-9
    )
    assert trend.covariance[0, 1] == pytest.approx(-residual_variance * x_mean / sxx, rel=1e-9)
    x_new = TAILS["S5"].geometry.area_m2
    prediction = trend.predict_geometry(TAILS["S5"].geometry, 0.098)
    leverage_term = 1 / n + (x_new - x_mean) ** 2 / sxx
    assert prediction.value == pytest.approx(intercept + slope * x_new, rel=1e-9)
    assert prediction.sigma_mean == pytest.approx(math.sqrt(residual_variance * leverage_term))
    assert prediction.sigma_new == pytest.approx(math.sqrt(residual_variance * (1 + leverage_term)))
    t_quantile = stats.t.ppf(0.975, 1)  # 12.71 with one degree of freedom
    assert prediction.interval_95_new[1] - prediction.value == pytest.approx(
        t_quantile * prediction.sigma_new
    )
    assert prediction.outside_fitted_range  # S5 lies beyond S3, the largest fitted area


def test_leave_one_out_by_hand(three_point_line):
    observations, x, y = three_point_line
    trend = fit_quantity_trend(observations, "Mq", "linear-area")
    by_hand = []
    for left_out in range(3):
        keep = [index for index in range(3) if index != left_out]
        slope = (y[keep[1]] - y[keep[0]]) / (x[keep[1]] - x[keep[0]])
        by_hand.append(y[left_out] - (y[keep[0]] + slope * (x[left_out] - x[keep[0]])))
    assert trend.loo_residuals == pytest.approx(by_hand, rel=1e-9)
    assert trend.loo_rmse == pytest.approx(math.sqrt(np.mean(np.square(by_hand))), rel=1e-9)


def test_explicit_refit_agrees_with_press_residuals_under_weights():
    values = [1.0, 2.2, 2.9, 4.4, 5.1]
    sigmas = [0.1, 0.3, 0.2, 0.1, 0.4]
    observations = [
        _observation(tail, 98.0, value, sigma)
        for tail, value, sigma in zip(("S1", "S2", "S3", "S4", "S5"), values, sigmas, strict=True)
    ]
    trend = fit_quantity_trend(observations, "Mq", "linear-area")
    assert trend.weighting == "wls"
    held_out = leave_one_out_predictions(observations, "Mq", "linear-area")
    refit_residuals = [item.measured - item.prediction.value for item in held_out]
    # The PRESS identity r_i / (1 - h_ii) is exact for weighted least squares too.
    assert trend.loo_residuals == pytest.approx(refit_residuals, rel=1e-9)


def test_weights_scale_free_and_relative():
    """Multiplying every sigma by 10 changes nothing (sigmas are relative weights)."""
    tails = ("S1", "S2", "S3", "S4", "S5")
    values = [1.0, 2.2, 2.9, 4.4, 5.1]
    sigmas = [0.1, 0.3, 0.2, 0.1, 0.4]
    first = fit_quantity_trend(
        [_observation(t, 98, v, s) for t, v, s in zip(tails, values, sigmas, strict=True)],
        "Mq",
        "linear-area",
    )
    scaled = fit_quantity_trend(
        [_observation(t, 98, v, 10 * s) for t, v, s in zip(tails, values, sigmas, strict=True)],
        "Mq",
        "linear-area",
    )
    assert scaled.covariance == pytest.approx(first.covariance, rel=1e-9)
    assert scaled.residual_variance == pytest.approx(first.residual_variance, rel=1e-9)
    # ... but the weights matter: an unweighted fit gives another slope.
    unweighted = fit_quantity_trend(
        [_observation(t, 98, v) for t, v in zip(tails, values, strict=True)], "Mq", "linear-area"
    )
    assert abs(unweighted.coefficients[1] - first.coefficients[1]) > 1e-3 * abs(
        first.coefficients[1]
    )


COVERAGE_CONFIGURATIONS = [
    ("S1", 57),
    ("S3", 57),
    ("S6", 57),
    ("AR1", 98),
    ("AR4", 98),
    ("AR6", 98),
    ("S2", 126),
    ("S5", 126),
    ("AR2", 126),
    ("T1", 114),
]
TRUE_COEFFICIENTS = np.array([0.3, 20.0, 0.05, -1.5])  # [1, S_m2, AR, x_h_m] of "linear"
NEW_TAIL, NEW_X_H_MM = "S4", 98.0


@pytest.mark.parametrize("weighted", [False, True], ids=["ols", "wls"])
def test_both_intervals_cover_95_percent_over_many_seeds(weighted: bool):
    basis = BASES["linear"]
    rows = np.array(
        [
            basis.features_of_geometry(TAILS[tail].geometry, x / 1000)
            for tail, x in COVERAGE_CONFIGURATIONS
        ]
    )
    truth = rows @ TRUE_COEFFICIENTS
    relative = np.linspace(0.5, 2.0, len(rows)) if weighted else np.ones(len(rows))
    noise_scale = 0.02
    new_row = np.array(basis.features_of_geometry(TAILS[NEW_TAIL].geometry, NEW_X_H_MM / 1000))
    new_truth = float(new_row @ TRUE_COEFFICIENTS)
    # A new flight is as precise as the fitted flights on average: variance n / sum(1/sigma^2).
    new_sigma = noise_scale * math.sqrt(len(rows) / np.sum(1 / relative**2))
    seeds = 2000
    mean_hits = new_hits = 0
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        values = truth + noise_scale * relative * rng.standard_normal(len(rows))
        observations = [
            _observation(tail, x, value, sigma if weighted else None)
            for (tail, x), value, sigma in zip(
                COVERAGE_CONFIGURATIONS, values, relative, strict=True
            )
        ]
        prediction = fit_quantity_trend(observations, "Mq", basis).predict_features(new_row)
        low, high = prediction.interval_95_mean
        mean_hits += low <= new_truth <= high
        new_flight = new_truth + new_sigma * rng.standard_normal()
        low, high = prediction.interval_95_new
        new_hits += low <= new_flight <= high
    # Binomial standard deviation at p = 0.95, 2000 draws: 0.0049; allow 3 of them.
    assert mean_hits / seeds == pytest.approx(0.95, abs=0.015)
    assert new_hits / seeds == pytest.approx(0.95, abs=0.015)


def test_casadi_features_and_values_equal_numpy_at_random_points():
    observations = [
        _observation(tail, x, float(value))
        for (tail, x), value in zip(
            COVERAGE_CONFIGURATIONS,
            np.linspace(-1e-3, -3e-4, len(COVERAGE_CONFIGURATIONS)),
            strict=True,
        )
    ]
    rng = np.random.default_rng(7)
    symbols = casadi.SX.sym("g", 5)
    elements = [symbols[i] for i in range(5)]
    for basis in BASES.values():
        trend = fit_quantity_trend(observations, "Mq", basis)
        features = casadi.Function("f", [symbols], [casadi.vertcat(*basis.features(elements))])
        value = casadi.Function("v", [symbols], [trend.casadi_value(elements)])
        for _ in range(20):
            point = [
                rng.uniform(0.15, 0.26),
                rng.uniform(0.07, 0.15),
                rng.uniform(0.05, 0.08),
                rng.uniform(0.02, 0.045),
                rng.uniform(0.05, 0.13),
            ]
            expected = np.array(basis.features(point), dtype=float)
            assert np.asarray(features(point)).ravel() == pytest.approx(expected, rel=1e-12)
            assert float(value(point)) == pytest.approx(trend.predict(point).value, rel=1e-12)


def test_extrapolation_distance_and_flags():
    observations = [
        _observation(tail, x, 0.0 + i) for i, (tail, x) in enumerate(COVERAGE_CONFIGURATIONS)
    ]
    trend = fit_quantity_trend(observations, "Mq", "linear")
    features = np.array(
        [
            BASES["linear"].features_of_geometry(TAILS[t].geometry, x / 1000)
            for t, x in COVERAGE_CONFIGURATIONS
        ]
    )[:, 1:]
    centre = features.mean(axis=0)
    inverse = np.linalg.inv(np.cov(features, rowvar=False))
    expected = math.sqrt((features[0] - centre) @ inverse @ (features[0] - centre))
    at_first = trend.predict_geometry(TAILS["S1"].geometry, 0.057)
    assert at_first.extrapolation == pytest.approx(expected, rel=1e-9)
    assert not at_first.outside_fitted_range
    far = trend.predict([0.26, 0.08, 0.057, 0.022, 0.200])  # x_h = 200 mm, beyond the 126 mm data
    assert far.outside_fitted_range and "x_h_m" in far.extrapolation_note
    fitted_distances = [math.sqrt((row - centre) @ inverse @ (row - centre)) for row in features]
    assert far.extrapolation > max(fitted_distances)


def test_too_few_observations_name_quantity_and_sources():
    observations = [_observation("S1", 98, 1.0), _observation("S2", 98, 2.0)]
    with pytest.raises(UserInputError, match=r"trend of Mq: 2 observation\(s\) from user:test"):
        fit_trends(observations, "linear", quantities=["Mq"])
    xu_observations = [
        _observation(t, 98, float(i) ** 2, quantity="Xu") for i, t in enumerate(("S1", "S2", "S5"))
    ]
    model_without_request = fit_trends(observations + xu_observations, "linear-area")
    assert "Mq" in model_without_request.unfitted and "Xu" in model_without_request.trends


def test_collinear_features_are_refused():
    # x_h (mm) set equal to S (cm^2) for every observation: x_h_m = 10 S_m2 exactly, so the x_h
    # column is a multiple of the S column and the two cannot be separated.
    observations = [
        _observation(tail, TAILS[tail].geometry.area_m2 * 1e4, float(i))
        for i, tail in enumerate(("S1", "S2", "S3", "S5", "AR4", "AR6"))
    ]
    with pytest.raises(UserInputError, match="linearly dependent"):
        fit_quantity_trend(observations, "Mq", "linear")


def test_a_design_on_the_edge_of_the_fitted_range_is_inside_it():
    """The optimiser holds a design on a range bound only to solver tolerance: 1e-8 beyond the largest fitted x_h
    is still inside (no note), 1e-4 beyond is outside and says which feature."""
    observations = [
        _observation(tail, x, 0.0 + i) for i, (tail, x) in enumerate(COVERAGE_CONFIGURATIONS)
    ]
    trend = fit_quantity_trend(observations, "Mq", "linear")
    largest_x_h_m = max(x for _, x in COVERAGE_CONFIGURATIONS) / 1000
    on_edge = trend.predict_geometry(TAILS["S3"].geometry, largest_x_h_m * (1 + 1e-8))
    assert (
        not on_edge.outside_fitted_range and on_edge.extrapolation_note == "inside the fitted range"
    )
    beyond = trend.predict_geometry(TAILS["S3"].geometry, largest_x_h_m * (1 + 1e-4))
    assert beyond.outside_fitted_range and "x_h_m" in beyond.extrapolation_note
