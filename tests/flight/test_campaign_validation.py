"""Validation errors, rejection flags, the 70/30 split and the choice of the representative model
(flight/validation.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ornitail.core.errors import UserInputError
from ornitail.flight.validation import (
    ValidationScores,
    normalised_rms,
    rejection_flags,
    response_errors,
    select_representative,
    split_training_validation,
)


def test_response_errors_match_numpy():
    generator = np.random.default_rng(2)
    measured = generator.normal(size=(400, 4))
    simulated = measured + 0.3 * generator.normal(size=(400, 4))
    errors = response_errors(measured, simulated)
    for column in range(4):
        difference = measured[:, column] - simulated[:, column]
        assert errors.rms[column] == pytest.approx(np.sqrt(np.mean(difference**2)), rel=1e-12)
        expected = np.corrcoef(measured[:, column], simulated[:, column])[0, 1]
        assert errors.pcc[column] == pytest.approx(expected, rel=1e-12)


def _constructed_models() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ten models, four states, eight parameters; rows 0-7 are good unless changed below."""
    rms = np.tile(np.linspace(1.0, 2.0, 10)[:, None], (1, 4))
    pcc = np.full((10, 4), 0.9)
    relative_sigma = np.full((10, 8), 0.2)
    rms[9] = 10.0  # worst in every state: RMS flag 4/4
    pcc[9] = 0.6  # PCC flag 1 -> total 2, rejected
    rms[3, 0] = 20.0  # top 20 % in one state: 1/4 ...
    pcc[3] = [0.5, 0.6, 0.7, 0.8]  # ... mean 0.65 <= 0.7: total 1.25, rejected
    rms[5, 1:] = 20.0  # three states in the top 20 %: 3/4 ...
    relative_sigma[5, :2] = 1.5  # ... two of eight parameters: 2/8 -> total exactly 1, kept
    pcc[6] = 0.70  # mean PCC exactly 0.70: flag 1, total 1, kept
    relative_sigma[7, :] = np.inf  # zero estimates everywhere: sigma flag 1, kept alone
    return rms, pcc, relative_sigma


def test_rejection_flags_on_constructed_models():
    flags = rejection_flags(*_constructed_models())
    np.testing.assert_allclose(flags.rms[[9, 3, 5, 0]], [1.0, 0.25, 0.75, 0.0])
    np.testing.assert_allclose(flags.pcc[[9, 3, 6, 5]], [1.0, 1.0, 1.0, 0.0])
    np.testing.assert_allclose(flags.sigma[[5, 7, 0]], [0.25, 1.0, 0.0])
    np.testing.assert_allclose(flags.total[[9, 3, 5, 6, 7]], [2.0, 1.25, 1.0, 1.0, 1.0])
    assert np.flatnonzero(flags.rejected).tolist() == [3, 9]


def test_nan_sigma_counts_as_undetermined():
    rms, pcc, relative_sigma = _constructed_models()
    relative_sigma[0, :4] = np.nan
    pcc[0] = 0.6
    flags = rejection_flags(rms, pcc, relative_sigma)
    assert flags.sigma[0] == pytest.approx(0.5) and flags.rejected[0]


@pytest.mark.parametrize("count", [2, 7, 12, 21])
def test_split_is_reproducible_disjoint_and_seventy_thirty(count):
    training, validation = split_training_validation(count, seed=5)
    again_training, again_validation = split_training_validation(count, seed=5)
    assert training.tolist() == again_training.tolist()
    assert validation.tolist() == again_validation.tolist()
    assert sorted(training.tolist() + validation.tolist()) == list(range(count))
    assert len(training) == min(max(round(0.7 * count), 1), count - 1)


def test_split_depends_on_the_seed():
    splits = {tuple(split_training_validation(21, seed)[0]) for seed in range(10)}
    assert len(splits) > 5


def test_split_refuses_a_single_manoeuvre():
    with pytest.raises(UserInputError, match="need at least 2"):
        split_training_validation(1, seed=0)


def test_normalised_rms_is_scale_free():
    generator = np.random.default_rng(8)
    measured = generator.normal(size=(300, 2))
    simulated = 0.8 * measured
    # error = 0.2 * measured, so RMS / std = 0.2 * rms(measured) / std(measured)
    expected = np.mean(0.2 * np.sqrt(np.mean(measured**2, axis=0)) / np.std(measured, axis=0))
    assert normalised_rms(measured, simulated) == pytest.approx(expected, rel=1e-12)
    assert normalised_rms(measured * [1, 1e3], simulated * [1, 1e3]) == pytest.approx(expected)


def test_an_rms_exactly_at_the_80th_percentile_is_flagged():
    # six models: numpy's (linear) 80th percentile of 1..6 is at position 0.8 * 5 = 4, exactly
    # the fifth value; the study's "top 20 %" flags it (RMS >= percentile), the old rule did not
    rms = np.tile(np.arange(1.0, 7.0)[:, None], (1, 4))
    flags = rejection_flags(rms, np.full((6, 4), 0.9), np.full((6, 8), 0.2))
    assert np.quantile(rms[:, 0], 0.8) == 5.0
    np.testing.assert_array_equal(flags.rms, [0, 0, 0, 0, 1, 1])


NAMES = ("mean", "weighted", "time_averaged")


def _scores(rms: list[list[float]], pcc: list[list[float]]) -> ValidationScores:
    return ValidationScores(NAMES, np.array(rms), np.array(pcc))


def test_most_wins_and_lowest_mean_rms_can_disagree():
    # four validation manoeuvres. "weighted" is best on three by RMS and PCC (6 wins) but fails
    # badly on the fourth, so its mean RMS (0.50) is above "time_averaged"'s (0.35)
    scores = _scores(
        rms=[[0.40, 0.40, 0.40, 0.60], [0.20, 0.20, 0.20, 1.40], [0.30, 0.30, 0.30, 0.50]],
        pcc=[[0.80, 0.80, 0.80, 0.80], [0.95, 0.95, 0.95, 0.10], [0.90, 0.90, 0.90, 0.85]],
    )
    assert scores.wins() == {
        "mean": {"rms": 0, "pcc": 0},
        "weighted": {"rms": 3, "pcc": 3},
        "time_averaged": {"rms": 1, "pcc": 1},
    }
    mean_rms = {"mean": 0.45, "weighted": 0.50, "time_averaged": 0.35}
    assert scores.mean_rms() == pytest.approx(mean_rms, rel=1e-12)  # sums of 4 decimals
    assert select_representative(scores) == "weighted"
    assert select_representative(scores, "most_wins") == "weighted"
    assert select_representative(scores, "lowest_mean_rms") == "time_averaged"


def test_rms_and_pcc_wins_are_counted_separately_and_ties_go_to_the_lower_mean_rms():
    # "mean" wins both manoeuvres by RMS, "time_averaged" both by PCC: 2 points each; the tie
    # goes to the lower mean RMS ("mean", 0.25 against 0.35)
    scores = _scores(
        rms=[[0.2, 0.3], [0.5, 0.5], [0.3, 0.4]],
        pcc=[[0.8, 0.8], [0.7, 0.7], [0.9, 0.9]],
    )
    assert scores.wins()["mean"] == {"rms": 2, "pcc": 0}
    assert scores.wins()["time_averaged"] == {"rms": 0, "pcc": 2}
    assert select_representative(scores) == "mean"
    # equal points and equal mean RMS: the candidates' order decides (mean before weighted)
    level = _scores(rms=[[0.2, 0.4], [0.4, 0.2], [0.5, 0.5]], pcc=[[0.5, 0.9], [0.9, 0.5], [0, 0]])
    assert select_representative(level) == "mean"


def test_exact_ties_for_best_each_win_and_unsimulable_models_take_no_part():
    scores = _scores(
        rms=[[0.2, 0.2], [0.2, math.inf], [0.3, 0.3]],
        pcc=[[0.9, 0.9], [0.9, math.nan], [0.8, 0.8]],
    )
    assert scores.eligible().tolist() == [True, False, True]
    assert scores.wins()["mean"] == {"rms": 2, "pcc": 2}
    assert scores.wins()["weighted"] == {"rms": 0, "pcc": 0}
    tie = _scores(rms=[[0.2], [0.2], [0.3]], pcc=[[0.9], [0.9], [0.8]])
    assert tie.wins()["mean"] == tie.wins()["weighted"] == {"rms": 1, "pcc": 1}
    nothing = _scores(rms=[[math.nan]] * 3, pcc=[[0.5]] * 3)
    with pytest.raises(UserInputError, match="S3@98: no averaged model could be simulated"):
        select_representative(nothing, where="S3@98")
    with pytest.raises(UserInputError, match="'best_pcc' is not one of"):
        select_representative(scores, "best_pcc")
