"""Validation pooled over the folds of the nested split (``[baseline].validation = "all-folds"``, the default).

The first fold's validation runs alone are few (4 of a 16-manoeuvre flight), too few for a reliable
lower bound (docs/gap-diagnosis.md, *Simultaneous lower bound*). Every fold already fits each
candidate on its own training runs and scores it on its own validation runs (to choose the effect
its test runs are scored with); pooled, those scores give the ranking and the detection rule every
fold's validation runs: 16 of 16 manoeuvres, each run once (:func:`ornitail.gap.flight_data.nested_splits`
validates fold k on group k + 1), scored by a model that did not see it. The null directions are fitted
and scored the same way in every fold, so that the rule compares like with like. Test runs are untouched: each is
scored with the effect its own fold chose on its own validation runs.

It fits the null in every fold: 7.8 s against 4.6 s for a 16-manoeuvre flight with the first fold's validation
runs alone (``validation = "first-fold"``; benchmarks/gap_simulation.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ornitail.gap.ranking import CandidateEvidence


@dataclass(frozen=True)
class FoldScores:
    """One fold's library scores: each candidate's evidence (in library order), the start model's
    per-validation-run energies and training energy, its mean residual-input correlation on the
    validation runs, the training samples, and the null directions' validation energies
    (draws, runs) with the start model's (runs,) on the same runs (weighted squared residuals,
    dimensionless)."""

    evidence: list[CandidateEvidence]
    start_heldout_sse: np.ndarray
    start_training_sse: float
    start_input_correlation: float
    training_count: int
    null_after_sse: np.ndarray
    null_start_sse: np.ndarray


def pool_folds(folds: Sequence[FoldScores]) -> FoldScores:
    """Every fold's scores as one: validation runs' energies joined (candidates and start model),
    training energies and samples summed, input correlations averaged, the null directions'
    validation energies joined per direction (so each direction's closure is over every fold's
    validation runs, as a candidate's is); each candidate's magnitude and bounds are the first
    fold's fit (the one reported and carried to a second effect)."""
    evidence = []
    for index, first in enumerate(folds[0].evidence):
        own = [fold.evidence[index] for fold in folds]
        evidence.append(
            CandidateEvidence(
                name=first.name,
                magnitude=first.magnitude,
                unit=first.unit,
                parameters=first.parameters,
                heldout_sse=np.concatenate([item.heldout_sse for item in own]),
                training_sse=float(sum(item.training_sse for item in own)),
                input_correlation=float(np.mean([item.input_correlation for item in own])),
                bounds=first.bounds,
            )
        )
    return FoldScores(
        evidence=evidence,
        start_heldout_sse=np.concatenate([fold.start_heldout_sse for fold in folds]),
        start_training_sse=float(sum(fold.start_training_sse for fold in folds)),
        start_input_correlation=float(np.mean([fold.start_input_correlation for fold in folds])),
        training_count=int(sum(fold.training_count for fold in folds)),
        null_after_sse=np.concatenate([fold.null_after_sse for fold in folds], axis=1),
        null_start_sse=np.concatenate([fold.null_start_sse for fold in folds]),
    )
