"""Candidates that are linear in their magnitude, fitted on training rows and scored on withheld ones.

Shared by the tunnel and steady-state diagnoses, whose rows (set points, configurations) each
carry one residual per channel. A simulator effect is ``baseline + k x step`` (``step`` = the
prediction with the effect on minus with it off), k by least squares on the normalised residual;
the offset candidate is a constant per channel (weighted mean of the training residual).

A split is a list of folds ``(training, withheld)``: one fold ``(training, validation)`` for a
three-way split (the test rows are then in neither, and their residual after a candidate is the
training fit's prediction; :func:`nested_test` rotates the test rows), one per row for
leave-one-out. Every row is withheld at most once; the
withheld rows of all folds are scored together. The magnitude reported is the fit on the union of
the training rows. The detection rule's null directions (:func:`linear_null_rule`) are random
combinations of the configuration variables, fitted and scored the same way.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ornitail.gap.detection import NULL_DRAWS, DetectionRule, closure_of, random_feature_steps
from ornitail.gap.ranking import CandidateEvidence, Ranking, rank_candidates

Fold = tuple[np.ndarray, np.ndarray]
EFFECT_UNIT = "x effect"
NEGLIGIBLE_STEP = 1e-9


@dataclass(frozen=True)
class LinearFit:
    """One candidate: residual after it on every row (withheld rows from their own fold)."""

    name: str
    after: np.ndarray
    magnitude: float
    unit: str
    parameters: int
    training_sse: float


@dataclass(frozen=True)
class LinearRanking:
    ranking: Ranking
    fits: dict[str, LinearFit]
    withheld: np.ndarray  # row indices in scoring order (folds concatenated)

    @property
    def best(self) -> LinearFit:
        return self.fits[self.ranking.entries[0].name]


def _step_factor(step: np.ndarray, residual: np.ndarray, scales: np.ndarray, rows) -> float:
    x = (step[rows] / scales[rows]).ravel()
    y = (residual[rows] / scales[rows]).ravel()
    return float(x @ y / (x @ x))


def _offset(residual: np.ndarray, scales: np.ndarray, rows) -> np.ndarray:
    weights = 1.0 / scales[rows] ** 2
    return np.sum(residual[rows] * weights, axis=0) / np.sum(weights, axis=0)


def _sse(residual: np.ndarray, scales: np.ndarray, rows) -> float:
    return float(np.sum((residual[rows] / scales[rows]) ** 2))


def fit_linear_candidates(
    residual: np.ndarray,
    steps: dict[str, np.ndarray],
    scales: np.ndarray,
    folds: list[Fold],
    offset: tuple[str, str] | None,
) -> dict[str, LinearFit]:
    """Fit every step (and the offset ``(name, unit)``) per fold; see the module docstring.

    ``residual`` and ``steps`` are (rows, channels) in SI; ``scales`` broadcasts to that shape.
    Steps that are negligible against the scales are dropped.
    """
    scales = np.broadcast_to(scales, residual.shape)
    training_all = np.unique(np.concatenate([training for training, _ in folds]))
    models: dict[str, tuple[Callable[[np.ndarray], np.ndarray], str, int]] = {}
    for name, step in steps.items():
        if np.max(np.abs(step / scales)) > NEGLIGIBLE_STEP:
            models[name] = (
                lambda rows, step=step: step * _step_factor(step, residual, scales, rows),
                EFFECT_UNIT,
                1,
            )
    if offset is not None:
        models[offset[0]] = (
            lambda rows: np.broadcast_to(_offset(residual, scales, rows), residual.shape),
            offset[1],
            residual.shape[1],
        )
    fits = {}
    for name, (correction, unit, parameters) in models.items():
        full = correction(training_all)
        after = residual - full
        training_sse = []
        for training, withheld in folds:
            fold_after = residual - correction(training)
            after[withheld] = fold_after[withheld]
            training_sse.append(_sse(fold_after, scales, training))
        if name in steps:
            magnitude = _step_factor(steps[name], residual, scales, training_all)
        else:
            magnitude = float(np.linalg.norm(full[0]))
        fits[name] = LinearFit(
            name, after, magnitude, unit, parameters, float(np.mean(training_sse))
        )
    return fits


def rank_linear_candidates(
    residual: np.ndarray,
    fits: dict[str, LinearFit],
    scales: np.ndarray,
    folds: list[Fold],
    seed: int,
    rule: DetectionRule | None = None,
) -> LinearRanking:
    """Rank ``fits`` on the withheld rows (:func:`ornitail.gap.ranking.rank_candidates`); detect
    with ``rule`` (None: rank only)."""
    scales = np.broadcast_to(scales, residual.shape)
    withheld = np.concatenate([rows for _, rows in folds])
    base_training = float(np.mean([_sse(residual, scales, rows) for rows, _ in folds]))
    base_rows = np.sum((residual / scales) ** 2, axis=1)
    evidence = [
        CandidateEvidence(
            fit.name,
            fit.magnitude,
            fit.unit,
            fit.parameters,
            np.sum((fit.after / scales) ** 2, axis=1)[withheld],
            fit.training_sse,
            0.0,
        )
        for fit in fits.values()
    ]
    training_count = len(folds[0][0]) * residual.shape[1]
    ranking = rank_candidates(
        evidence, base_rows[withheld], base_training, 0.0, training_count, seed, rule
    )
    return LinearRanking(ranking, fits, withheld)


def linear_null_rule(
    residual: np.ndarray,
    features: np.ndarray,
    scales: np.ndarray,
    folds: list[Fold],
    seed: int,
    draws: int = NULL_DRAWS,
) -> DetectionRule:
    """The detection rule (:mod:`ornitail.gap.detection`) for row tables: ``draws`` random steps
    built from ``features`` (rows, variables), fitted per fold like the candidates and scored on
    the withheld rows."""
    scales = np.broadcast_to(scales, residual.shape)
    steps = random_feature_steps(features, scales, draws, seed)
    fits = fit_linear_candidates(
        residual, {f"null_{i}": step for i, step in enumerate(steps)}, scales, folds, None
    )
    withheld = np.concatenate([rows for _, rows in folds])
    before = _sse(residual, scales, withheld)
    closures = [closure_of(before, _sse(fit.after, scales, withheld)) for fit in fits.values()]
    return DetectionRule(
        f"withheld closures of {len(closures)} random one-parameter steps (random combinations "
        "of the standardised configuration variables and a constant per channel), fitted on the "
        "training rows like every candidate",
        np.array(closures),
    )


def nested_test(
    residual: np.ndarray,
    steps: dict[str, np.ndarray],
    scales: np.ndarray,
    offset: tuple[str, str] | None,
    candidates: tuple[str, ...],
    seed: int,
    outer: list[tuple[list[Fold], np.ndarray]],
) -> tuple[np.ndarray, dict[str, int]]:
    """Test residuals by nested cross-validation: for each ``(inner folds, test rows)`` of
    ``outer``, the inner folds (which hold no test row) rank the candidates, and the top one,
    fitted on the inner training rows, predicts the test rows. Returns the residual after the chosen
    candidate on every test row (rows, channels, SI; NaN on rows never tested) and how often each
    candidate was chosen. ``candidates`` (when not empty) restricts the library."""
    after = np.full(residual.shape, np.nan)
    chosen: dict[str, int] = {}
    for inner, test in outer:
        fits = fit_linear_candidates(residual, steps, scales, inner, offset)
        if candidates:
            fits = {name: fit for name, fit in fits.items() if name in candidates}
        best = rank_linear_candidates(residual, fits, scales, inner, seed).best
        after[test] = best.after[test]
        chosen[best.name] = chosen.get(best.name, 0) + 1
    return after, chosen


def leave_one_out_outer(count: int) -> list[tuple[list[Fold], np.ndarray]]:
    """Nested leave-one-out: each row in turn is the test row; leave-one-out over the others
    chooses."""
    everything = np.arange(count)
    outer = []
    for row in everything:
        rest = np.delete(everything, row)
        outer.append(([(np.delete(rest, i), rest[[i]]) for i in range(len(rest))], np.array([row])))
    return outer
