"""Gap before and after an effect, per channel, with bootstrap intervals over test runs.

gap (per channel) = sqrt(sum over runs of squared normalised residuals / samples): the residual's
RMS in units of the channel's scale (tunnel and steady data: the measured signal's standard deviation
or the value's standard error; flight: the baseline's run-to-run residual spread, the noise level);
the total gap pools the channels.
Intervals are the 5-95 % quantiles over resamples of the test runs (with replacement); they are
conditional on the chosen effect and its fitted magnitude, which the resamples keep.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

RESAMPLES = 1000


def gap_with_interval(
    channel_sse: np.ndarray, counts: np.ndarray, channels: Sequence[str], seed: int = 0
) -> dict[str, object]:
    """``channel_sse`` (runs, channels) normalised squared residuals, ``counts`` samples per run."""
    runs = len(counts)
    weights = np.random.default_rng(seed).multinomial(
        runs, np.full(runs, 1.0 / runs), size=RESAMPLES
    )
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


def closure_with_interval(
    before_sse: np.ndarray, after_sse: np.ndarray, seed: int = 0
) -> tuple[float, list[float]]:
    """Closure 1 - gap_after / gap_before over runs (``before_sse``, ``after_sse``: normalised
    squared residual per run, same samples per run in both) and its paired 5-95 % bootstrap
    interval over the runs (the same resamples as :func:`gap_with_interval` with this seed)."""
    runs = len(before_sse)
    weights = np.random.default_rng(seed).multinomial(
        runs, np.full(runs, 1.0 / runs), size=RESAMPLES
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        observed = 1.0 - np.sqrt(after_sse.sum() / before_sse.sum())
        resampled = 1.0 - np.sqrt((weights @ after_sse) / (weights @ before_sse))
    return float(observed), np.quantile(resampled, [0.05, 0.95]).tolist()
