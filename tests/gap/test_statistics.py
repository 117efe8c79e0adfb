"""The diagnosis' statistical pieces on synthetic numbers: ranking, intervals, sparse regression,
magnitude fit, the flight noise level."""

import numpy as np
import pytest

from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_localisation import unlocked_residual_sd
from ornitail.gap.intervals import gap_with_interval
from ornitail.gap.magnitude_fit import fit_magnitude
from ornitail.gap.ranking import CandidateEvidence, rank_candidates
from ornitail.gap.sparse_regression import sparse_terms


def _evidence(name: str, sse: np.ndarray, correlation: float = 0.0) -> CandidateEvidence:
    return CandidateEvidence(name, 1.0, "-", 1, sse, float(sse.sum()), correlation)


def test_identical_families_form_one_set_and_a_clear_winner_stands_alone():
    generator = np.random.default_rng(1)
    base = generator.uniform(9.0, 11.0, 12)
    effect = base * 0.25  # closes 1 - sqrt(0.25) = 50 %
    other = base * 0.81  # closes 10 %
    evidence = [_evidence("a", effect), _evidence("b", effect.copy()), _evidence("c", other)]
    ranking = rank_candidates(evidence, base, float(base.sum()), 0.0, 1000, seed=0)
    assert set(ranking.top_set) == {"a", "b"}
    assert ranking.detected
    assert ranking.entries[0].heldout_closure == pytest.approx(0.5, abs=1e-12)
    assert ranking.entries[-1].name == "c" and not ranking.entries[-1].in_top_set
    assert ranking.top_set_confidence == pytest.approx(1.0)


def test_a_small_closure_is_not_detected():
    base = np.full(10, 10.0)
    evidence = [_evidence("a", base * 0.9**2)]  # closes exactly 10 %, below the 15 % floor
    ranking = rank_candidates(evidence, base, 100.0, 0.0, 1000, seed=0)
    assert not ranking.detected


def test_ties_are_ordered_by_the_drop_of_input_correlation():
    base = np.full(8, 4.0)
    evidence = [_evidence("a", base * 0.5, correlation=0.3), _evidence("b", base * 0.5, 0.1)]
    ranking = rank_candidates(evidence, base, 32.0, 0.4, 1000, seed=0)
    assert [entry.name for entry in ranking.entries] == ["b", "a"]
    assert ranking.entries[0].input_correlation_drop == pytest.approx(0.3)


def test_gap_interval_covers_the_true_gap_about_ninety_percent_of_the_time():
    # 20 runs of 50 white samples of unit variance: the true gap is 1. Over 200 seeds the 5-95 %
    # bootstrap interval should cover it in ~90 % of cases; binomial sd 2.1 %, and the percentile
    # bootstrap with 20 resampled runs under-covers by a few percent, hence [0.80, 0.96].
    covered = 0
    for seed in range(200):
        generator = np.random.default_rng(seed)
        sse = np.array([[np.sum(generator.standard_normal(50) ** 2)] for _ in range(20)])
        gap = gap_with_interval(sse, np.full(20, 50.0), ("x",), seed=seed)
        low, high = gap["per_channel"]["x"]["interval"]
        covered += low <= 1.0 <= high
        assert gap["total"] == pytest.approx(gap["per_channel"]["x"]["value"])
    assert 0.80 <= covered / 200 <= 0.96


def test_sparse_regression_finds_the_two_true_terms():
    generator = np.random.default_rng(3)
    features = generator.standard_normal((2000, 6)) * np.array([1, 2, 3, 0.5, 1, 4])
    target = 2.0 * features[:, 1] - 3.0 * features[:, 3] + 0.01 * generator.standard_normal(2000)
    fit = sparse_terms(features, target, ["a", "b", "c", "d", "e", "f"])
    assert set(fit["terms"]) == {"b", "d"}
    assert fit["terms"]["b"] == pytest.approx(2.0, rel=0.01)
    assert fit["terms"]["d"] == pytest.approx(-3.0, rel=0.01)
    assert fit["explained"] > 0.999


def test_magnitude_fit_escapes_a_local_minimum_and_refines():
    def cost(k: float) -> float:  # global minimum at 0.37, a shallower local one near -0.8
        return (k - 0.37) ** 2 * ((k + 0.8) ** 2 + 0.05)

    magnitude, value = fit_magnitude(cost, (-1.0, 1.0))
    assert magnitude == pytest.approx(0.37, abs=1e-3)
    assert value == pytest.approx(0.0, abs=1e-6)


def test_the_noise_level_is_the_run_to_run_spread_not_the_repeated_error():
    """unlocked_residual_sd: white noise of a known sd per channel on top of an error that every
    run repeats (locked to the input) gives back the noise's sd, whatever the repeated error."""
    generator = np.random.default_rng(4)
    time_s = np.arange(300) / 64.0
    repeated = np.outer(np.sin(2.0 * time_s), [5.0, 0.0, 1.0, 20.0])  # the same in every run
    noise_sd = np.array([0.1, 0.3, 0.02, 1.0])
    runs, residuals = [], []
    for index in range(12):
        runs.append(
            FlightRun(f"t#{index}", time_s, np.zeros((300, 4)), np.zeros(300), 0.5, 0.3, 0.7)
        )
        residuals.append(repeated + noise_sd * generator.standard_normal((300, 4)))
    # 12 x 300 samples per channel: the sd estimate scatters by ~1/sqrt(2 x 3300) = 1.2 %; 5 %
    # is 4 of those
    assert unlocked_residual_sd(runs, residuals) == pytest.approx(noise_sd, rel=0.05)
    assert np.all(np.isnan(unlocked_residual_sd(runs[:1], residuals[:1])))
