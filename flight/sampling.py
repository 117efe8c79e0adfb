"""Uniform sampling of a log's time column, up to rounding and jitter.

Real logs carry timestamps that are a uniform grid ``t0 + i dt`` only approximately: written
with a few decimals (rounded), or stamped by a clock with jitter. A time column is accepted as
uniformly sampled when

- every step is positive and between 0.5 and 1.5 sample intervals (otherwise a sample is doubled
  or missing: refused, naming the row), and
- every timestamp lies within the tolerance of the least-squares line ``t0 + i dt`` through
  time against sample index: the larger of a quarter sample interval (jitter) and the column's
  decimal resolution (rounding; 1 ms for a clock logged in milliseconds).

``dt`` is that line's slope: unbiased by rounding and jitter, unlike the median step. Samples are
then treated as lying on the grid; their logged timestamps are not used further.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.core.errors import UserInputError

JITTER_TOLERANCE = 0.25  # largest deviation from the grid allowed for jitter, in intervals
DOUBLED_STEP = 0.5  # a step of at most this many intervals means a doubled sample
MISSING_STEP = 1.5  # a step of at least this many intervals means a missing sample
_DECIMALS_TRIED = range(10)  # resolutions 1 s ... 1 ns
_ON_RESOLUTION = 1e-3  # a timestamp within this fraction of a quantum lies on the resolution


@dataclass(frozen=True)
class UniformGrid:
    """The uniform grid of a time column: ``start_s + i * step_s`` for ``count`` samples."""

    start_s: float
    step_s: float
    count: int

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.step_s

    def times_s(self) -> np.ndarray:
        """The grid's timestamps (s)."""
        return self.start_s + self.step_s * np.arange(self.count)


def time_resolution_s(time_s: np.ndarray) -> float:
    """The coarsest decimal quantum (1, 0.1, ... 1e-9 s) every timestamp (s) is a multiple of,
    or 0.0 when none is (full-precision or jittered timestamps).
    """
    largest = float(np.max(np.abs(time_s)))
    for decimals in _DECIMALS_TRIED:
        quantum = 10.0**-decimals
        if largest / quantum > 1e12:  # beyond float64's resolution of the quantum
            break
        scaled = time_s / quantum
        if np.max(np.abs(scaled - np.round(scaled))) <= _ON_RESOLUTION:
            return quantum
    return 0.0


def _refuse_out_of_order(time_s: np.ndarray, where: str, first_row: int) -> None:
    steps = np.diff(time_s)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        row = first_row + int(bad[0]) + 1
        raise UserInputError(
            where,
            f"time does not increase at row {row} ({time_s[bad[0] + 1]:.9g} s after "
            f"{time_s[bad[0]]:.9g} s): a doubled or out-of-order sample",
        )


def _refuse_uneven_steps(time_s: np.ndarray, step_s: float, where: str, first_row: int) -> None:
    ratios = np.diff(time_s) / step_s
    outside = (ratios <= DOUBLED_STEP) | (ratios >= MISSING_STEP)
    if not outside.any():
        return
    worst = int(np.argmax(np.where(outside, np.abs(ratios - 1.0), -np.inf)))
    row = first_row + worst + 1
    kind = "sample(s) missing before" if ratios[worst] >= MISSING_STEP else "a doubled sample at"
    raise UserInputError(
        where,
        f"{kind} row {row} (t = {time_s[worst + 1]:.9g} s): it comes {ratios[worst]:.2f} "
        f"sample intervals of {step_s:.6g} s after the row before",
    )


def uniform_grid(time_s: np.ndarray, where: str, first_row: int = 1) -> UniformGrid:
    """The uniform grid of a finite time column (s), or a refusal naming the worst row.

    ``where`` names the file and column; ``first_row`` is the row number of ``time_s[0]`` in
    the user's file (1 = first data row).
    """
    time_s = np.asarray(time_s, dtype=float)
    if time_s.size < 3:
        raise UserInputError(where, f"{time_s.size} samples: too few to tell the sample interval")
    _refuse_out_of_order(time_s, where, first_row)
    index = np.arange(time_s.size) - 0.5 * (time_s.size - 1)
    step_s = float(np.dot(index, time_s) / np.dot(index, index))
    start_s = float(np.mean(time_s) - step_s * 0.5 * (time_s.size - 1))
    _refuse_uneven_steps(time_s, step_s, where, first_row)
    grid = UniformGrid(start_s, step_s, time_s.size)
    deviations = time_s - grid.times_s()
    tolerance_s = max(JITTER_TOLERANCE * step_s, time_resolution_s(time_s))
    worst = int(np.argmax(np.abs(deviations)))
    if abs(deviations[worst]) > tolerance_s:
        raise UserInputError(
            where,
            f"row {first_row + worst} (t = {time_s[worst]:.9g} s) lies "
            f"{deviations[worst] / step_s:+.2f} sample intervals off the uniform grid of "
            f"{step_s:.6g} s (tolerance {tolerance_s / step_s:.2f}); resample the log first",
        )
    return grid
