"""Bracketing tares: the interpolated zero, its error, and the covariance of points that share tares."""

import numpy as np
import pytest

from ornitail.balance.derivatives import weighted_tare_covariance
from ornitail.balance.tare_drift import (
    DRIFT_MODEL_CONSTANT,
    DRIFT_MODEL_LINEAR,
    RecordedTare,
    RunningClock,
    drift_statement,
    tare_correction,
)

BEFORE = RecordedTare("run#0", "run", 1_000.0, np.full(6, 0.010), np.full(6, 3e-5))
AFTER = RecordedTare("run#9", "run", 11_000.0, np.full(6, 0.030), np.full(6, 4e-5))
EARLIER = RecordedTare("run#1", "run", 500.0, AFTER.volts, AFTER.volts_standard_error)


def test_a_point_between_two_tares_gets_the_zero_interpolated_in_time():
    correction = tare_correction(BEFORE, AFTER, 3_500.0, "run")  # a quarter of the way
    assert correction.after_weight == pytest.approx(0.25)
    np.testing.assert_allclose(correction.volts, 0.75 * 0.010 + 0.25 * 0.030)
    np.testing.assert_allclose(correction.volts_standard_error, np.hypot(0.75 * 3e-5, 0.25 * 4e-5))
    assert correction.drift_model == DRIFT_MODEL_LINEAR


@pytest.mark.parametrize(
    ("after", "run_id"),
    [(None, "run"), (AFTER, "another run"), (EARLIER, "run")],
    ids=["no tare after", "point in another run", "tare after not later"],
)
def test_without_a_later_tare_in_the_same_run_the_last_tare_is_used_as_it_is(after, run_id):
    correction = tare_correction(BEFORE, after, 3_500.0, run_id)
    assert correction.after is None and correction.after_weight == 0.0
    np.testing.assert_allclose(correction.volts, BEFORE.volts)
    assert correction.drift_model == DRIFT_MODEL_CONSTANT


def test_weights_stay_between_the_tares():
    assert tare_correction(BEFORE, AFTER, 20_000.0, "run").after_weight == 1.0
    assert tare_correction(BEFORE, AFTER, 0.0, "run").after_weight == 0.0


def test_shared_tares_covariance_equals_the_sampled_covariance_of_interpolated_zeros():
    """Three points between tares A and B (weights 0.2, 0.5, 0.9) and one with tare C alone: the formula against
    the covariance of 200 000 draws of independent tare errors (relative error of a sampled covariance
    ~ sqrt(2 / n) = 0.3 %, so 2 % of the largest entry is ~7 standard errors)."""
    tare_se = {"A": 2.0, "B": 3.0, "C": 1.5, "": 0.0}
    before_ids = np.array(["A", "A", "A", "C"])
    after_ids = np.array(["B", "B", "B", ""])
    weights = np.array([0.2, 0.5, 0.9, 0.0])
    point_se = np.array([0.5, 0.6, 0.7, 0.8])
    before_se = np.array([tare_se[name] for name in before_ids])
    after_se = np.array([tare_se[name] for name in after_ids])
    formula = weighted_tare_covariance(
        point_se, [(before_ids, (1 - weights) * before_se), (after_ids, weights * after_se)]
    )
    generator = np.random.default_rng(5)
    draws = 200_000
    tare_errors = {name: generator.normal(0.0, se, draws) for name, se in tare_se.items()}
    zeros = np.array(
        [
            (1 - w) * tare_errors[b] + w * tare_errors[a] + generator.normal(0.0, se, draws)
            for b, a, w, se in zip(before_ids, after_ids, weights, point_se, strict=True)
        ]
    )
    sampled = np.cov(zeros)
    assert np.abs(formula - sampled).max() <= 0.02 * np.abs(formula).max()
    assert formula[0, 3] == 0.0  # no tare in common


def test_the_running_clock_counts_only_from_a_tare_to_the_last_point_before_the_next():
    """Records (is tare, first, last sample): tare 0-99, points 300-399 and 600-699, tare 900-999, point 1300-1399,
    tare 1500-1599. The motor runs 99..699 (600 samples) and 999..1399 (400); it stands from the end of the last
    point before a tare through the tare's record."""
    clock = RunningClock(
        [
            (True, 0, 99),
            (False, 300, 399),
            (False, 600, 699),
            (True, 900, 999),
            (False, 1300, 1399),
            (True, 1500, 1599),
        ]
    )
    assert clock.intervals == [(99.0, 699.0), (999.0, 1399.0)]
    assert clock.at(49.5) == 0.0  # the first tare's middle
    assert clock.at(349.5) == pytest.approx(250.5)
    assert clock.at(949.5) == clock.at(800.0) == 600.0  # standing: wind-off and the tare's record
    assert clock.at(1549.5) == 1000.0
    # A point halfway through the running between two tares gets weight one half, wherever the standing time is.
    first = RecordedTare("r#0", "r", clock.at(49.5), np.zeros(6), np.ones(6))
    second = RecordedTare("r#3", "r", clock.at(949.5), np.ones(6), np.ones(6))
    assert tare_correction(first, second, clock.at(399.0), "r").after_weight == pytest.approx(0.5)


def test_the_drift_statement_says_whether_every_point_was_corrected():
    assert drift_statement([DRIFT_MODEL_LINEAR] * 3) == (
        f"Balance drift: the zero of all 3 points interpolated {DRIFT_MODEL_LINEAR}."
    )
    partly = drift_statement([DRIFT_MODEL_LINEAR, DRIFT_MODEL_CONSTANT, DRIFT_MODEL_CONSTANT])
    assert partly.startswith("Balance drift NOT corrected for 2 of 3 points")
