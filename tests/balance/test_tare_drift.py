"""The running clock the drift runs on, the zero without a later tare, the drift statement and the covariance of
points that share tares (the run's drift fit itself: test_run_drift_fit.py)."""

import numpy as np
import pandas as pd
import pytest

from ornitail.acquisition.counter_gaps import CounterGap
from ornitail.acquisition.motor_running_log import MOTOR_TRANSITIONS_KEY
from ornitail.acquisition.recording_layout import SetPointRecord
from ornitail.balance.point_covariance import point_covariance
from ornitail.balance.run_drift_fit import drift_model_name, fit_run_drift, zero_correction
from ornitail.balance.tare_drift import (
    DRIFT_MODEL_CONSTANT,
    RecordedTare,
    RunningClock,
    SampleClockPositions,
    drift_statement,
    running_clock_of,
)

BEFORE = RecordedTare("run#0", "run", 1_000.0, np.full(6, 0.010), np.diag(np.full(6, 3e-5**2)))
AFTER = RecordedTare("run#9", "run", 11_000.0, np.full(6, 0.030), np.diag(np.full(6, 4e-5**2)))
EARLIER = RecordedTare("run#1", "run", 500.0, AFTER.volts, AFTER.volts_covariance)


@pytest.mark.parametrize(
    ("keyed_tares", "running_time"),
    [
        ([("a", BEFORE)], 3_500.0),
        ([("a", BEFORE), ("a", AFTER)], 12_000.0),
        ([("b", EARLIER), ("a", BEFORE)], 3_500.0),
    ],
    ids=["no tare after", "point after the run's last tare", "two pitches with one tare each"],
)
def test_without_a_drift_measured_past_the_point_the_tare_before_is_used_as_it_is(
    keyed_tares, running_time
):
    correction = zero_correction(fit_run_drift("run", keyed_tares), "a", running_time, BEFORE)
    assert correction.terms == ((BEFORE, 1.0),)
    np.testing.assert_allclose(correction.volts, BEFORE.volts)
    assert correction.drift_model == DRIFT_MODEL_CONSTANT


def test_shared_tares_covariance_equals_the_sampled_covariance_of_interpolated_zeros():
    """Three points between tares A and B (weights 0.2, 0.5, 0.9), one whose zero also takes C with a negative
    weight, and one with tare C alone, as a processed table writes them: the covariance against that of 200 000
    draws of independent tare errors (relative error of a sampled covariance ~ sqrt(2 / n) = 0.3 %, so 2 % of the
    largest entry is ~7 standard errors)."""
    tare_se = {"A": 2.0, "B": 3.0, "C": 1.5}
    zeros = [
        {"A": 0.8, "B": 0.2},
        {"A": 0.5, "B": 0.5},
        {"A": 0.1, "B": 0.9},
        {"A": 0.4, "B": 0.9, "C": -0.3},
        {"C": 1.0},
    ]
    point_se = np.array([0.5, 0.6, 0.7, 0.4, 0.8])
    table = pd.DataFrame(
        {
            "x_n_se": point_se,
            "tare_terms": [";".join(f"r#{k}={w}" for k, w in zero.items()) for zero in zeros],
            "x_n_tare_terms_se": [";".join(str(tare_se[k]) for k in zero) for zero in zeros],
        }
    )
    formula = point_covariance(table, "x_n")
    generator = np.random.default_rng(5)
    draws = 200_000
    tare_errors = {name: generator.normal(0.0, se, draws) for name, se in tare_se.items()}
    sampled_zeros = np.array(
        [
            sum(w * tare_errors[k] for k, w in zero.items()) + generator.normal(0.0, se, draws)
            for zero, se in zip(zeros, point_se, strict=True)
        ]
    )
    sampled = np.cov(sampled_zeros)
    assert np.abs(formula - sampled).max() <= 0.02 * np.abs(formula).max()
    assert formula[0, 4] == 0.0  # no tare in common


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
    fit = fit_run_drift("r", [("a", first), ("a", second)])
    weights = [weight for _, weight in fit.correction("a", clock.at(399.0), first).terms]
    assert weights == pytest.approx([0.5, 0.5])


def test_the_drift_statement_says_whether_every_point_was_corrected():
    straight = drift_model_name(1)
    assert drift_statement([straight] * 3).startswith(
        "Balance drift: the zero of all 3 points from their run's drift fit"
    )
    partly = drift_statement([straight, DRIFT_MODEL_CONSTANT, DRIFT_MODEL_CONSTANT])
    assert partly.startswith("Balance drift NOT corrected for 2 of 3 points")


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
