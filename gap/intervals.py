"""Gap before and after an effect, per channel, with bootstrap intervals over test runs.

gap (per channel) = sqrt(sum over runs of squared normalised residuals / samples): the residual's
RMS in units of the channel's scale (tunnel and steady data: the measured signal's standard deviation
or the value's standard error; flight: the baseline's run-to-run residual spread, the noise level);
the total gap pools the channels.
Intervals are the 5-95 % quantiles over resamples of the test runs (with replacement); they are
conditional on the chosen effect and its fitted magnitude, which the resamples keep. They describe the
closure of these runs' population. A fresh flight's closure scatters on its own as well: its 90 %
prediction interval (:func:`fresh_data_interval`) adds that scatter, for a flight of as many runs.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import stats

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


def fresh_data_interval(
    before_sse: np.ndarray, after_sse: np.ndarray, seed: int = 0, fresh_runs: int | None = None
) -> list[float]:
    """90 % prediction interval of the closure new data of ``fresh_runs`` runs (a fresh flight;
    default: as many runs as these) will show with the same model and weights.

    The closure of n runs scatters from flight to flight with a standard error s (the paired
    bootstrap's spread, times sqrt(n / (n - 1)) for the bootstrap's shrinkage on few runs); a fresh
    flight of m runs adds its own s * sqrt(n / m), so the difference between the two has the standard
    error s * sqrt(1 + n / m), and the interval is the closure +- Student's t (n - 1 degrees of
    freedom, 95th percentile) times that. It assumes the runs of both flights are alike (the same
    manoeuvres, disturbance and noise), not that the model is right.
    """
    runs = len(before_sse)
    fresh = runs if fresh_runs is None else fresh_runs
    observed = _closure(before_sse, after_sse)
    resampled = _resampled_closures(before_sse, after_sse, seed)
    spread = float(np.std(resampled[np.isfinite(resampled)])) * np.sqrt(runs / max(runs - 1, 1))
    half_width = stats.t.ppf(0.95, max(runs - 1, 1)) * spread * np.sqrt(1.0 + runs / fresh)
    return [observed - half_width, observed + half_width]
