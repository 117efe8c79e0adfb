"""What the live plots show, drained from the balance's display feed at each redraw into fixed-size rings.

Balance rows are decimated copies (display only; the recorder gets every row). Forces and moments are body-frame
loads about the rig's reference point, tare-corrected once a wind-off tare was taken; hot-wire velocity uses the
hot-wire law when one is known, temperature comes from the thermocouple amplifier.
"""

from __future__ import annotations

import math

import numpy as np

from ornitail.acquisition.daq_protocol import CHANNEL_NAMES
from ornitail.calibration.hotwire_laws import HotwireLaw
from ornitail.calibration.thermocouple_amplifier import (
    CELSIUS_TO_KELVIN_OFFSET,
    temperature_k_from_amplifier_voltage,
)
from ornitail.gui.rig_session import RigSession
from ornitail.gui.ring_buffer import RingBuffer

BALANCE_WINDOW_S = 10.0
INSTRUMENT_HISTORY_ROWS = 600
HOTWIRE = CHANNEL_NAMES.index("hotwire_bridge_v")
THERMOCOUPLE = CHANNEL_NAMES.index("thermocouple_v")


class LiveData:
    """Rings of the newest balance rows (decimated) and instrument readings, for one session.

    Attributes
    ----------
    balance : RingBuffer
        Columns: counter, then the nine channels of ``CHANNEL_NAMES`` (V).
    instruments : RingBuffer
        Columns: time (s), pitch (rad), tunnel velocity (m/s), flapping frequency (Hz).
    hotwire_law : HotwireLaw or None
        Law for the hot-wire velocity, the one the rig knows (the simulator's for a simulated rig), else None.
    """

    def __init__(self, session: RigSession) -> None:
        self.session = session
        self.balance: RingBuffer | None = None
        self.instruments = RingBuffer(INSTRUMENT_HISTORY_ROWS, 4)
        self.hotwire_law: HotwireLaw | None = None
        self.display_rate_hz = math.nan
        self.rows_received = 0

    def reset_for_rig(self) -> None:
        """Size the rings for the connected rig's rate and pick its hot-wire law."""
        live = self.session.live
        rig = self.session.rig
        if live is None or rig is None:
            return
        self.display_rate_hz = live.sample_rate_hz / live.display_feed.decimation
        self.balance = RingBuffer(
            int(BALANCE_WINDOW_S * self.display_rate_hz), 1 + len(CHANNEL_NAMES)
        )
        self.instruments.clear()
        self.hotwire_law = rig.hotwire_law()

    def update(self) -> int:
        """Drain the display feed and take the latest readings; return the balance rows added."""
        live = self.session.live
        added = 0
        if live is not None and self.balance is not None:
            for counters, samples in live.display_feed.take_all():
                self.balance.extend(np.column_stack([counters, samples]))
                added += len(counters)
        readings = self.session.readings
        if math.isfinite(readings.time_s):
            latest = self.instruments.latest(1)
            if not len(latest) or latest[0, 0] != readings.time_s:
                self.instruments.extend(
                    [
                        readings.time_s,
                        readings.pitch_rad,
                        readings.tunnel_velocity_m_s,
                        readings.flapping_frequency_hz,
                    ]
                )
        self.rows_received += added
        return added

    def volts(self, seconds: float | None = None) -> np.ndarray:
        """Newest balance rows (n, 9) in V, the last ``seconds`` of display data (all by default)."""
        if self.balance is None:
            return np.zeros((0, len(CHANNEL_NAMES)))
        rows = None if seconds is None else int(seconds * self.display_rate_hz)
        return self.balance.latest(rows)[:, 1:]

    def loads(self, volts: np.ndarray) -> np.ndarray:
        """Body-frame loads (n, 6): X, Y, Z (N), L, M, N (N m), tare-corrected once a tare exists."""
        calibration = self.session.calibration
        if calibration is None or not len(volts):
            return np.zeros((len(volts), 6))
        tare = self.session.tare_volts
        return calibration.forces_from_voltages(
            volts[:, :6], tare if tare is not None else np.zeros(6)
        )

    def temperature_c(self, volts: np.ndarray) -> np.ndarray:
        """Flow temperature from the thermocouple channel, degC."""
        if not len(volts):
            return np.zeros(0)
        return (
            np.asarray(temperature_k_from_amplifier_voltage(volts[:, THERMOCOUPLE]))
            - CELSIUS_TO_KELVIN_OFFSET
        )

    def hotwire_velocity_m_s(self, volts: np.ndarray) -> np.ndarray | None:
        """Hot-wire velocity (m/s), temperature-corrected; None without a hot-wire law."""
        if self.hotwire_law is None or not len(volts):
            return None
        temperature_k = self.temperature_c(volts) + CELSIUS_TO_KELVIN_OFFSET
        return np.asarray(self.hotwire_law.velocity_from_voltage(volts[:, HOTWIRE], temperature_k))
