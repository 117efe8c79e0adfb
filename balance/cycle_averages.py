"""Averages over flapping cycles: per-cycle means and phase-resolved averages.

Both are plain numpy reductions over the sample array (``numpy.add.reduceat`` over blocks of rows for cycle
means, ``numpy.bincount`` for phase bins); a ten-minute, 10 kHz, 9-channel record cycle-averages faster than
numpy's own ``sum(axis=0)`` over it (``benchmarks/cycle_average.py``).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ornitail.balance.hall_cycles import FlapCycles


def _cycle_sample_bounds(cycles: FlapCycles, sample_rate_hz: float, n_samples: int) -> np.ndarray:
    """First and one-past-last sample index of each cycle, shape (n_cycles, 2)."""
    first = np.ceil(cycles.start_s * sample_rate_hz - 1e-9).astype(np.int64)
    stop = np.ceil(cycles.end_s * sample_rate_hz - 1e-9).astype(np.int64)
    return np.clip(np.column_stack([first, stop]), 0, n_samples)


BLOCK_ROWS = 64
"""Rows per block in :func:`prefix_sums_at` (even)."""
PARALLEL_MINIMUM_BLOCKS = 16_384
"""Records of at least this many blocks (about 10 s at 10 kHz) have their block sums taken on several threads."""


def _rows_sum(data: np.ndarray, first: np.ndarray, count: np.ndarray, width: int) -> np.ndarray:
    """Sum of rows ``first[i] .. first[i] + count[i] - 1`` (``count <= width``), float64, shape (m, n_cols).

    Gathers one contiguous window of ``width`` rows per span through a strided view (a memory copy of
    ``width x n_cols`` values each) and sums it with 0/1 weights that leave out the rows outside the span.
    """
    width = min(width, len(data))
    windows = np.lib.stride_tricks.as_strided(
        data,
        shape=(len(data) - width + 1, width, data.shape[1]),
        strides=(data.strides[0], data.strides[0], data.strides[1]),
        writeable=False,
    )
    start = np.minimum(first, len(data) - width)
    shift = (first - start)[:, None]
    column = np.arange(width)[None, :]
    inside = (column >= shift) & (column < shift + count[:, None])
    weights = inside.astype(data.dtype)[:, None, :]
    return np.matmul(weights, windows[start])[:, 0, :].astype(np.float64)


def _block_sums(blocks: np.ndarray) -> np.ndarray:
    """Sum over axis 1 of (n_blocks, rows, n_cols), one ``einsum`` per chunk, chunks on parallel threads.

    ``einsum`` releases the GIL, so long records use every core; records under
    :data:`PARALLEL_MINIMUM_BLOCKS` blocks are summed in one call.
    """
    sums = np.empty((blocks.shape[0], blocks.shape[2]), dtype=blocks.dtype)
    workers = min(os.cpu_count() or 1, 8)
    if workers == 1 or len(blocks) < PARALLEL_MINIMUM_BLOCKS:
        return np.einsum("ijk->ik", blocks, out=sums)
    edges = np.linspace(0, len(blocks), 2 * workers + 1).astype(int)

    def sum_chunk(index: int) -> None:
        chunk = slice(edges[index], edges[index + 1])
        np.einsum("ijk->ik", blocks[chunk], out=sums[chunk])

    with ThreadPoolExecutor(max_workers=workers) as pool:
        list(pool.map(sum_chunk, range(len(edges) - 1)))
    return sums


def prefix_sums_at(data: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Column sums of ``data[:p]`` for every ``p`` in ``rows`` (0 <= p <= n), float64, shape (len(rows), n_cols).

    Numpy reduces a C-ordered (n, 9) array along axis 0 nine values at a time, which is slow, and a prefix sum
    of every row would need a float64 copy of the whole record. Instead the record is cut into blocks of
    :data:`BLOCK_ROWS` rows, each block summed in streaming ``einsum`` passes (float32 sums of 64 values), the
    block sums prefix-summed in float64, and each requested prefix completed from the nearer end of its block
    (at most 32 rows gathered). ``data`` is read once and not copied.
    """
    count, width = data.shape
    block_count = count // BLOCK_ROWS
    block_sums = _block_sums(
        data[: block_count * BLOCK_ROWS].reshape(block_count, BLOCK_ROWS, width)
    )
    prefix = np.zeros((block_count + 1, width))
    np.cumsum(block_sums, axis=0, dtype=np.float64, out=prefix[1:])
    block, offset = np.divmod(np.asarray(rows, dtype=np.int64), BLOCK_ROWS)
    half = BLOCK_ROWS // 2
    in_last_part = block >= block_count  # the rows after the last whole block
    forward = (offset <= half) & ~in_last_part
    backward = (offset > half) & ~in_last_part
    result = np.empty((len(block), width))
    result[forward] = prefix[block[forward]] + _rows_sum(
        data, block[forward] * BLOCK_ROWS, offset[forward], half
    )
    result[backward] = prefix[block[backward] + 1] - _rows_sum(
        data, block[backward] * BLOCK_ROWS + offset[backward], BLOCK_ROWS - offset[backward], half
    )
    result[in_last_part] = prefix[block_count] + _rows_sum(
        data,
        np.full(int(in_last_part.sum()), block_count * BLOCK_ROWS),
        offset[in_last_part],
        BLOCK_ROWS,
    )
    return result


def segment_sums(data: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Column sums of ``data`` over row spans ``[bounds[i, 0], bounds[i, 1])``, float64, shape (n_spans, n_cols).

    The difference of two prefix sums (:func:`prefix_sums_at`); neighbouring cycles share a boundary, so each
    boundary's prefix is computed once.
    """
    boundaries, position = np.unique(bounds.ravel(), return_inverse=True)
    prefixes = prefix_sums_at(data, boundaries)
    position = position.reshape(bounds.shape)
    return prefixes[position[:, 1]] - prefixes[position[:, 0]]


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
