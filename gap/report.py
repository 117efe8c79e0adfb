"""The diagnosis report's fields (docs/gap-diagnosis.md), shared by flight and tunnel data."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ornitail.gap.detection import DetectionRule
from ornitail.gap.intervals import closure_with_interval, fresh_data_interval, gap_with_interval
from ornitail.gap.model_spec import BaselineSpec
from ornitail.gap.ranking import Ranking
from ornitail.gap.verdict import verdict_of


def magnitude_field(value: float, unit: str, at_bound: str | None) -> dict[str, object]:
    """The report's ``magnitude`` object: ``value``, ``unit`` and ``at_bound`` (``"lower"``: the
    data want at most ``value``; ``"upper"``: at least ``value``; None: inside the range)."""
    return {"value": value, "unit": unit, "at_bound": at_bound}


def assemble_report(
    *,
    kind: str,
    spec: BaselineSpec,
    data_paths: Sequence[str | Path],
    total_runs: int,
    split: dict[str, object],
    ranking: Ranking,
    rule: DetectionRule,
    channels: Sequence[str],
    sample_counts: np.ndarray,
    before_sse: np.ndarray,
    after_sse: np.ndarray,
    where: dict[str, object],
    pointer: dict[str, object],
    seed: int,
    verdict_gap: float | None = None,
    derivative_refit: dict[str, object] | None = None,
) -> dict[str, object]:
    """The report's JSON fields (docs/gap-diagnosis.md) from the pieces of a diagnosis.

    ``split`` holds the ``training``, ``validation`` and ``test`` run counts and the ``method``.
    ``before_sse`` and ``after_sse`` are the *test* runs' normalised squared residuals per channel
    (runs, channels) of the baseline and of the top-ranked effect (fitted without them, chosen
    without them); ``sample_counts`` the samples per test run. ``verdict_gap`` is the baseline gap
    in units of the measured signals' standard deviation that the ``unexplained`` rule reads
    (default: ``gap_before``, when the channels were normalised that way). ``derivative_refit`` is
    the re-fit of the model's derivatives (None when not done), which the verdict also reads.
    """
    top = ranking.entries[0]
    gap_before = gap_with_interval(before_sse, sample_counts, channels, seed)
    gap_after = gap_with_interval(after_sse, sample_counts, channels, seed)
    run_before, run_after = before_sse.sum(axis=1), after_sse.sum(axis=1)
    realised, interval = closure_with_interval(run_before, run_after, seed)
    verdict, verdict_basis = verdict_of(
        ranking,
        gap_before["total"] if verdict_gap is None else verdict_gap,
        where["input_locked_fraction"],
        derivative_refit,
    )
    return {
        "format": "ornitail gap diagnosis",
        "version": 1,
        "data_kind": kind,
        "baseline": {
            "kind": spec.kind,
            "tail": spec.tail or None,
            "x_h_mm": spec.x_h_mm if math.isfinite(spec.x_h_mm) else None,
            "segment_s": spec.segment_s,
            "effects_off": list(spec.effects_off),
            "model": spec.model or None,
            "source": spec.source,
        },
        "data": [str(path) for path in data_paths],
        "seed": seed,
        "runs": {
            "total": total_runs,
            "training": split["training"],
            "validation": split["validation"],
            "test": split["test"],
        },
        "split": split,
        "detection_rule": rule.as_report(),
        "verdict": verdict,
        "verdict_basis": verdict_basis or None,
        "effect": top.name if verdict == "effect" else None,
        "indistinguishable_set": list(ranking.top_set) if verdict == "effect" else [],
        "confidence": ranking.top_set_confidence if verdict == "effect" else None,
        "magnitude": magnitude_field(top.magnitude, top.unit, top.at_bound),
        "best_candidate": top.name,
        "gap_before": gap_before,
        "gap_after": gap_after,
        "closure": {
            "predicted_from_training": top.training_closure,
            "realised_validation": top.heldout_closure,
            "realised_test": realised,
            "interval": interval,
            "fresh_data_interval": fresh_data_interval(run_before, run_after, seed),
        },
        "ranking": [
            {
                "name": entry.name,
                "magnitude": entry.magnitude,
                "unit": entry.unit,
                "at_bound": entry.at_bound,
                "validation_closure": entry.heldout_closure,
                "closure_interval": list(entry.closure_interval),
                "simultaneous_lower_bound": entry.simultaneous_lower_bound,
                "training_closure": entry.training_closure,
                "probability_best": entry.probability_best,
                "same_model_as": list(entry.same_model_as),
                "input_correlation_drop": entry.input_correlation_drop,
                "aic": entry.aic,
                "in_top_set": entry.in_top_set,
            }
            for entry in ranking.entries
        ],
        "where": where,
        "sparse_regression": pointer,
        "derivative_refit": derivative_refit,
    }
