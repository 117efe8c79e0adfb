"""Averages over flapping cycles: per-cycle means and phase-resolved averages.

Both are plain numpy reductions over the sample array (``numpy.add.reduceat`` for cycle means, ``numpy.bincount``
for phase bins), so a ten-minute, 10 kHz record averages in about the time it takes to read it from memory.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.balance.hall_cycles import FlapCycles


def _cycle_sample_bounds(cycles: FlapCycles, sample_rate_hz: float, n_samples: int) -> np.ndarray:
    """First and one-past-last sample index of each cycle, shape (n_cycles, 2)."""
    first = np.ceil(cycles.start_s * sample_rate_hz - 1e-9).astype(np.int64)
    stop = np.ceil(cycles.end_s * sample_rate_hz - 1e-9).astype(np.int64)
    return np.clip(np.column_stack([first, stop]), 0, n_samples)


def cycle_means(samples: np.ndarray, cycles: FlapCycles, sample_rate_hz: float) -> np.ndarray:
    """Mean of every channel over each accepted cycle.

    Parameters
    ----------
    samples : numpy.ndarray
        Shape (n_samples,) or (n_samples, n_channels), any unit.
    cycles : FlapCycles
        Accepted cycles, times in seconds from the first sample.
    sample_rate_hz : float
        Sampling rate, hertz.

    Returns
    -------
    numpy.ndarray
        Shape (n_cycles, n_channels) (or (n_cycles,) for 1-D input), same unit as ``samples``.
    """
    data = np.asarray(samples)
    one_dimensional = data.ndim == 1
    data = data.reshape(len(data), -1)
    bounds = _cycle_sample_bounds(cycles, sample_rate_hz, len(data))
    # One zero row at the end keeps every reduceat index in range when the last cycle ends on the last sample.
    padded = np.vstack([data, np.zeros((1, data.shape[1]), dtype=data.dtype)])
    sums = np.add.reduceat(padded, bounds.ravel(), axis=0)[0::2]
    means = sums / (bounds[:, 1] - bounds[:, 0])[:, None]
    return means[:, 0] if one_dimensional else means


@dataclass(frozen=True)
class PhaseAverage:
    """Phase-resolved average over flapping cycles.

    Attributes
    ----------
    phase : numpy.ndarray
        Centre of each phase bin as a fraction of the cycle, 0 at the Hall edge, shape (n_bins,).
    per_cycle : numpy.ndarray
        Mean of each bin in each cycle, shape (n_cycles, n_bins, n_channels).
    mean, spread : numpy.ndarray
        Mean over cycles and sample standard deviation over cycles per bin, shape (n_bins, n_channels).
    """

    phase: np.ndarray
    per_cycle: np.ndarray
    mean: np.ndarray
    spread: np.ndarray


def phase_average(
    samples: np.ndarray, cycles: FlapCycles, sample_rate_hz: float, n_bins: int = 50
) -> PhaseAverage:
    """Resample every accepted cycle onto ``n_bins`` phase bins and average over cycles.

    A sample belongs to bin ``floor(n_bins * (t - start) / period)`` of its cycle; a bin's value in a cycle is the
    mean of its samples. ``n_bins`` must leave at least one sample per bin.
    """
    data = np.asarray(samples, dtype=float)
    data = data.reshape(len(data), -1)
    bounds = _cycle_sample_bounds(cycles, sample_rate_hz, len(data))
    lengths = bounds[:, 1] - bounds[:, 0]
    if n_bins < 1 or n_bins > int(lengths.min()):
        raise ValueError(
            f"n_bins={n_bins} must be between 1 and the shortest cycle ({lengths.min()} samples)"
        )
    n_cycles = len(bounds)
    cycle_of_sample = np.repeat(np.arange(n_cycles), lengths)
    sample_index = np.concatenate([np.arange(a, b) for a, b in bounds])
    phase = (sample_index / sample_rate_hz - cycles.start_s[cycle_of_sample]) / cycles.period_s[
        cycle_of_sample
    ]
    bin_of_sample = np.clip((phase * n_bins).astype(np.int64), 0, n_bins - 1)
    flat_bin = cycle_of_sample * n_bins + bin_of_sample
    counts = np.bincount(flat_bin, minlength=n_cycles * n_bins).reshape(n_cycles, n_bins)
    per_cycle = np.empty((n_cycles, n_bins, data.shape[1]))
    for channel in range(data.shape[1]):
        sums = np.bincount(
            flat_bin, weights=data[sample_index, channel], minlength=n_cycles * n_bins
        )
        per_cycle[:, :, channel] = sums.reshape(n_cycles, n_bins) / counts
    spread = per_cycle.std(axis=0, ddof=1) if n_cycles > 1 else np.zeros(per_cycle.shape[1:])
    return PhaseAverage(
        phase=(np.arange(n_bins) + 0.5) / n_bins,
        per_cycle=per_cycle,
        mean=per_cycle.mean(axis=0),
        spread=spread,
    )
