"""Coverage of the campaign's per-manoeuvre 95 % intervals on the simulator's nonlinear flights.

A small version of ``benchmarks/flight_coverage.py``: the S5 tail at x_h = 98 mm, two simulated
campaigns of 20 manoeuvres each (``run_campaign``, as ``ornitail flight campaign --simulate``),
every converged manoeuvre model's value +- 1.96 sigma_colored against the simulator's linearisation
(same parameter names, frame and SI units as the DelFly preset).

Reference figures (benchmark, 40 flights of S5, 9300 intervals, re-measured on the simulator of
issue 13: the study's wing arm and a tail that separates past 6.7 deg): pooled coverage with the
colored sigmas 0.663 (95 % interval 0.654-0.672, flights as clusters), with the Cramer-Rao sigmas
0.096. It misses the nominal 0.95 because the 13 deg doublets drive the vehicle beyond its linear
range (Zw, Xde, Mw, Xq, Zu, Mu, Mde, Zq are biased by 1.3-3.4 sigma on average) and because the
colored-residual correction is itself estimated from ~45 independent samples per manoeuvre
(docs/flight-campaign.md).
"""

from __future__ import annotations

import numpy as np
import pytest

from ornitail.flight.campaign import ConfigurationResult, run_campaign
from ornitail.flight.campaign_file import CampaignSpec, configuration_from_label
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import linearise

TAIL = "S5"
X_H_MM = 98
MANOEUVRES = 20
SEEDS = (11, 12)
Z_95 = 1.959963984540054
# Statistics of the band. Intervals of one flight are correlated (shared steady state and
# gusts; the 12 parameters of a manoeuvre share its residuals), so the unit of independence is
# the flight: over the benchmark's 40 S5 flights the pooled coverage of one flight (about 230
# intervals) scattered with sd 0.029 from flight to flight (the binomial sd of 230 independent
# intervals would be 0.031). Two flights (the suite's time budget): sd 0.029 / sqrt(2) = 0.020
# about the expected 0.663. LOWER_POOLED = 0.59 is 3.6 sd below it. The Cramer-Rao sigmas on these
# residuals cover 0.10 (0.096 over 40 flights), 28 sd below the expectation, so the test fails if
# the colored correction is dropped or lost. UPPER_POOLED = 0.98 is the target's upper edge: 95 %
# intervals that cover more are too wide (colored sigmas doubled cover 0.96-0.996 per flight).
# Measured for these seeds: 0.625.
LOWER_POOLED = 0.59
UPPER_POOLED = 0.98
# Well-excited parameters with small model-structure bias at this tail (coverage over the
# benchmark's 40 flights: Zde 0.923, Mq 0.884, mean z 0.23 and 0.89; Mde, 0.908 on the earlier
# model, now 0.693: the 13 deg doublets saturate the separated tail, mean z -1.27). Two flights
# hold ~39 intervals per parameter: binomial sd 0.043 and 0.051. 0.70 is >= 3.6 sd below each
# expectation.
WELL_EXCITED = ("Zde", "Mq")
LOWER_WELL_EXCITED = 0.70


@pytest.fixture(scope="module")
def campaigns() -> list[ConfigurationResult]:
    results = []
    for seed in SEEDS:
        campaign = CampaignSpec(
            (
                configuration_from_label(
                    f"{TAIL}@{X_H_MM}", "coverage test", simulated_manoeuvres=MANOEUVRES
                ),
            ),
            seed=seed,
        )
        results += run_campaign(campaign)
    return results


def _normalised_errors(results: list[ConfigurationResult], kind: str) -> tuple[tuple, np.ndarray]:
    """Parameter names and z = (value - truth) / sigma of every converged manoeuvre model
    (``kind``: ``sigma_colored`` or ``sigma``), shape (models, parameters).
    """
    truth = linearise(study_configuration(TAIL, X_H_MM)).derivatives
    names = results[0].models[0].parameter_names
    rows = [
        [
            (model.result.parameters[name].value - truth[name])
            / getattr(model.result.parameters[name], kind)
            for name in names
        ]
        for result in results
        for model in result.models
    ]
    return names, np.array(rows)


def _covered(z: np.ndarray) -> np.ndarray:
    """|z| <= 1.96; a NaN sigma (negative colored variance) forms no interval: not covered."""
    with np.errstate(invalid="ignore"):
        return np.abs(z) <= Z_95


def test_enough_manoeuvres_are_identified(campaigns):
    # Benchmark: 1427 of 1600 manoeuvres of S1 and S5 converge within the 100 iterations.
    converged = sum(len(result.models) for result in campaigns)
    assert converged >= 0.75 * MANOEUVRES * len(SEEDS)


def test_colored_intervals_cover_the_linearisation_as_measured(campaigns):
    _, colored = _normalised_errors(campaigns, "sigma_colored")
    pooled = _covered(colored).mean()
    assert LOWER_POOLED <= pooled <= UPPER_POOLED, pooled


def test_cramer_rao_intervals_would_fail_the_band(campaigns):
    """The band discriminates: the uncorrected bound on the same fits falls far below it."""
    _, cramer_rao = _normalised_errors(campaigns, "sigma")
    assert _covered(cramer_rao).mean() < LOWER_POOLED - 0.2


def test_well_excited_parameters_are_covered_nearly_nominally(campaigns):
    names, colored = _normalised_errors(campaigns, "sigma_colored")
    covered = _covered(colored)
    for name in WELL_EXCITED:
        coverage = covered[:, names.index(name)].mean()
        assert coverage >= LOWER_WELL_EXCITED, (name, coverage)
