"""Flapping-cycle boundaries from the Hall-sensor line.

The Hall sensor fires once per flap on a magnet on the flapping mechanism. Its line is read as a voltage;
rising edges are found with hysteresis (a sample must rise above ``high_threshold_v`` after having been below
``low_threshold_v``), timed to a fraction of a sample by linear interpolation at the mid level, and thinned by a
lock-out window so that ringing or a glitch right after an edge is not a second flap. Consecutive edges bound a
cycle; cycles whose period departs from the median by more than ``max_period_deviation`` (a missed pulse, a
glitch outside the lock-out) are rejected, and the partial cycles before the first and after the last edge are
never used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.core.errors import UserInputError


@dataclass(frozen=True)
class HallEdgeSettings:
    """Thresholds and windows for Hall edge detection.

    Attributes
    ----------
    low_threshold_v, high_threshold_v : float
        Hysteresis band of the Hall line, volts.
    lockout_s : float
        After an accepted edge, further edges within this time are ignored, seconds. Must be shorter than the
        shortest flap period expected (a DelFly flaps at 10-17 Hz, 59-100 ms per cycle).
    max_period_deviation : float
        Cycles whose period differs from the median period by more than this fraction are rejected.
    minimum_cycles : int
        Fewer accepted cycles than this is refused: the average would not be meaningful.
    """

    low_threshold_v: float = 1.0
    high_threshold_v: float = 2.0
    lockout_s: float = 0.02
    max_period_deviation: float = 0.20
    minimum_cycles: int = 5


@dataclass(frozen=True)
class FlapCycles:
    """Accepted flapping cycles of one record.

    Attributes
    ----------
    start_s, end_s : numpy.ndarray
        Start and end time of each accepted cycle, seconds from the first sample (sub-sample resolution).
    edge_times_s : numpy.ndarray
        Every accepted rising edge, seconds.
    rejected_count : int
        Cycles between consecutive edges that failed the period check.
    """

    start_s: np.ndarray
    end_s: np.ndarray
    edge_times_s: np.ndarray
    rejected_count: int

    @property
    def period_s(self) -> np.ndarray:
        """Period of each accepted cycle, seconds."""
        return self.end_s - self.start_s

    @property
    def mean_frequency_hz(self) -> float:
        """Flapping frequency over all accepted cycles, hertz: their number over their summed periods. Between
        contiguous cycles an edge's timing error cancels (one cycle ends where the next starts), so this is far
        steadier than the mean of the per-cycle frequencies (on a 0.6 s record at 10 kHz, 0.001 Hz against
        0.007 Hz)."""
        return float(1.0 / self.period_s.mean())

    @property
    def frequency_hz(self) -> np.ndarray:
        """Flapping frequency of each accepted cycle, hertz."""
        return 1.0 / self.period_s

    def __len__(self) -> int:
        return len(self.start_s)


def rising_edge_times(
    hall_v: np.ndarray, sample_rate_hz: float, settings: HallEdgeSettings
) -> np.ndarray:
    """Times of the rising edges of the Hall line, seconds from the first sample.

    Parameters
    ----------
    hall_v : numpy.ndarray
        Hall line, volts, one value per sample.
    sample_rate_hz : float
        Sampling rate, hertz.
    settings : HallEdgeSettings
        Thresholds and lock-out window.
    """
    hall_v = np.asarray(hall_v, dtype=float)
    if not np.all(np.isfinite(hall_v)):
        raise UserInputError("hall_v", "the Hall line contains NaN or infinite samples")
    # Hysteresis state: 1 above high, 0 below low, carried forward in between.
    level = np.full(hall_v.shape, -1, dtype=np.int8)
    level[hall_v >= settings.high_threshold_v] = 1
    level[hall_v <= settings.low_threshold_v] = 0
    defined = np.flatnonzero(level >= 0)
    if defined.size == 0:
        return np.empty(0)
    last_defined = np.maximum.accumulate(np.where(level >= 0, np.arange(level.size), defined[0]))
    state = level[last_defined]
    state[: defined[0]] = state[defined[0]]
    candidates = np.flatnonzero((state[1:] == 1) & (state[:-1] == 0)) + 1
    # Sub-sample time of the mid-level crossing on the rising flank just before each candidate.
    middle_v = 0.5 * (settings.low_threshold_v + settings.high_threshold_v)
    above_middle = hall_v >= middle_v
    crossing_times = np.empty(candidates.size)
    for index, sample in enumerate(candidates):
        after = sample
        while after > 0 and above_middle[after - 1]:
            after -= 1
        before = max(after - 1, 0)
        rise = hall_v[after] - hall_v[before]
        fraction = (middle_v - hall_v[before]) / rise if rise > 0 else 0.0
        crossing_times[index] = before + fraction
    crossing_times /= sample_rate_hz
    accepted: list[float] = []
    for time_s in crossing_times:
        if not accepted or time_s - accepted[-1] >= settings.lockout_s:
            accepted.append(time_s)
    return np.asarray(accepted)


def flap_cycles(
    hall_v: np.ndarray, sample_rate_hz: float, settings: HallEdgeSettings | None = None
) -> FlapCycles:
    """Accepted flapping cycles of a record, from its Hall line.

    Raises
    ------
    UserInputError
        If fewer than ``settings.minimum_cycles`` cycles are accepted.
    """
    settings = settings or HallEdgeSettings()
    edges = rising_edge_times(hall_v, sample_rate_hz, settings)
    if edges.size < 2:
        raise UserInputError(
            "hall_v",
            f"found {edges.size} Hall edge(s) in {len(hall_v) / sample_rate_hz:.3g} s; "
            "is the motor running and the Hall line connected?",
        )
    starts, ends = edges[:-1], edges[1:]
    periods = ends - starts
    median_period = float(np.median(periods))
    keep = np.abs(periods - median_period) <= settings.max_period_deviation * median_period
    if int(keep.sum()) < settings.minimum_cycles:
        raise UserInputError(
            "hall_v",
            f"only {int(keep.sum())} whole flapping cycle(s) accepted, at least "
            f"{settings.minimum_cycles} needed; record longer",
        )
    return FlapCycles(
        start_s=starts[keep],
        end_s=ends[keep],
        edge_times_s=edges,
        rejected_count=int((~keep).sum()),
    )
