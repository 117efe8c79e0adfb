"""A device's sample counter mapped to host time: a straight line under the arrival times (the lower envelope).

A device with its own sample clock (the ORNI-DAQ9 board beside another balance, the Net F/T's ``ft_sequence``) stamps
nothing; the host knows only when each block arrived. Arrival = sampling time + transport latency, and the latency is
never negative, so the sampling times lie on a line (the device's crystal: an offset and a rate a few tens of ppm off
nominal) *at or below* every arrival. :class:`CounterClockModel` fits that line: the slope through the per-bin minima
of the arrival times (bins of ``BIN_S`` of samples, where the fastest deliveries sit; the median of the slopes
between every two bins, so that bins whose deliveries all stalled do not tilt it), the offset so that the line
touches the lowest arrival of the newest ``OFFSET_WINDOW_S``. What remains is the transport's fastest delivery (its
floor), which timestamps cannot see; the spread of the lowest arrivals above the line (:attr:`ClockFit.envelope_s`)
says how sharply the line is known. Times are in the host clock's seconds (rig time on a simulated rig); counters are
unwrapped (int64, :class:`CounterUnwrapper`).

The line is refitted as arrivals come, so it moves (a faster delivery, a new bin of the slope). While a set point's
record is taken it is held (:meth:`CounterClockModel.hold`): a move of the line inside the record shifts the samples
placed after it against those placed before, which cuts out or repeats that much of a flap and biases the cycle
means.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

WINDOW_S = 60.0
"""Arrivals older than this (in samples of the device) are forgotten: the crystal's rate drifts with temperature."""
BIN_S = 0.25
"""Span of samples per bin whose earliest arrival is one point of the slope fit, s."""
MIN_BINS_FOR_SLOPE = 40
"""Below this many bins (10 s) the nominal rate is used: with bin minima scattered by ~1 ms, a slope from a shorter
span is less exact than the crystal (50-100 ppm)."""
OFFSET_WINDOW_S = 5.0
"""The line is laid under the arrivals of the newest this many seconds (rows are taken near the newest samples),
so an error of the rate moves it by at most rate error x this span (100 ppm: 0.5 ms)."""
CRYSTAL_TOLERANCE_PPM = 200.0
"""How far off nominal a device's crystal can run, ppm: a common part's tolerance and temperature drift are each
within about 50 ppm; twice their sum. A fitted rate beyond it is the host's, not the crystal's (its deliveries lagging
more and more for seconds, as a starved reader does), and is clipped to it: resetting it to the nominal rate instead
made the line jump by the slope's change over the offset window whenever the fit crossed the limit (6.7 ms back and
forth every few tenths of a second at a 1000 ppm limit, on a loaded host), and a jump of the line inside a flap cuts
or repeats that much of the flap's loads."""
COUNTER_MODULUS = 1 << 32
"""The devices' counters are 32-bit and wrap to 0."""
ENVELOPE_QUANTILE = 0.05
"""The envelope's sharpness is the residual this fraction of arrivals lies within."""


@dataclass(frozen=True)
class ClockFit:
    """The fitted line ``time = offset_s + (counter - reference) * period_s`` and how well arrivals follow it.

    jitter_rms_s, jitter_max_s : arrival residuals above the line (transport latency beyond its floor), s.
    envelope_s : the ``ENVELOPE_QUANTILE`` quantile of those residuals, s: the line's own uncertainty.
    """

    reference: int
    offset_s: float
    period_s: float
    nominal_period_s: float
    points: int
    jitter_rms_s: float
    jitter_max_s: float
    envelope_s: float

    @property
    def rate_error_ppm(self) -> float:
        """How much faster than nominal the device's clock runs, ppm."""
        return (self.nominal_period_s / self.period_s - 1.0) * 1e6

    def time_of(self, counters: np.ndarray | float) -> np.ndarray:
        """Host time at which the device took the samples ``counters`` (unwrapped), s."""
        return self.offset_s + (np.asarray(counters, dtype=float) - self.reference) * self.period_s

    def counter_at(self, times_s: np.ndarray | float) -> np.ndarray:
        """Fractional counter the device was at at host times ``times_s``."""
        return self.reference + (np.asarray(times_s, dtype=float) - self.offset_s) / self.period_s


class CounterClockModel:
    """Arrivals of one device's blocks, and the line under them (thread-safe: one thread may add while another
    fits).

    Parameters
    ----------
    nominal_rate_hz : float
        The device's nominal sample rate, samples per host-clock second.
    """

    def __init__(self, nominal_rate_hz: float) -> None:
        self.nominal_period_s = 1.0 / float(nominal_rate_hz)
        self._counters = np.empty(0, dtype=np.int64)
        self._arrivals = np.empty(0, dtype=float)
        self._fit: ClockFit | None = None
        self._held: ClockFit | None = None
        self._lock = threading.Lock()  # the stream's reader adds while a sweep asks for the fit

    def add(self, last_counter: int, arrival_s: float) -> None:
        """One block arrived at ``arrival_s``; ``last_counter`` is its last (newest) sample's unwrapped counter."""
        with self._lock:
            self._counters = np.append(self._counters, np.int64(last_counter))
            self._arrivals = np.append(self._arrivals, float(arrival_s))
            window = int(WINDOW_S / self.nominal_period_s)
            keep = self._counters >= self._counters[-1] - window
            if not keep.all():
                self._counters, self._arrivals = self._counters[keep], self._arrivals[keep]
            self._fit = None

    @property
    def points(self) -> int:
        """Arrivals in the window."""
        return len(self._counters)

    def fit(self) -> ClockFit | None:
        """The line under the arrivals in the window, or the line held by :meth:`hold` (None before the first
        arrival)."""
        with self._lock:
            if self._held is not None:
                return self._held
            if self._fit is None and len(self._counters):
                self._fit = self._fitted()
            return self._fit

    def hold(self) -> None:
        """From now on :meth:`fit` returns the line as it is now (arrivals are still taken in), until
        :meth:`release`; nothing is held before the first arrival."""
        with self._lock:
            if self._fit is None and len(self._counters):
                self._fit = self._fitted()
            self._held = self._fit

    def release(self) -> float:
        """:meth:`fit` follows the arrivals again; how far the line moved while it was held, at the newest arrival's
        counter (the line now minus the held one, s; 0 when nothing was held)."""
        with self._lock:
            held, self._held = self._held, None
            if held is None:
                return 0.0
            if self._fit is None:
                self._fit = self._fitted()
            newest = self._counters[-1]
            return float(self._fit.time_of(newest) - held.time_of(newest))

    def _fitted(self) -> ClockFit:
        reference = int(self._counters[0])
        x = (self._counters - reference).astype(float)
        # residuals against the nominal line; the slope correction is fitted through per-bin minima
        residual = self._arrivals - x * self.nominal_period_s
        bins = np.floor(x / (BIN_S / self.nominal_period_s)).astype(np.int64)
        edges = np.flatnonzero(np.diff(bins)) + 1
        starts = np.concatenate(([0], edges))
        slope = 0.0
        if len(starts) >= MIN_BINS_FOR_SLOPE:
            lowest = np.array(
                [
                    start + int(np.argmin(part))
                    for start, part in zip(starts, np.split(residual, edges), strict=True)
                ]
            )
            limit = CRYSTAL_TOLERANCE_PPM * 1e-6 * self.nominal_period_s
            slope = float(np.clip(_median_slope(x[lowest], residual[lowest]), -limit, limit))
        above = residual - slope * x
        recent = x >= x[-1] - OFFSET_WINDOW_S / self.nominal_period_s
        offset = float(above[recent].min())
        latency = (above - offset)[recent]
        return ClockFit(
            reference=reference,
            offset_s=offset,
            period_s=self.nominal_period_s + slope,
            nominal_period_s=self.nominal_period_s,
            points=int(np.count_nonzero(recent)),
            jitter_rms_s=float(np.sqrt(np.mean(latency**2))),
            jitter_max_s=float(latency.max()),
            envelope_s=float(np.quantile(latency, ENVELOPE_QUANTILE)),
        )


def _median_slope(x: np.ndarray, y: np.ndarray) -> float:
    """Theil-Sen slope: the median of the slopes between every two points (robust to up to ~29 % outliers)."""
    first, second = np.triu_indices(len(x), k=1)
    run = x[second] - x[first]
    valid = run > 0
    return float(np.median((y[second] - y[first])[valid] / run[valid]))


class CounterUnwrapper:
    """A device's 32-bit sample counters, block after block, as one increasing int64 series."""

    def __init__(self) -> None:
        self._last: tuple[int, int] | None = None  # (raw, unwrapped) counter of the newest sample

    def unwrap(self, raw: np.ndarray) -> np.ndarray:
        """(n,) raw counters (the block after the previous one) -> (n,) unwrapped int64 counters."""
        raw = np.asarray(raw, dtype=np.int64)
        if self._last is None:
            last_raw, last = int(raw[0]) - 1, int(raw[0]) - 1
        else:
            last_raw, last = self._last
        steps = np.diff(np.concatenate(([last_raw], raw))) % COUNTER_MODULUS
        unwrapped = last + np.cumsum(steps)
        self._last = (int(raw[-1]), int(unwrapped[-1]))
        return unwrapped
