"""Averages over flapping cycles: per-cycle means and phase-resolved averages.

Both are plain numpy reductions over the sample array (``numpy.add.reduceat`` over blocks of rows for cycle
means, ``numpy.bincount`` for phase bins); a ten-minute, 10 kHz, 9-channel record cycle-averages faster than
numpy's own ``sum(axis=0)`` over it (``benchmarks/cycle_average.py``).
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


BLOCK_ROWS = 16
"""Rows per block in :func:`segment_sums` (a power of two)."""


def _partial_rows_sum(data: np.ndarray, first: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """Sum of rows ``first[i] .. stop[i] - 1`` for spans of at most :data:`BLOCK_ROWS` rows, float64."""
    rows = first[:, None] + np.arange(BLOCK_ROWS)[None, :]
    outside = rows >= stop[:, None]
    gathered = data[np.minimum(rows, len(data) - 1)]
    gathered[outside] = 0
    return gathered.sum(axis=1, dtype=np.float64)


def _block_sums(data: np.ndarray, block_count: int) -> np.ndarray:
    """Column sums of each block of :data:`BLOCK_ROWS` rows, shape (block_count, n_cols), by pairwise halving.

    Each halving adds the first half of every block's rows to the second half; both halves are contiguous runs
    of ``rows x n_cols`` values, so numpy adds long contiguous stretches instead of reducing nine values at a time
    along a strided axis.
    """
    width = data.shape[1]
    sums = data[: block_count * BLOCK_ROWS].reshape(block_count, BLOCK_ROWS * width)
    rows = BLOCK_ROWS
    while rows > 1:
        rows //= 2
        sums = sums[:, : rows * width] + sums[:, rows * width :]
    return sums


def segment_sums(data: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Column sums of ``data`` over row spans ``[bounds[i, 0], bounds[i, 1])``, float64, shape (n_spans, n_cols).

    Numpy reduces a C-ordered (n, 9) array along axis 0 nine values at a time, which is slow. Here the whole
    blocks of :data:`BLOCK_ROWS` rows inside a span are summed through per-block sums (:func:`_block_sums`) and
    their float64 prefix sum; the rows of each span before its first whole block and after its last (fewer than
    a block each) are gathered and added. ``data`` is read once and not copied.
    """
    count = len(data)
    first, stop = bounds[:, 0], bounds[:, 1]
    block_count = count // BLOCK_ROWS
    block_first = np.minimum(-(-first // BLOCK_ROWS), block_count)
    block_stop = np.maximum(stop // BLOCK_ROWS, block_first)
    has_blocks = block_stop > block_first
    # A span holding no whole block is shorter than 2 blocks: split it into two pieces of at most one block.
    head_stop = np.where(has_blocks, block_first * BLOCK_ROWS, np.minimum(first + BLOCK_ROWS, stop))
    tail_first = np.where(has_blocks, block_stop * BLOCK_ROWS, head_stop)
    sums = _partial_rows_sum(data, first, head_stop) + _partial_rows_sum(data, tail_first, stop)
    if block_count:
        prefix = np.zeros((block_count + 1, data.shape[1]))
        np.cumsum(_block_sums(data, block_count), axis=0, dtype=np.float64, out=prefix[1:])
        sums += prefix[block_stop] - prefix[block_first]
    return sums


def cycle_means(samples: np.ndarray, cycles: FlapCycles, sample_rate_hz: float) -> np.ndarray:
    """Mean of every channel over each accepted cycle.

    Parameters
    ----------
    samples : numpy.ndarray
        Shape (n_samples,) or (n_samples, n_channels), any unit; float32 (as recorded) or float64. Sums are
        accumulated in float64.
    cycles : FlapCycles
        Accepted cycles, times in seconds from the first sample.
    sample_rate_hz : float
        Sampling rate, hertz.

    Returns
    -------
    numpy.ndarray
        Shape (n_cycles, n_channels) (or (n_cycles,) for 1-D input), float64, same unit as ``samples``.
    """
    data = np.ascontiguousarray(samples)
    one_dimensional = data.ndim == 1
    data = data.reshape(len(data), -1)
    bounds = _cycle_sample_bounds(cycles, sample_rate_hz, len(data))
    means = segment_sums(data, bounds) / (bounds[:, 1] - bounds[:, 0])[:, None]
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
