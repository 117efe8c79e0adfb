"""Diagnosis of free-flight logs against a linear baseline: where, which effect, how far it shrinks.

1. The logs' manoeuvres (:mod:`ornitail.gap.flight_data`) are split 70/30 with the seed.
2. Where: the baseline's residuals on all manoeuvres, decomposed by channel, frequency band, time
   segment and steady state (:mod:`ornitail.gap.flight_localisation`).
3. Which: every candidate (:mod:`ornitail.gap.flight_candidates`) is fitted on the training
   manoeuvres and scored on the withheld ones (:mod:`ornitail.gap.ranking`).
4. How far: gap before and after the chosen effect per channel on the withheld manoeuvres.

Fits, ranking and the gap before and after are weighted per channel by the inverse of the noise
level: the standard deviation of the part of the baseline's training residual that does not repeat
from manoeuvre to manoeuvre (gusts, sensor noise; :func:`unlocked_residual_sd`). A channel the input
hardly moves (its residual mostly disturbance) then weighs less than one whose residual an effect
can explain, as an output-error fit weighs channels by their noise covariance. ``where`` and the
``unexplained`` verdict keep the measured signal's standard deviation as the unit.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ornitail.flight.residual_statistics import residual_tests
from ornitail.gap.flight_candidates import (
    FlightCandidate,
    baseline_flight_model,
    flight_candidates,
)
from ornitail.gap.flight_data import CHANNELS, FlightRun, read_flight_runs, split_runs
from ornitail.gap.flight_localisation import (
    localise_flight,
    sparse_pointer,
    unlocked_residual_sd,
)
from ornitail.gap.flight_model import LinearFlightModel, simulate_runs, superpose
from ornitail.gap.magnitude_fit import fit_magnitude
from ornitail.gap.model_spec import BaselineSpec
from ornitail.gap.ranking import CandidateEvidence, Ranking, rank_candidates
from ornitail.gap.report import assemble_report

DEFAULT_SEED = 2018


@dataclass(frozen=True)
class FlightDiagnosis:
    """The report (JSON-ready dict) and what the plots need."""

    report: dict[str, object]
    runs: list[FlightRun]
    withheld: np.ndarray
    baseline: LinearFlightModel
    chosen: LinearFlightModel
    scales: np.ndarray


def noise_scales(
    training: Sequence[FlightRun], residuals: Sequence[np.ndarray], signal_scales: np.ndarray
) -> np.ndarray:
    """Per-channel weights' scale (SI units of each channel): the baseline's unlocked residual
    standard deviation on the training runs, or the signal's standard deviation where that is not
    positive and finite (fewer than two runs, a channel without noise).
    """
    noise = unlocked_residual_sd(training, residuals)
    return np.where(np.isfinite(noise) & (noise > 0), noise, signal_scales)


def residuals_of(model: LinearFlightModel, runs: Sequence[FlightRun]) -> list[np.ndarray]:
    """Measured minus simulated states (N, 4) per run."""
    return [
        run.states - predicted
        for run, predicted in zip(runs, simulate_runs(model, runs), strict=True)
    ]


def _channel_sse(residuals: Sequence[np.ndarray], scales: np.ndarray) -> np.ndarray:
    return np.array([np.sum((residual / scales) ** 2, axis=0) for residual in residuals])


def _input_correlation(
    residuals: Sequence[np.ndarray], runs: Sequence[FlightRun], reference_rms: np.ndarray
) -> float:
    """Mean over channels of the largest |residual-elevator correlation| over lags, each scaled by
    the residual's RMS over ``reference_rms`` (the baseline's), so a smaller residual counts less.
    """
    stacked = np.concatenate(residuals)
    tests = residual_tests(
        stacked,
        np.concatenate([run.elevator_rad for run in runs])[:, None],
        CHANNELS,
        ("elevator",),
    )
    ratio = np.sqrt(np.mean(stacked**2, axis=0)) / reference_rms
    return float(
        np.mean(
            [
                tests.max_input_correlation[c].get("elevator", 0.0) * ratio[i]
                for i, c in enumerate(CHANNELS)
            ]
        )
    )


def _fit(
    family: Callable[[float], LinearFlightModel],
    bounds: tuple[float, float],
    training: Sequence[FlightRun],
    scales: np.ndarray,
) -> tuple[float, LinearFlightModel]:
    def cost(magnitude: float) -> float:
        return float(_channel_sse(residuals_of(family(magnitude), training), scales).sum())

    magnitude, _ = fit_magnitude(cost, bounds)
    return magnitude, family(magnitude)


@dataclass(frozen=True)
class _Split:
    training: list[FlightRun]
    withheld: list[FlightRun]
    scales: np.ndarray
    reference_rms: np.ndarray
    seed: int


def _fit_pair(
    first: FlightCandidate,
    first_magnitude: float,
    second: FlightCandidate,
    baseline: LinearFlightModel,
    split: _Split,
) -> tuple[float, LinearFlightModel]:
    """Both magnitudes by coordinate descent (second, first, second), from the first's own fit."""
    magnitudes = [first_magnitude, 0.0]
    for index in (1, 0, 1):
        candidate = (first, second)[index]

        def family(k: float, index: int = index) -> LinearFlightModel:
            pair = [*magnitudes]
            pair[index] = k
            return superpose(baseline, first.build(pair[0]), second.build(pair[1]))

        magnitudes[index], model = _fit(family, candidate.bounds, split.training, split.scales)
    return magnitudes[1], model


def _score_library(
    library: Sequence[FlightCandidate],
    start: LinearFlightModel,
    baseline: LinearFlightModel,
    split: _Split,
    first: tuple[FlightCandidate, float] | None = None,
) -> tuple[Ranking, dict[str, tuple[LinearFlightModel, np.ndarray]], np.ndarray]:
    """Fit every candidate on the training runs and rank them on the withheld runs against
    ``start``: alone (``first`` None, ``start`` = ``baseline``), or together with the ``first``
    (candidate, magnitude) whose model is ``start``, both magnitudes refitted.

    Returns the ranking, each candidate's model and withheld per-channel squared residuals, and
    ``start``'s withheld per-channel squared residuals.
    """
    start_residuals = residuals_of(start, split.withheld)
    start_sse = _channel_sse(start_residuals, split.scales)
    evidence, fitted = [], {}
    for candidate in library:
        if first is None:
            magnitude, model = _fit(candidate.build, candidate.bounds, split.training, split.scales)
        else:
            magnitude, model = _fit_pair(*first, candidate, baseline, split)
        residuals = residuals_of(model, split.withheld)
        fitted[candidate.name] = (model, _channel_sse(residuals, split.scales))
        evidence.append(
            CandidateEvidence(
                name=candidate.name,
                magnitude=magnitude,
                unit=candidate.unit,
                parameters=1,
                heldout_sse=fitted[candidate.name][1].sum(axis=1),
                training_sse=float(
                    _channel_sse(residuals_of(model, split.training), split.scales).sum()
                ),
                input_correlation=_input_correlation(
                    residuals, split.withheld, split.reference_rms
                ),
            )
        )
    ranking = rank_candidates(
        evidence,
        start_sse.sum(axis=1),
        float(_channel_sse(residuals_of(start, split.training), split.scales).sum()),
        _input_correlation(start_residuals, split.withheld, split.reference_rms),
        int(sum(len(run.time_s) for run in split.training) * len(CHANNELS)),
        split.seed,
    )
    return ranking, fitted, start_sse


def _second_effect(ranking: Ranking | None) -> dict[str, object] | None:
    """A second effect found on top of the first (closure counted from the first)."""
    if ranking is None or not ranking.detected:
        return None
    top = ranking.entries[0]
    return {
        "effect": top.name,
        "indistinguishable_set": list(ranking.top_set),
        "magnitude": {"value": top.magnitude, "unit": top.unit},
        "closure_beyond_first": top.heldout_closure,
        "closure_interval": list(top.closure_interval),
    }


def diagnose_flight(
    spec: BaselineSpec, data_paths: Sequence[str | Path], seed: int = DEFAULT_SEED
) -> FlightDiagnosis:
    """Run the whole diagnosis of flight logs against ``spec``'s baseline."""
    runs = read_flight_runs(data_paths)
    training_index, withheld_index = split_runs(len(runs), seed)
    training = [runs[i] for i in training_index]
    withheld = [runs[i] for i in withheld_index]
    baseline = baseline_flight_model(spec)
    signal_scales = np.concatenate([run.states for run in training]).std(axis=0)
    signal_scales = np.where(signal_scales > 0, signal_scales, 1.0)
    scales = noise_scales(training, residuals_of(baseline, training), signal_scales)
    counts = np.array([len(run.time_s) for run in withheld], dtype=float)

    base_withheld_residuals = residuals_of(baseline, withheld)
    reference_rms = np.sqrt(np.mean(np.concatenate(base_withheld_residuals) ** 2, axis=0))
    reference_rms = np.where(reference_rms > 0, reference_rms, 1.0)
    library = flight_candidates(spec, baseline)
    split = _Split(training, withheld, scales, reference_rms, seed)
    ranking, fitted, base_withheld = _score_library(library, baseline, baseline, split)
    second = None
    if ranking.detected:
        top = ranking.entries[0]
        first = (next(c for c in library if c.name == top.name), top.magnitude)
        rest = [c for c in library if c.name not in ranking.top_set]
        if rest:
            second, _, _ = _score_library(rest, fitted[top.name][0], baseline, split, first)
    all_residuals = residuals_of(baseline, runs)
    where = localise_flight(runs, all_residuals, signal_scales, baseline)
    pointer = sparse_pointer(training, residuals_of(baseline, training), baseline)
    chosen_model, chosen_sse = fitted[ranking.entries[0].name]
    report = assemble_report(
        kind="flight",
        spec=spec,
        data_paths=data_paths,
        run_counts={"total": len(runs), "training": len(training), "withheld": len(withheld)},
        ranking=ranking,
        channels=CHANNELS,
        sample_counts=counts,
        before_sse=base_withheld,
        after_sse=chosen_sse,
        where=where,
        pointer=pointer,
        seed=seed,
        verdict_gap=float(
            np.sqrt(
                np.sum(base_withheld * (scales / signal_scales) ** 2)
                / (counts.sum() * len(CHANNELS))
            )
        ),
    )
    report["second_effect"] = _second_effect(second)
    return FlightDiagnosis(report, runs, withheld_index, baseline, chosen_model, signal_scales)
