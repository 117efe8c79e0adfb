"""How much each validation run counts in the ranking and the detection rule
(``[baseline].validation_weighting``; flight logs).

``"none"`` (segments of a record, and the design until stop 43): every run counts by its
energy, and the closure is the ratio of the summed energies after and before. A run holding a
strong disturbance that no candidate explains (4-5 x the median run's energy in the benchmark's
missed effects) adds the same to both sums and dilutes every candidate's closure towards 0, and it
widens the bootstrap's spread, so a real effect can fall under the materiality floor
(docs/gap-diagnosis.md, *Detection limits*).

``"winsorised"`` (the default for manoeuvres since stop 43, measured on all 16 of the benchmark's
simulator seeds and flapper B's: docs/gap-diagnosis.md, *Winsorised validation runs*): a
validation run whose baseline energy exceeds :data:`WINSORISED_RUN_ENERGY` times the median run's is scaled down to
that energy, its energies after every candidate and every null direction by the same factor, so
the run keeps its closure but not its weight. The weights depend only on the baseline's
residuals, never on a candidate, so candidates and the null are scored alike and the rule stays
calibrated on the same statistic. The closure on test runs and its intervals are not weighted:
how far the gap shrinks is reported on every run as it is. Nor is a second effect's search, which
ranks on the first fold's validation runs alone.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.gap.flight_data import MANOEUVRES_CUT
from ornitail.gap.model_spec import BaselineSpec
from ornitail.gap.pooled_validation import FoldScores

WINSORISED_RUN_ENERGY = 3.0
"""A validation run counts as at most this many times the median run's baseline energy. Set before
measuring, not fitted: in the benchmark's flights 90 % of runs hold under 1.8 x the median theta
energy and the strongly disturbed ones 4-9 x (docs/gap-diagnosis.md, *Closure on new data*)."""


def validation_weighting_for(spec: BaselineSpec, cut: str) -> str:
    """The weighting the runs get: the baseline file's, or when it names none ``"winsorised"`` for
    manoeuvres (``cut`` is :data:`MANOEUVRES_CUT`) and ``"none"`` for segments. ``"winsorised"`` is
    refused for segments: only runs that repeat one input differ in energy by their disturbance;
    consecutive segments of one record differ by how much the input excites them, and the most
    excited, the most informative, would lose weight."""
    repeated = cut == MANOEUVRES_CUT
    if spec.validation_weighting is None:
        return "winsorised" if repeated else "none"
    if spec.validation_weighting != "none" and not repeated:
        raise UserInputError(
            f"{spec.source}: [baseline].validation_weighting",
            f"{spec.validation_weighting!r} needs runs that repeat one manoeuvre; these runs are {cut} "
            "of a record, which differ in how much the input excites them",
        )
    return spec.validation_weighting


def validation_run_weights(weighting: str, start_sse: np.ndarray) -> np.ndarray:
    """Each validation run's weight (runs,) from the baseline's energy on it (``start_sse``,
    weighted squared residuals): all 1 for ``"none"``; min(1, cap x median / energy) for
    ``"winsorised"``."""
    start_sse = np.asarray(start_sse, dtype=float)
    if weighting == "none":
        return np.ones_like(start_sse)
    cap = WINSORISED_RUN_ENERGY * float(np.median(start_sse))
    with np.errstate(divide="ignore"):
        return np.where(start_sse > cap, cap / start_sse, 1.0)


def weighted_scores(scores: FoldScores, weights: np.ndarray) -> FoldScores:
    """``scores`` with every per-validation-run energy (the start model's, each candidate's and
    each null direction's) multiplied by that run's weight."""
    evidence = [
        dataclasses.replace(item, heldout_sse=item.heldout_sse * weights)
        for item in scores.evidence
    ]
    null_weights = weights if scores.null_start_sse.size else np.ones(0)
    return dataclasses.replace(
        scores,
        evidence=evidence,
        start_heldout_sse=scores.start_heldout_sse * weights,
        null_start_sse=scores.null_start_sse * null_weights,
        null_after_sse=scores.null_after_sse * null_weights,
    )
