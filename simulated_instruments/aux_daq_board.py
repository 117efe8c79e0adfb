"""The simulated ORNI-DAQ9 board as auxiliary acquisition beside a simulated CAN balance, on a clock of its own.

A real board's crystal is neither the host's clock nor the balance's: it starts when ``START`` arrives, runs a few
tens of ppm off nominal, and its counter carries on from wherever it was. This simulator does the same
(``rate_error_ppm``, ``counter_offset``) so that the alignment of :mod:`aligned_balance` is exercised: its sample
``k`` of a stream is taken at simulated time ``start + k / (rate * (1 + rate_error_ppm / 1e6))`` from the tunnel
signals shared with the balance (:meth:`SharedTunnelSignals.samples_at_times`), and :meth:`sample_time_s` gives
that true time of any counter for benchmarks and tests.
"""

from __future__ import annotations

import numpy as np

from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.daq_board import SimulatedDaqBoard
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

DEFAULT_RATE_ERROR_PPM = 80.0
"""The simulated crystal's error: a common 50 ppm part at the edge of its temperature range."""
DEFAULT_COUNTER_OFFSET = 1_234_567
"""Where the simulated board's counter stands at the first START (a board that has streamed before)."""


class SimulatedAuxDaqBoard(SimulatedDaqBoard):
    """An ORNI-DAQ9 simulator whose sample clock is ``rate_error_ppm`` off nominal and whose counter starts at
    ``counter_offset``; other arguments as :class:`SimulatedDaqBoard`."""

    def __init__(
        self,
        signals: SharedTunnelSignals,
        clock: SimulatedClock,
        *,
        rate_error_ppm: float = DEFAULT_RATE_ERROR_PPM,
        counter_offset: int = DEFAULT_COUNTER_OFFSET,
        **board_arguments,
    ) -> None:
        super().__init__(signals, clock, serial_number="SIMAUX01", **board_arguments)
        self.rate_error_ppm = float(rate_error_ppm)
        self._next_counter = int(counter_offset)
        self._stream_counter0 = int(counter_offset)

    @property
    def true_rate_hz(self) -> float:
        """The rate the board really samples at, per simulated second."""
        return self.sample_rate_hz * (1.0 + self.rate_error_ppm * 1e-6)

    def _samples_due(self, elapsed_s: float) -> int:
        return int(elapsed_s * self.true_rate_hz)

    def _sample_signals(self, count: int) -> np.ndarray:
        first = self._samples_due_before - count
        if first == 0:
            self._stream_counter0 = self._next_counter
        times = self._stream_start_s + (first + np.arange(count)) / self.true_rate_hz
        return self.signals.samples_at_times(times)

    def sample_time_s(self, counters: np.ndarray) -> np.ndarray:
        """Simulated time at which the current stream took the samples ``counters`` (unwrapped), s."""
        return (
            self._stream_start_s
            + (np.asarray(counters, dtype=float) - self._stream_counter0) / self.true_rate_hz
        )
