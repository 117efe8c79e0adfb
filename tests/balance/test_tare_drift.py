"""Bracketing tares: the interpolated zero, its error, and the covariance of points that share tares."""

import numpy as np
import pytest

from ornitail.acquisition.counter_gaps import CounterGap
from ornitail.acquisition.motor_running_log import MOTOR_TRANSITIONS_KEY
from ornitail.acquisition.recording_layout import SetPointRecord
from ornitail.balance.point_covariance import weighted_tare_covariance
from ornitail.balance.sweep_table import third_tare
from ornitail.balance.tare_drift import (
    DRIFT_MODEL_CONSTANT,
    DRIFT_MODEL_LINEAR,
    DRIFT_MODEL_QUADRATIC,
    RecordedTare,
    RunningClock,
    SampleClockPositions,
    drift_check,
    drift_statement,
    running_clock_of,
    tare_correction,
)

BEFORE = RecordedTare("run#0", "run", 1_000.0, np.full(6, 0.010), np.diag(np.full(6, 3e-5**2)))
AFTER = RecordedTare("run#9", "run", 11_000.0, np.full(6, 0.030), np.diag(np.full(6, 4e-5**2)))
EARLIER = RecordedTare("run#1", "run", 500.0, AFTER.volts, AFTER.volts_covariance)


def test_a_point_between_two_tares_gets_the_zero_interpolated_in_time():
    correction = tare_correction(BEFORE, AFTER, 3_500.0, "run")  # a quarter of the way
    assert correction.after_weight == pytest.approx(0.25)
    np.testing.assert_allclose(correction.volts, 0.75 * 0.010 + 0.25 * 0.030)
    np.testing.assert_allclose(
        np.sqrt(np.diag(correction.volts_covariance)), np.hypot(0.75 * 3e-5, 0.25 * 4e-5)
    )
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


def test_samples_lost_between_rows_still_count_as_running_time():
    """The motor runs from row 100 to row 1100 of a recording whose link lost 3000 samples before row 400 and 500
    before row 2000 (after the stop): on the sample counter it ran 4000 samples, not the 1000 rows between; a
    tare at row 1500 sits at 4000, one at row 2500 too (the loss after the stop is standing time)."""
    gaps = [
        CounterGap(400, 10_399, 13_400, 3000, "jump"),
        CounterGap(2000, 14_999, 15_500, 500, "jump"),
    ]
    positions = SampleClockPositions(gaps)
    assert positions(399) == 399.0 and positions(400) == 3400.0 and positions(2500) == 6000.0
    clock = RunningClock.from_motor_transitions(
        [("started", 100), ("stopped", 1100)], 2999, positions
    )
    assert clock.intervals == [(100.0, 4100.0)]
    assert clock.at(1500) == clock.at(2500) == 4000.0
    assert clock.at(399) == 299.0  # before the gap, rows are samples
    # A stop the link lost carries the samples lost from it to the row it was journalled on.
    lost_stop = RunningClock.from_motor_transitions(
        [("started", 100), ("stopped", 400, 1000)], 2999, positions
    )
    assert lost_stop.intervals == [(100.0, 2400.0)]
    # Without the gaps the clock would stop for the lost samples: the tare 3000 samples early.
    assert (
        RunningClock.from_motor_transitions([("started", 100), ("stopped", 1100)], 2999).at(1500)
        == 1000.0
    )


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
    first = RecordedTare("r#0", "r", clock.at(49.5), np.zeros(6), np.eye(6))
    second = RecordedTare("r#3", "r", clock.at(949.5), np.ones(6), np.eye(6))
    assert tare_correction(first, second, clock.at(399.0), "r").after_weight == pytest.approx(0.5)


def test_the_drift_statement_says_whether_every_point_was_corrected():
    assert drift_statement([DRIFT_MODEL_LINEAR] * 3) == (
        f"Balance drift: the zero of all 3 points interpolated {DRIFT_MODEL_LINEAR}."
    )
    partly = drift_statement([DRIFT_MODEL_LINEAR, DRIFT_MODEL_CONSTANT, DRIFT_MODEL_CONSTANT])
    assert partly.startswith("Balance drift NOT corrected for 2 of 3 points")


def _tares_on(drift, times, noise_v=1e-5, seed=0):
    """Tares at ``times`` (running samples) whose gauge zeros follow ``drift(t)`` (V) plus white noise."""
    generator = np.random.default_rng(seed)
    covariance = np.diag(np.full(6, noise_v**2))
    return [
        RecordedTare(f"r#{index}", "r", t, drift(t) + generator.normal(0, noise_v, 6), covariance)
        for index, t in enumerate(times)
    ]


TIMES = (0.0, 100_000.0, 200_000.0, 300_000.0)
GAUGE_RATES = np.array([1.0, -2.0, 0.5, 3.0, -1.0, 2.0])


def test_straight_drift_passes_the_check_and_a_bend_is_caught_and_followed():
    """Zeros straight in time pass (chi-square near its 12 degrees of freedom); zeros on a parabola 30 noise
    steps deep fail it, and the zero through three tares lands on the parabola where the straight line misses."""
    straight = _tares_on(lambda t: 1e-8 * t * GAUGE_RATES, TIMES)
    check = drift_check("r", [straight])
    assert check.degrees_of_freedom == 12 and not check.straight_drift_rejected
    assert "consistent with straight drift" in check.statement()

    def bent(t):
        return (
            3e-4 * (t / 100_000.0) * (3.0 - t / 100_000.0) * GAUGE_RATES
        )  # 30x the noise at its peak

    tares = _tares_on(bent, TIMES)
    check = drift_check("r", [tares])
    assert check.straight_drift_rejected and check.p_value < 1e-10
    assert "the drift bends between tares" in check.statement()
    point_time = 150_000.0  # between the second and third tare
    before, after = tares[1], tares[2]
    third = third_tare(tares, before, after)
    assert third is tares[3]  # the next after the bracketing pair
    quadratic = tare_correction(before, after, point_time, "r", third)
    straight_line = tare_correction(before, after, point_time, "r")
    assert quadratic.drift_model == DRIFT_MODEL_QUADRATIC
    assert (
        quadratic.before_weight + quadratic.after_weight + quadratic.third_weight
        == pytest.approx(1)
    )
    truth = bent(point_time)
    # The parabola is exact up to the tares' noise (weights 0.375, 0.75, -0.125: 0.85 of one tare's noise);
    # the straight line misses by the bend, 3e-4 * 0.25 per unit rate.
    assert np.abs(quadratic.volts - truth).max() < 5 * 0.85e-5 * np.abs(GAUGE_RATES).max()
    assert np.abs(straight_line.volts - truth).max() > 5e-5
    np.testing.assert_allclose(
        np.diag(quadratic.volts_covariance), (0.375**2 + 0.75**2 + 0.125**2) * 1e-10
    )
    # At the end of the series the third tare is the one before the pair; with only two there is none.
    assert third_tare(tares, tares[2], tares[3]) is tares[1]
    assert third_tare(tares[:2], tares[0], tares[1]) is None


def test_fewer_than_three_tares_at_a_pitch_leave_straight_drift_untested():
    check = drift_check("r", [_tares_on(lambda t: 0 * GAUGE_RATES, TIMES[:2])])
    assert check.p_value == 1.0 and not check.straight_drift_rejected
    assert "straight drift not tested" in check.statement()


def test_the_running_clock_follows_the_motors_journalled_starts_and_stops():
    """The motor read running from sample 150 and standing again from 950 (it spun down into the next tare's
    settling); started again at 1050 and still running at the run's last sample, 1599."""
    records = [
        SetPointRecord(0, "tare", 0, 99, 0.4, 0.0, 0.0, False, extra={MOTOR_TRANSITIONS_KEY: []}),
        SetPointRecord(
            1,
            "measurement",
            300,
            399,
            0.4,
            0.8,
            13.5,
            False,
            extra={MOTOR_TRANSITIONS_KEY: [["started", 150]]},
        ),
        SetPointRecord(
            2,
            "tare",
            1000,
            1099,
            0.4,
            0.0,
            0.0,
            False,
            extra={MOTOR_TRANSITIONS_KEY: [["stopped", 950]]},
        ),
        SetPointRecord(
            3,
            "measurement",
            1500,
            1599,
            0.4,
            0.8,
            13.5,
            False,
            extra={MOTOR_TRANSITIONS_KEY: [["started", 1050]]},
        ),
    ]
    assert running_clock_of(records).intervals == [(150.0, 950.0), (1050.0, 1599.0)]
    # A journal without the transitions (recorded before the sweep read them) falls back to the records.
    for record in records:
        record.extra.clear()
    assert running_clock_of(records).intervals == [(99.0, 399.0), (1099.0, 1599.0)]
