"""One clock shared by the simulated instruments of a rig, at a chosen multiple of real time."""

from __future__ import annotations

import math
import time

from ornitail.core.errors import UserInputError


class SimulatedClock:
    """Simulated seconds since the clock was made, advancing ``time_scale`` times real time.

    ``time_scale=1`` is real time (benchmarks, users watching the rig); tests use 10-50 so that a
    fan spinning up over seconds of simulated time takes a fraction of a second of wall time.
    """

    def __init__(self, time_scale: float = 1.0) -> None:
        if (
            not (isinstance(time_scale, int | float) and math.isfinite(time_scale))
            or time_scale <= 0
        ):
            raise UserInputError("time_scale", f"{time_scale!r} must be a finite number > 0")
        self.time_scale = float(time_scale)
        self._wall_start_s = time.monotonic()

    def now_s(self) -> float:
        """Simulated seconds elapsed since the clock was made."""
        return (time.monotonic() - self._wall_start_s) * self.time_scale
