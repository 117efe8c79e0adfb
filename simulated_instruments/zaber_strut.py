"""Simulated Zaber-style ASCII motion controller moving the strut, behind a pty, driving the tunnel simulator.

Speaks the subset of the Zaber ASCII protocol the ``zaber_ascii`` backend uses (:mod:`zaber_ascii`): ``get
device.id``, ``home``, ``move abs <counts>``, ``get pos``, ``stop``, ``estop``. Replies end with CR LF. It moves at
``speed_counts_per_s``; until homed it carries the flag ``WR`` (no reference position) and refuses ``move abs``
(``RJ ... BADCOMMAND``, this simulator's choice); a position beyond its travel is refused ``RJ ... BADDATA``, an
unknown command ``BADCOMMAND``, another axis ``BADAXIS``. Messages for another device address get no reply.
The pitch it publishes is converted from its position with the rig file's ``[strut.zaber]`` conversion.
"""

from __future__ import annotations

import math

from ornitail.acquisition.zaber_strut_driver import ZaberStrutSettings
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.line_instrument import SimulatedLineInstrument, first_order_step
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

SIMULATED_DEVICE_ID = 30222
"""The ``device.id`` this simulator reports (a made-up product id)."""


class SimulatedZaberStrut(SimulatedLineInstrument):
    """One-axis controller at address ``settings.device``, axis ``settings.axis``."""

    model = "Zaber ASCII (simulated)"

    def __init__(
        self,
        clock: SimulatedClock,
        signals: SharedTunnelSignals,
        settings: ZaberStrutSettings,
        *,
        slew_rate_deg_s: float = 10.0,
        travel_deg: tuple[float, float] = (-30.0, 60.0),
        power_on_position_counts: int | None = None,
        **kwargs,
    ) -> None:
        super().__init__(clock, **kwargs)
        self.signals = signals
        self.settings = settings
        self.speed_counts_per_s = slew_rate_deg_s * abs(settings.counts_per_deg)
        limits = [settings.counts_for_pitch(math.radians(deg)) for deg in travel_deg]
        self.travel_counts = (min(limits), max(limits))
        start = (
            power_on_position_counts
            if power_on_position_counts is not None
            else settings.counts_for_pitch(math.radians(3.7))
        )
        self.position = float(start)
        self.target = float(start)
        self.homed = False
        self.homing = False
        self._publish()

    def _publish(self) -> None:
        self.signals.set_operating_point(
            pitch_rad=self.settings.pitch_rad_for_counts(self.position)
        )

    def advance(self, dt_s: float) -> None:
        previous = self.position
        self.position = first_order_step(
            self.position, self.target, dt_s, 0.0, self.speed_counts_per_s
        )
        if self.homing and self.position == self.target:
            self.homing = False
            self.homed = True
        if self.position != previous:
            self._publish()

    def _reply(self, axis: int, accepted: bool, data: object) -> str:
        status = "BUSY" if self.position != self.target else "IDLE"
        flag = "--" if self.homed else "WR"
        return f"@{self.settings.device:02d} {axis} {'OK' if accepted else 'RJ'} {status} {flag} {data}\r"

    def handle(self, command: str) -> str | None:
        if not command.startswith("/"):
            return None
        device, words = _leading_number(command[1:].split())
        if device not in (0, self.settings.device):
            return None
        axis, words = _leading_number(words)
        if axis not in (0, self.settings.axis):
            return self._reply(axis, False, "BADAXIS")
        text = " ".join(words)
        if text == "get device.id":
            return self._reply(axis, True, SIMULATED_DEVICE_ID)
        if text == "get pos":
            return self._reply(axis, True, round(self.position))
        if text == "home":
            self.homing, self.homed = True, False
            self.target = 0.0
            return self._reply(axis, True, 0)
        if text in ("stop", "estop"):
            self.target = self.position  # (a real axis decelerates; this one stops at once)
            self.homing = False
            return self._reply(axis, True, 0)
        if words[:2] == ["move", "abs"] and len(words) == 3:
            try:
                counts = int(words[2])
            except ValueError:
                return self._reply(axis, False, "BADDATA")
            if not self.homed:
                return self._reply(axis, False, "BADCOMMAND")
            if not self.travel_counts[0] <= counts <= self.travel_counts[1]:
                return self._reply(axis, False, "BADDATA")
            self.target = float(counts)
            return self._reply(axis, True, 0)
        return self._reply(axis, False, "BADCOMMAND")


def _leading_number(words: list[str]) -> tuple[int, list[str]]:
    """The address or axis a message starts with (0 when omitted: all devices, or the whole device) and the rest."""
    if words and words[0].isdigit():
        return int(words[0]), words[1:]
    return 0, words
