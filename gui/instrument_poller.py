"""A thread that reads pitch, tunnel velocity and flapping frequency a few times a second for the display."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.rig import Rig

POLL_INTERVAL_S = 0.2


@dataclass(frozen=True)
class InstrumentReadings:
    """Latest readings (SI): strut pitch (rad), tunnel velocity from the fan (m/s), flapping frequency from the
    motor (Hz), and the monotonic time they were taken (s). NaN where an instrument did not answer."""

    pitch_rad: float = math.nan
    tunnel_velocity_m_s: float = math.nan
    flapping_frequency_hz: float = math.nan
    time_s: float = math.nan


class InstrumentPoller:
    """Reads the line instruments every ``POLL_INTERVAL_S``; keeps the latest values, reports errors once.

    Parameters
    ----------
    rig : Rig
        A connected rig (its connections are locked, so a sweep may use them at the same time).
    on_error : callable
        Called in the poller thread with an :class:`InstrumentError` whenever the error text changes.
    on_recovered : callable
        Called in the poller thread at the first good reading after an error.
    """

    def __init__(
        self,
        rig: Rig,
        on_error: Callable[[InstrumentError], None],
        on_recovered: Callable[[], None] = lambda: None,
    ) -> None:
        self.rig = rig
        self.latest = InstrumentReadings()
        self._on_error = on_error
        self._on_recovered = on_recovered
        self._last_error = ""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="instrument-poller", daemon=True)

    @property
    def failing(self) -> bool:
        """True while the last reading failed."""
        return bool(self._last_error)

    def start(self) -> None:
        """Start polling."""
        self._thread.start()

    def stop(self) -> None:
        """Stop polling and wait for the thread."""
        self._stop.set()
        self._thread.join(timeout=2.0)

    def _run(self) -> None:
        while not self._stop.wait(POLL_INTERVAL_S):
            try:
                self.latest = InstrumentReadings(
                    self.rig.read_pitch_rad(),
                    self.rig.read_tunnel_velocity_m_s(),
                    self.rig.read_flapping_frequency_hz(),
                    time.monotonic(),
                )
                if self._last_error:
                    self._last_error = ""
                    self._on_recovered()
            except InstrumentError as error:
                if str(error) != self._last_error:
                    self._last_error = str(error)
                    self._on_error(error)
            except RuntimeError:  # the rig was closed under us (disconnect)
                return
