"""Gap before and after an effect, per channel, with bootstrap intervals over test runs.

gap (per channel) = sqrt(sum over runs of squared normalised residuals / samples): the residual's
RMS in units of the channel's scale (tunnel and steady data: the measured signal's standard deviation
or the value's standard error; flight: the baseline's run-to-run residual spread, the noise level);
the total gap pools the channels.
Intervals are the 5-95 % quantiles over resamples of the test runs (with replacement); they are
conditional on the chosen effect and its fitted magnitude, which the resamples keep. They describe the
closure of these runs' population. A fresh flight's closure scatters on its own as well: its 90 %
prediction interval (:func:`fresh_data_interval`, a studentised bootstrap, because run energies are
skewed and heavy-tailed) adds that scatter, for a flight of as many runs. Like the others it is
conditional on the chosen effect and its fitted magnitude: the four folds' fitted models differ far
less on a fresh flight (closures within 0.006 in the benchmark cases checked) than fresh flights do.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

RESAMPLES = 1000


def _resample_weights(runs: int, seed: int) -> np.ndarray:
    """(RESAMPLES, runs) counts of each run in each resample with replacement."""
    return np.random.default_rng(seed).multinomial(runs, np.full(runs, 1.0 / runs), size=RESAMPLES)


def gap_with_interval(
    channel_sse: np.ndarray, counts: np.ndarray, channels: Sequence[str], seed: int = 0
) -> dict[str, object]:
    """``channel_sse`` (runs, channels) normalised squared residuals, ``counts`` samples per run."""
    weights = _resample_weights(len(counts), seed)
    per_channel = {}
    resampled_counts = weights @ counts
    for index, channel in enumerate(channels):
        value = np.sqrt(channel_sse[:, index].sum() / counts.sum())
        resampled = np.sqrt(weights @ channel_sse[:, index] / resampled_counts)
        per_channel[channel] = {
            "value": float(value),
            "interval": np.quantile(resampled, [0.05, 0.95]).tolist(),
        }
    total = np.sqrt(channel_sse.sum() / (counts.sum() * len(channels)))
    resampled_total = np.sqrt(
        weights @ channel_sse.sum(axis=1) / (resampled_counts * len(channels))
    )
    return {
        "total": float(total),
        "interval": np.quantile(resampled_total, [0.05, 0.95]).tolist(),
        "per_channel": per_channel,
    }


def _resampled_closures(before_sse: np.ndarray, after_sse: np.ndarray, seed: int) -> np.ndarray:
    """Closures of :data:`RESAMPLES` paired resamples of the runs (with replacement)."""
    weights = _resample_weights(len(before_sse), seed)
    with np.errstate(divide="ignore", invalid="ignore"):
        return 1.0 - np.sqrt((weights @ after_sse) / (weights @ before_sse))


def closure_with_interval(
    before_sse: np.ndarray, after_sse: np.ndarray, seed: int = 0
) -> tuple[float, list[float]]:
    """Closure 1 - gap_after / gap_before over runs (``before_sse``, ``after_sse``: normalised
    squared residual per run, same samples per run in both) and its paired 5-95 % bootstrap
    interval over the runs (the same resamples as :func:`gap_with_interval` with this seed)."""
    resampled = _resampled_closures(before_sse, after_sse, seed)
    return _closure(before_sse, after_sse), np.quantile(resampled, [0.05, 0.95]).tolist()


def _closure(before_sse: np.ndarray, after_sse: np.ndarray) -> float:
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(1.0 - np.sqrt(after_sse.sum() / before_sse.sum()))


def closures_and_standard_errors(
    weights: np.ndarray, before_sse: np.ndarray, after_sse: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Closure and its delta-method standard error for each row of run ``weights`` (B, runs
    counts) and each candidate (``after_sse`` (runs,) for one, giving (B,); (K, runs) for K,
    giving (B, K)).

    With A and B the weighted sums of after and before and r = sqrt(A / B), run i's influence on
    the closure 1 - r is -(r / 2) n (a_i / A - b_i / B); the standard error is the influences'
    weighted standard deviation over sqrt(n) (n = the row's total count).
    """
    after_rows = np.atleast_2d(after_sse)  # (K, R)
    runs = weights.sum(axis=1)[:, None]  # (B, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        after = weights @ after_rows.T  # (B, K)
        before = (weights @ before_sse)[:, None]  # (B, 1)
        ratio = np.sqrt(after / before)
        influence = -(ratio * runs / 2)[:, :, None] * (
            after_rows[None, :, :] / after[:, :, None] - (before_sse[None, :] / before)[:, None, :]
        )  # (B, K, R)
        counts = weights[:, None, :]
        mean = (counts * influence).sum(axis=2) / runs
        variance = (counts * (influence - mean[:, :, None]) ** 2).sum(axis=2) / runs
        closure, error = 1.0 - ratio, np.sqrt(variance / runs)
    if np.ndim(after_sse) == 1:
        return closure[:, 0], error[:, 0]
    return closure, error


def fresh_data_interval(
    before_sse: np.ndarray, after_sse: np.ndarray, seed: int = 0, fresh_runs: int | None = None
) -> list[float]:
    """90 % prediction interval of the closure new data of ``fresh_runs`` runs (a fresh flight;
    default: as many runs as these) will show with the same model and weights.

    A studentised bootstrap of the prediction (bootstrap-t): the pivot is the difference between a
    fresh flight's closure and this one's, in units of this flight's standard error s (delta
    method, :func:`closures_and_standard_errors`) times sqrt(1 + n / m). Its distribution is read off
    pairs of independent resamples of the runs, one of n runs playing these runs (with its own
    standard error) and one of m runs playing the fresh flight; the interval is the closure plus
    the pivot's 5 and 95 % quantiles times s sqrt(1 + n / m) sqrt(n / (n - 1)) (the last factor
    for the resamples' shrinkage on few runs, as the closure interval's bootstrap has it).

    Why not the closure +- Student's t (n - 1) times the bootstrap spread (the method before):
    run energies are skewed and heavy-tailed (a run holding a strong disturbance that no effect
    explains carries 2-9 x the median energy), so the spread of 16 runs is usually an
    underestimate and a flight's closure scatters lopsidedly (low when it holds such a run), which
    t, exact only for normally distributed runs, ignores. That, not the fitted model, is what the
    fresh flights the old interval missed differed in (docs/gap-diagnosis.md, *Closure on new
    data*): 0.90 of flight pairs in benchmark replays fall inside this interval, 0.86 inside the
    old one, when the diagnosed flight gives it. Studentising each resample by its own standard
    error carries how uncertain that spread is on these very runs, and keeps the skew. It assumes the
    runs of both flights are alike (the same manoeuvres, disturbance and noise), not that the
    model is right; it cannot foresee a kind of disturbance none of these runs holds. The
    interval is kept within the closures of the worst and the best single run, the range a flight
    of such runs can reach (the pivot, unbounded, steps outside it when one run dominates).
    """
    runs = len(before_sse)
    fresh = runs if fresh_runs is None else fresh_runs
    observed = _closure(before_sse, after_sse)
    _, (error,) = closures_and_standard_errors(np.ones((1, runs)), before_sse, after_sse)
    these, these_error = closures_and_standard_errors(
        _resample_weights(runs, seed), before_sse, after_sse
    )
    new = np.random.default_rng([seed, 1]).multinomial(
        fresh, np.full(runs, 1.0 / runs), size=RESAMPLES
    )
    fresh_closure, _ = closures_and_standard_errors(new, before_sse, after_sse)
    scale = np.sqrt(1.0 + runs / fresh)
    with np.errstate(divide="ignore", invalid="ignore"):
        pivot = (fresh_closure - these) / (these_error * scale)
    pivot = pivot[np.isfinite(pivot)]
    if not (np.isfinite(error) and error > 0 and pivot.size):
        return [observed, observed]  # every run closes alike: nothing to scatter
    low, high = np.quantile(pivot, [0.05, 0.95]) * error * scale * np.sqrt(runs / max(runs - 1, 1))
    # a flight of runs like these closes between its worst and its best run (a ratio of sums lies
    # between the ratios): the pivot, unbounded, can step outside when one run dominates
    with np.errstate(divide="ignore", invalid="ignore"):
        per_run = 1.0 - np.sqrt(after_sse / before_sse)
    per_run = per_run[np.isfinite(per_run)]
    return [
        float(max(observed + low, per_run.min())),
        float(min(observed + high, per_run.max())),
    ]
