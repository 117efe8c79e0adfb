"""Averaged-model mathematics of flight/averaged_models.py on synthetic parameter sets."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ornitail.core.errors import UserInputError
from ornitail.flight.averaged_models import (
    SAMPLE_RATE_TOLERANCE,
    covariance_weighted_mean,
    mean_of_parameters,
    time_averaged_response,
)
from ornitail.flight.manoeuvres import Manoeuvre, SteadyState


def _random_covariance(generator: np.random.Generator, size: int) -> np.ndarray:
    factor = generator.normal(size=(size, size))
    return factor @ factor.T + 0.5 * np.eye(size)


def test_weighted_mean_equals_the_hand_formula_for_independent_parameters():
    values = np.array([[1.0, -2.0], [3.0, -1.0], [2.0, 0.5]])
    sigmas = np.array([[0.5, 1.0], [1.0, 2.0], [2.0, 0.5]])
    merged = covariance_weighted_mean(values, [np.diag(s**2) for s in sigmas])
    weights = 1 / sigmas**2
    expected = np.sum(weights * values, axis=0) / np.sum(weights, axis=0)
    np.testing.assert_allclose(merged.values, expected, rtol=1e-12)
    np.testing.assert_allclose(merged.sigmas, 1 / np.sqrt(np.sum(weights, axis=0)), rtol=1e-12)


def test_weighted_mean_with_full_covariances_matches_the_information_form():
    generator = np.random.default_rng(4)
    covariances = [_random_covariance(generator, 3) for _ in range(4)]
    values = generator.normal(size=(4, 3))
    merged = covariance_weighted_mean(values, covariances)
    information = sum(np.linalg.inv(c) for c in covariances)
    expected = np.linalg.solve(
        information, sum(np.linalg.solve(c, v) for c, v in zip(covariances, values, strict=True))
    )
    np.testing.assert_allclose(merged.values, expected, rtol=1e-10)
    np.testing.assert_allclose(merged.covariance, np.linalg.inv(information), rtol=1e-10)
    assert merged.degrees_of_freedom == 9


def test_two_model_chi_square_is_matlab_merge_test():
    generator = np.random.default_rng(7)
    first, second = _random_covariance(generator, 3), _random_covariance(generator, 3)
    values = generator.normal(size=(2, 3))
    merged = covariance_weighted_mean(values, [first, second])
    difference = values[0] - values[1]
    expected = difference @ np.linalg.solve(first + second, difference)
    assert merged.chi_square == pytest.approx(expected, rel=1e-10)
    assert merged.degrees_of_freedom == 3


def test_chi_square_test_holds_its_size_and_detects_a_shifted_model():
    generator = np.random.default_rng(11)
    truth = np.array([1.0, -0.5, 2.0])
    covariances = [_random_covariance(generator, 3) * 0.01 for _ in range(5)]
    factors = [np.linalg.cholesky(c) for c in covariances]
    trials = 2000
    false_alarms = 0
    for _ in range(trials):
        values = np.array([truth + f @ generator.normal(size=3) for f in factors])
        false_alarms += not covariance_weighted_mean(values, covariances).merge_justified
    # binomial: 5 % +- 3 sigma, sigma = sqrt(0.05 * 0.95 / 2000) = 0.49 %
    assert abs(false_alarms / trials - 0.05) < 3 * np.sqrt(0.05 * 0.95 / trials)
    shifted = np.array([truth + f @ generator.normal(size=3) for f in factors])
    shifted[2] += 10 * np.sqrt(np.diag(covariances[2]))  # one manoeuvre 10 sigma away
    assert not covariance_weighted_mean(shifted, covariances).merge_justified


def test_mean_of_parameters_and_its_covariance():
    values = np.array([[1.0, 10.0], [2.0, 14.0], [6.0, 12.0]])
    mean = mean_of_parameters(values)
    np.testing.assert_allclose(mean.values, [3.0, 12.0])
    np.testing.assert_allclose(mean.covariance, np.cov(values.T) / 3)


def test_merging_refuses_a_single_model_and_a_singular_covariance():
    with pytest.raises(UserInputError, match="at least 2"):
        covariance_weighted_mean(np.ones((1, 2)), [np.eye(2)])
    with pytest.raises(UserInputError, match="singular"):
        covariance_weighted_mean(np.ones((2, 2)), [np.eye(2), np.zeros((2, 2))])


def _manoeuvre(
    run_in_samples: int, after_samples: int, level: float, rate: float = 100.0, time_s=None
) -> Manoeuvre:
    count = run_in_samples + after_samples
    signal = np.where(np.arange(count) >= run_in_samples, level, 0.0) + np.arange(count) * 1e-3
    time_s = np.arange(count) / rate if time_s is None else time_s
    frame = pd.DataFrame({"time_s": time_s, "q_rad_s": signal})
    return Manoeuvre(
        "synthetic",
        1,
        0.0,
        count / rate,
        run_in_samples / rate,
        SteadyState(0.4, -0.6, -0.2, 0.63, 13.5),
        frame,
    )


def test_time_averaged_response_aligns_on_the_input_and_keeps_the_common_span():
    first, second = _manoeuvre(50, 300, 1.0), _manoeuvre(70, 250, 3.0)
    averaged = time_averaged_response([first, second])
    assert len(averaged) == 50 + 250  # shortest run-in plus shortest response
    # after alignment the steps coincide: sample 50 is the input in both
    np.testing.assert_allclose(averaged["q_rad_s"].iloc[49], (0.049 + 0.069) / 2, rtol=1e-12)
    np.testing.assert_allclose(averaged["q_rad_s"].iloc[50], 2.0 + (0.050 + 0.070) / 2, rtol=1e-12)
    np.testing.assert_allclose(np.diff(averaged["time_s"]), 0.01)


def test_time_averaging_accepts_rounded_and_jittered_time_and_clocks_within_the_tolerance():
    """Timestamps written with 7 decimals, a clock with jitter, and a second logger's clock 50 ppm fast (two
    crystals): one sample rate within SAMPLE_RATE_TOLERANCE (1e-4), so they are averaged."""
    count = 2048
    rounded = np.round(np.arange(count) / 512.0 + 12.3456789, 7) - 12.3456789
    jitter = np.random.default_rng(3).normal(0.0, 0.02 / 512.0, count)
    jittered = np.round(np.arange(count) / (512.0 * (1 + 5e-5)) + jitter, 7)
    first = _manoeuvre(256, count - 256, 1.0, time_s=rounded)
    second = _manoeuvre(256, count - 256, 3.0, time_s=jittered)
    assert np.ptp(np.diff(rounded)) / (1 / 512.0) > 1e-6  # the median-step check refused these
    averaged = time_averaged_response([first, second])
    assert len(averaged) == count
    np.testing.assert_allclose(np.diff(averaged["time_s"]), 1 / 512.0, rtol=SAMPLE_RATE_TOLERANCE)
    np.testing.assert_allclose(averaged["q_rad_s"].iloc[256], 2.0 + 0.256, rtol=1e-12)


def test_time_averaging_refuses_logs_at_different_sample_rates_naming_them():
    first, second = _manoeuvre(50, 300, 1.0, rate=100.0), _manoeuvre(50, 300, 1.0, rate=101.0)
    with pytest.raises(UserInputError, match=r"one sample rate.*100 Hz.*101 Hz.*0.0001 apart"):
        time_averaged_response([first, second])
