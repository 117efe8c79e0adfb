"""Diagnosis of free-flight logs against a linear baseline: where, which effect, how far it shrinks.

1. The logs' manoeuvres (:mod:`ornitail.gap.flight_data`) are split 70/30 with the seed.
2. Where: the baseline's residuals on all manoeuvres, decomposed by channel, frequency band, time
   segment and steady state (:mod:`ornitail.gap.flight_localisation`).
3. Which: every candidate (:mod:`ornitail.gap.flight_candidates`) is fitted on the training
   manoeuvres and scored on the withheld ones (:mod:`ornitail.gap.ranking`).
4. How far: gap before and after the chosen effect per channel on the withheld manoeuvres.

Residuals are normalised per channel by the measured signal's standard deviation on the training
manoeuvres, so q, u, w and theta weigh alike.
"""

from __future__ import annotations

from collections.abc import Sequence
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
from ornitail.gap.flight_localisation import localise_flight, sparse_pointer
from ornitail.gap.flight_model import LinearFlightModel, simulate_runs
from ornitail.gap.magnitude_fit import fit_magnitude
from ornitail.gap.model_spec import BaselineSpec
from ornitail.gap.ranking import CandidateEvidence, rank_candidates
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
    candidate: FlightCandidate, training: Sequence[FlightRun], scales: np.ndarray
) -> tuple[float, LinearFlightModel]:
    def cost(magnitude: float) -> float:
        return float(_channel_sse(residuals_of(candidate.build(magnitude), training), scales).sum())

    magnitude, _ = fit_magnitude(cost, candidate.bounds)
    return magnitude, candidate.build(magnitude)


def diagnose_flight(
    spec: BaselineSpec, data_paths: Sequence[str | Path], seed: int = DEFAULT_SEED
) -> FlightDiagnosis:
    """Run the whole diagnosis of flight logs against ``spec``'s baseline."""
    runs = read_flight_runs(data_paths)
    training_index, withheld_index = split_runs(len(runs), seed)
    training = [runs[i] for i in training_index]
    withheld = [runs[i] for i in withheld_index]
    baseline = baseline_flight_model(spec)
    scales = np.concatenate([run.states for run in training]).std(axis=0)
    scales = np.where(scales > 0, scales, 1.0)
    counts = np.array([len(run.time_s) for run in withheld], dtype=float)

    base_training = _channel_sse(residuals_of(baseline, training), scales).sum()
    base_withheld_residuals = residuals_of(baseline, withheld)
    base_withheld = _channel_sse(base_withheld_residuals, scales)
    reference_rms = np.sqrt(np.mean(np.concatenate(base_withheld_residuals) ** 2, axis=0))
    reference_rms = np.where(reference_rms > 0, reference_rms, 1.0)
    base_correlation = _input_correlation(base_withheld_residuals, withheld, reference_rms)

    evidence, fitted = [], {}
    for candidate in flight_candidates(spec, baseline):
        magnitude, model = _fit(candidate, training, scales)
        residuals = residuals_of(model, withheld)
        fitted[candidate.name] = (model, _channel_sse(residuals, scales))
        evidence.append(
            CandidateEvidence(
                name=candidate.name,
                magnitude=magnitude,
                unit=candidate.unit,
                parameters=1,
                heldout_sse=fitted[candidate.name][1].sum(axis=1),
                training_sse=float(_channel_sse(residuals_of(model, training), scales).sum()),
                input_correlation=_input_correlation(residuals, withheld, reference_rms),
            )
        )
    ranking = rank_candidates(
        evidence,
        base_withheld.sum(axis=1),
        float(base_training),
        base_correlation,
        int(sum(len(run.time_s) for run in training) * len(CHANNELS)),
        seed,
    )
    all_residuals = residuals_of(baseline, runs)
    where = localise_flight(runs, all_residuals, scales, baseline)
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
    )
    return FlightDiagnosis(report, runs, withheld_index, baseline, chosen_model, scales)
