"""Ranking candidate effects on withheld data, with bootstrap confidence and indistinguishable sets.

Inputs are per-run normalised squared residuals (run = a withheld manoeuvre or tunnel point).
Closure = 1 - gap_after / gap_before, gap = sqrt(sum of normalised squared residuals / count).
Order: held-out closure first; candidates the withheld data cannot separate from the best form
the top *set* and are ordered among themselves by their probability of being best (the share of
resamples in which their model closes most), then by the drop of the residual-input correlation,
then by AIC on the training data (which assumes white residuals, so it only breaks ties).

The held-out runs here are the *validation* runs: they choose, and the gap's shrinking is reported
on separate test runs (:mod:`ornitail.gap.report`).

Tied with the best: the best candidate's closure exceeds the other's in fewer than
:data:`SEPARATION_PROBABILITY` of the bootstrap resamples of the validation runs, or the two
closures differ by less than :data:`IDENTICAL_CLOSURE` (the same model family, e.g. added mass and
I_yy). An effect is *detected* when the calibrated rule (:mod:`ornitail.gap.detection`) accepts the
best validation closure and its *simultaneous lower bound*.

One model under several names (every validation run's energy the same within
:data:`SAME_MODEL_ENERGY`: added mass and I_yy in the simulator) is one hypothesis: its members share
their probability of being best (the share of resamples in which that model closes most; which of its
names wins a resample is rounding) and list each other in ``same_model_as``.

Simultaneous lower bound: the best of several candidates on the same validation runs is the one those
runs flattered most (the winner's curse), so its own 5 % bootstrap quantile is too high a bound. Each
candidate's bound is instead its closure minus t times its bootstrap standard deviation, with t the
95th percentile over resamples of the largest standardised shortfall max_j (c_j - c*_j) / s_j (c_j
the observed closure, c*_j a resample's, s_j their standard deviation) over the *contenders*: the
candidates whose 95 % resample quantile reaches the best closure, the ones these runs could have
made the winner. Their bounds hold together in 95 % of resamples, whichever of them wins (a
max-statistic bootstrap as in Romano and Wolf's step-down tests; leaving out candidates that could
not have won follows Hansen's test for superior predictive ability, which drops alternatives far
below the best so that they do not widen the bound). With one contender it is that candidate's 5 %
quantile of the percentile bootstrap, the bound used before.

With validation pooled over the folds (``[baseline].validation = "all-folds"``, the default) the
rule has 12-20 runs and the bound is a two-step Bonferroni-t (after Romano, Shaikh and Wolf's
two-step method for moment inequalities): the contenders are those whose 99.5 % resample quantile
(:data:`CONTENDER_LEVEL`) reaches the best closure; each of the m contenders' bounds is c_j - t s_j,
s_j the delta-method standard error of the ratio of sums (:func:`closures_and_standard_errors`, with
the influences' unbiased variance) and t Student's quantile on R - 1 degrees of freedom at (5 % -
0.5 %) / m, m counting contenders that are one model (every run's energy the same, as added mass and
I_yy) once: their bounds fail together. On 16 skewed synthetic runs it covers 0.91 alone and 0.77
among 8 equally good candidates (the percentile bound: 0.89 and 0.63). A studentised max-statistic
bootstrap covers 0.94 and 0.92 there, but one strongly disturbed run (closing nothing, carrying
twice the median energy) wrecks it: the resamples without that run close high with a tiny standard
error, and a simulated pitch-damping flight closing 0.34 on 16 pooled runs got a bound of 0.04
(docs/gap-diagnosis.md, *Simultaneous lower bound*).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ornitail.gap.detection import DetectionRule
from ornitail.gap.intervals import closures_and_standard_errors
from ornitail.gap.magnitude_fit import bound_side

BOOTSTRAP_RESAMPLES = 1000
SEPARATION_PROBABILITY = 0.95
SIMULTANEOUS_LEVEL = 0.05  # the lower bounds fail together in 5 % of resamples
CONTENDER_LEVEL = 0.005  # of the 5 %, what the Bonferroni-t bound's first step may spend
IDENTICAL_CLOSURE = 0.005
SAME_MODEL_ENERGY = 5e-4
"""Two candidates are one model (counted once by the Bonferroni-t bound, sharing their probability of being best) when
every validation run's energy agrees within this fraction of the baseline's: added mass and I_yy, one model family,
agree within 7e-5 (their fits' tolerance) on every simulated flight of the four benchmark seeds; the closest
different models among contenders (a delay and a first-order filter) differed by 2.8e-3 at least
(docs/gap-diagnosis.md)."""


@dataclass(frozen=True)
class CandidateEvidence:
    """One fitted candidate: magnitude, parameter count, and its residual energies.

    ``heldout_sse`` is per validation run; ``training_sse`` the training total;
    ``input_correlation`` the mean over channels of the largest |residual-input correlation| on
    the validation data; ``bounds`` the range the magnitude was fitted in (None: unbounded).
    """

    name: str
    magnitude: float
    unit: str
    parameters: int
    heldout_sse: np.ndarray
    training_sse: float
    input_correlation: float
    bounds: tuple[float, float] | None = None


@dataclass(frozen=True)
class RankedEffect:
    """One candidate's scores; ``at_bound`` is ``"lower"``, ``"upper"`` or None
    (:func:`ornitail.gap.magnitude_fit.bound_side`)."""

    name: str
    magnitude: float
    unit: str
    at_bound: str | None
    heldout_closure: float
    closure_interval: tuple[float, float]
    simultaneous_lower_bound: float
    training_closure: float
    probability_best: float
    same_model_as: tuple[str, ...]
    input_correlation_drop: float
    aic: float
    in_top_set: bool


@dataclass(frozen=True)
class Ranking:
    entries: list[RankedEffect]
    top_set: tuple[str, ...]
    top_set_confidence: float
    detected: bool


def _closures(base: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return 1.0 - np.sqrt(candidates / base[..., None])


def _simultaneous_lower_bounds(observed: np.ndarray, resampled: np.ndarray) -> np.ndarray:
    """Lower bounds (K,) that hold together for the contenders (module docstring) from the
    observed closures (K,) and their resamples (B, K). A candidate whose closure does not vary over
    the resamples keeps its closure and widens no other's."""
    spread = resampled.std(axis=0)
    varies = np.isfinite(spread) & (spread > 0)
    best = np.max(observed)
    contenders = varies & (np.quantile(resampled, 1.0 - SIMULTANEOUS_LEVEL, axis=0) >= best)
    if not contenders.any():
        return observed.copy()
    shortfall = (observed[contenders] - resampled[:, contenders]) / spread[contenders]
    width = float(np.quantile(np.max(shortfall, axis=1), 1.0 - SIMULTANEOUS_LEVEL))
    return observed - width * np.where(varies, spread, 0.0)


def _bonferroni_t_lower_bounds(
    baseline_sse: np.ndarray, heldout_sse: np.ndarray, observed: np.ndarray, resampled: np.ndarray
) -> np.ndarray:
    """The two-step Bonferroni-t bounds (K,) of the module docstring, from the per-run energies
    (``baseline_sse`` (R,), ``heldout_sse`` (K, R)), the observed closures (K,) and the resampled
    ones (B, K). A candidate whose closure does not vary over the runs keeps its closure."""
    runs = len(baseline_sse)
    _, (error,) = closures_and_standard_errors(np.ones((1, runs)), baseline_sse, heldout_sse)
    error = error * np.sqrt(runs / max(runs - 1, 1))  # the influences' unbiased variance
    varies = np.isfinite(error) & (error > 0)
    contenders = varies & (np.quantile(resampled, 1.0 - CONTENDER_LEVEL, axis=0) >= observed.max())
    if runs < 2 or not contenders.any():
        return observed.copy()
    distinct = len(set(_model_groups(heldout_sse[contenders], baseline_sse)))
    width = stats.t.isf((SIMULTANEOUS_LEVEL - CONTENDER_LEVEL) / distinct, runs - 1)
    return np.where(varies, observed - width * error, observed)


def _model_groups(heldout_sse: np.ndarray, baseline_sse: np.ndarray) -> list[int]:
    """A label per row of ``heldout_sse`` (K, R), equal for rows that are one model: every run's
    energy agrees within :data:`SAME_MODEL_ENERGY` of the baseline's (``baseline_sse`` (R,)) with
    the row the label names (their bounds fail together, so Bonferroni counts them once)."""
    labels: list[int] = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for index, row in enumerate(heldout_sse):
            same = (
                label
                for label in dict.fromkeys(labels)
                if np.max(np.abs(row - heldout_sse[label]) / baseline_sse) < SAME_MODEL_ENERGY
            )
            labels.append(next(same, index))
    return labels


def _order_key(entry: RankedEffect) -> tuple[int, float, float, float]:
    """Top set by probability of being best, then input-correlation drop (to 1e-3), then AIC; the
    rest by held-out closure."""
    if entry.in_top_set:
        return (0, -entry.probability_best, -round(entry.input_correlation_drop, 3), entry.aic)
    return (1, -entry.heldout_closure, 0.0, 0.0)


def rank_candidates(
    evidence: list[CandidateEvidence],
    baseline_heldout_sse: np.ndarray,
    baseline_training_sse: float,
    baseline_input_correlation: float,
    training_count: int,
    seed: int = 0,
    rule: DetectionRule | None = None,
    bonferroni_t: bool = False,
) -> Ranking:
    """Rank ``evidence`` (see the module docstring); ``training_count`` = training samples.

    ``rule`` decides detection; without one (ranking only to choose, e.g. inside a nested
    cross-validation) nothing is detected. ``bonferroni_t``: the two-step Bonferroni-t lower bound
    (for validation pooled over folds) instead of the percentile one.
    """
    runs = len(baseline_heldout_sse)
    generator = np.random.default_rng(seed)
    weights = generator.multinomial(runs, np.full(runs, 1.0 / runs), size=BOOTSTRAP_RESAMPLES)
    heldout = np.array([item.heldout_sse for item in evidence])  # (K, R)
    observed = _closures(np.array(baseline_heldout_sse.sum()), heldout.sum(axis=1))
    resampled = _closures(weights @ baseline_heldout_sse, weights @ heldout.T)  # (B, K)
    best = int(np.argmax(observed))
    winners = np.argmax(resampled, axis=1)
    groups = np.array(_model_groups(heldout, baseline_heldout_sse))
    winning_models = groups[winners]
    tied = np.array(
        [
            index == best
            or np.mean(resampled[:, best] > resampled[:, index]) < SEPARATION_PROBABILITY
            or observed[best] - observed[index] < IDENTICAL_CLOSURE
            for index in range(len(evidence))
        ]
    )
    lower_bounds = (
        _bonferroni_t_lower_bounds(baseline_heldout_sse, heldout, observed, resampled)
        if bonferroni_t
        else _simultaneous_lower_bounds(observed, resampled)
    )
    entries = []
    for index, item in enumerate(evidence):
        low, high = np.quantile(resampled[:, index], [0.05, 0.95])
        training_closure = 1.0 - np.sqrt(item.training_sse / baseline_training_sse)
        aic = training_count * np.log(item.training_sse / training_count) + 2 * item.parameters
        entries.append(
            RankedEffect(
                name=item.name,
                magnitude=item.magnitude,
                unit=item.unit,
                at_bound=bound_side(item.magnitude, item.bounds),
                heldout_closure=float(observed[index]),
                closure_interval=(float(low), float(high)),
                simultaneous_lower_bound=float(lower_bounds[index]),
                training_closure=float(training_closure),
                probability_best=float(np.mean(winning_models == groups[index])),
                same_model_as=tuple(
                    other.name
                    for other, group in zip(evidence, groups, strict=True)
                    if group == groups[index] and other is not item
                ),
                input_correlation_drop=baseline_input_correlation - item.input_correlation,
                aic=float(aic),
                in_top_set=bool(tied[index]),
            )
        )
    entries.sort(key=_order_key)
    top_set = tuple(entry.name for entry in entries if entry.in_top_set)
    top_indices = [index for index in range(len(evidence)) if tied[index]]
    confidence = float(np.mean(np.isin(winners, top_indices)))
    detected = rule is not None and rule.detects(float(observed[best]), float(lower_bounds[best]))
    return Ranking(entries, top_set, confidence, detected)
