"""Ranking candidate effects on withheld data, with bootstrap confidence and indistinguishable sets.

Inputs are per-run normalised squared residuals (run = a withheld manoeuvre or tunnel point).
Closure = 1 - gap_after / gap_before, gap = sqrt(sum of normalised squared residuals / count).
Order: held-out closure first; candidates the withheld data cannot separate from the best form
the top *set* and are ordered among themselves by the drop of the residual-input correlation,
then by AIC on the training data (which assumes white residuals, so it only breaks ties).

The held-out runs here are the *validation* runs: they choose, and the gap's shrinking is reported
on separate test runs (:mod:`ornitail.gap.report`).

Tied with the best: the best candidate's closure exceeds the other's in fewer than
:data:`SEPARATION_PROBABILITY` of the bootstrap resamples of the validation runs, or the two
closures differ by less than :data:`IDENTICAL_CLOSURE` (the same model family, e.g. added mass and
I_yy). An effect is *detected* when the calibrated rule (:mod:`ornitail.gap.detection`) accepts the
best validation closure and its *simultaneous lower bound*.

Simultaneous lower bound: the best of several candidates on the same validation runs is the one those
runs flattered most (the winner's curse), so its own 5 % bootstrap quantile is too high a bound. The
bound is built in two steps (Romano, Shaikh and Wolf's two-step method for moment inequalities):
1. the *contenders*, the candidates these runs could have made the winner: those whose 99.5 % resample
   quantile (:data:`CONTENDER_LEVEL`) reaches the best closure. Candidates far below are left out so
   that they do not widen the bound (the idea of Hansen's test for superior predictive ability);
2. a studentised max-statistic bootstrap over them (Romano and Wolf): in each resample of the runs,
   each contender's shortfall (c*_j - c_j) / s*_j (c_j the observed closure, c*_j the resample's,
   s*_j the resample's own delta-method standard error, :func:`closures_and_standard_errors`), and
   t, the 95.5 % quantile of the largest of them (5 % less the 0.5 % the first step may cost).
Each candidate's bound is c_j - t s_j, with s_j its standard error on the observed runs; the
contenders' bounds hold together in about 95 % of flights, whichever of them wins. Studentising each
resample carries the skew of few, heavy-tailed runs, which the percentile bootstrap misses (its 5 %
quantile of one candidate covers 0.89 on 16 skewed runs, the studentised bound 0.94).

No bound lies below the candidate's worst single validation run: a ratio of sums over runs lies
between its runs' ratios, so a flight of runs like these closes at least that much. It matters with
few runs (a 16-run flight's first fold validates on 4): there the studentised quantile is dominated
by resamples of one or two runs whose standard error is near zero (with 3 runs or fewer it is
infinite), and the bound would say nothing. The floor is itself the best of the runs' luck: with 4
runs and 8 equally good candidates the winner's bound covers only 0.48 of draws (0.87 alone); the
few-run limit in docs/gap-diagnosis.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.gap.detection import DetectionRule
from ornitail.gap.intervals import closures_and_standard_errors
from ornitail.gap.magnitude_fit import bound_side

BOOTSTRAP_RESAMPLES = 1000
SEPARATION_PROBABILITY = 0.95
SIMULTANEOUS_LEVEL = 0.05  # the lower bounds fail together in 5 % of resamples
CONTENDER_LEVEL = 0.005  # of which the first step (who could have won) may spend this much
IDENTICAL_CLOSURE = 0.005


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


def _simultaneous_lower_bounds(
    baseline_sse: np.ndarray,
    heldout_sse: np.ndarray,
    weights: np.ndarray,
    observed: np.ndarray,
    resampled: np.ndarray,
) -> np.ndarray:
    """Lower bounds (K,) that hold together for the contenders (module docstring), from the
    per-run energies (``baseline_sse`` (R,), ``heldout_sse`` (K, R)), the resamples' run counts
    ``weights`` (B, R), the observed closures (K,) and the resampled ones (B, K). A candidate whose
    closure does not vary over the runs keeps its closure and widens no other's. No bound lies below
    the candidate's worst single run (module docstring)."""
    runs = len(baseline_sse)
    _, (error,) = closures_and_standard_errors(np.ones((1, runs)), baseline_sse, heldout_sse)
    _, resampled_error = closures_and_standard_errors(weights, baseline_sse, heldout_sse)
    varies = np.isfinite(error) & (error > 0)
    best = np.max(observed)
    contenders = varies & (np.quantile(resampled, 1.0 - CONTENDER_LEVEL, axis=0) >= best)
    if not contenders.any():
        return observed.copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        pivot = (resampled[:, contenders] - observed[contenders]) / resampled_error[:, contenders]
        worst_run = np.nanmin(1.0 - np.sqrt(heldout_sse / baseline_sse[None, :]), axis=1)
    # a resample of one run repeated has no standard error: its shortfall is infinite (0 where it
    # reproduces the observed closure); where such resamples pass the level (3 runs or fewer) the
    # width is infinite and the worst single run is the bound
    largest = np.max(np.nan_to_num(pivot, nan=0.0, posinf=np.inf, neginf=-np.inf), axis=1)
    with np.errstate(invalid="ignore"):
        width = np.nan_to_num(
            np.quantile(largest, 1.0 - (SIMULTANEOUS_LEVEL - CONTENDER_LEVEL)), nan=np.inf
        )
        bounds = np.maximum(observed - width * error, worst_run)
    return np.where(varies, bounds, observed)


def _order_key(entry: RankedEffect) -> tuple[int, float, float]:
    """Top set by input-correlation drop (to 1e-3), then AIC; the rest by held-out closure."""
    if entry.in_top_set:
        return (0, -round(entry.input_correlation_drop, 3), entry.aic)
    return (1, -entry.heldout_closure, 0.0)


def rank_candidates(
    evidence: list[CandidateEvidence],
    baseline_heldout_sse: np.ndarray,
    baseline_training_sse: float,
    baseline_input_correlation: float,
    training_count: int,
    seed: int = 0,
    rule: DetectionRule | None = None,
) -> Ranking:
    """Rank ``evidence`` (see the module docstring); ``training_count`` = training samples.

    ``rule`` decides detection; without one (ranking only to choose, e.g. inside a nested
    cross-validation) nothing is detected.
    """
    runs = len(baseline_heldout_sse)
    generator = np.random.default_rng(seed)
    weights = generator.multinomial(runs, np.full(runs, 1.0 / runs), size=BOOTSTRAP_RESAMPLES)
    heldout = np.array([item.heldout_sse for item in evidence])  # (K, R)
    observed = _closures(np.array(baseline_heldout_sse.sum()), heldout.sum(axis=1))
    resampled = _closures(weights @ baseline_heldout_sse, weights @ heldout.T)  # (B, K)
    best = int(np.argmax(observed))
    winners = np.argmax(resampled, axis=1)
    tied = np.array(
        [
            index == best
            or np.mean(resampled[:, best] > resampled[:, index]) < SEPARATION_PROBABILITY
            or observed[best] - observed[index] < IDENTICAL_CLOSURE
            for index in range(len(evidence))
        ]
    )
    lower_bounds = _simultaneous_lower_bounds(
        baseline_heldout_sse, heldout, weights, observed, resampled
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
                probability_best=float(np.mean(winners == index)),
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
