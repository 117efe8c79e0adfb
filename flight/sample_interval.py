"""The longest sample interval a flight log may have: a guard against time columns in milliseconds.

A flight log whose time column is in milliseconds looks like a log sampled 1000 times slower (a 512 Hz
log gives a sample interval of 1.95 "s" instead of 1.95 ms), and every rate, frequency and derivative
identified from it would be off by that factor. Flight dynamics need at least 10 samples per second,
so a sample interval above :data:`MAX_SAMPLE_INTERVAL_S` is refused (docs/model-files.md,
docs/flight-campaign.md).
"""

from __future__ import annotations

import numpy as np

from ornitail.core.errors import UserInputError

MAX_SAMPLE_INTERVAL_S = 0.1
"""Longest sample interval accepted in a flight log, s (10 Hz)."""


def refuse_long_sample_interval(step_s: float, where: str, remedy: str) -> None:
    """Refuse a sample interval above :data:`MAX_SAMPLE_INTERVAL_S`; ``remedy`` says what to fix."""
    if not step_s <= MAX_SAMPLE_INTERVAL_S:  # NaN and inf too: a time column beyond float range
        raise UserInputError(
            where,
            f"sample interval {step_s:.6g} s is longer than {MAX_SAMPLE_INTERVAL_S:g} s "
            f"(fewer than {1 / MAX_SAMPLE_INTERVAL_S:g} samples per second): is the time in "
            f"milliseconds? {remedy}",
        )


MAX_ABS_TIME_S = 1e15
"""Largest |time| accepted in a flight log's time column, s (clock counts beyond this lose precision)."""


def refuse_huge_times(time_s: np.ndarray, where: str) -> None:
    """Refuse a time column with values beyond :data:`MAX_ABS_TIME_S` (no grid can be fitted)."""
    largest = float(np.max(np.abs(time_s))) if np.size(time_s) else 0.0
    if largest > MAX_ABS_TIME_S:
        raise UserInputError(
            where, f"time values up to {largest:.3g} are beyond +-{MAX_ABS_TIME_S:g} s"
        )
