"""Free-flight logs as the gap diagnosis sees them: manoeuvres at a reduced rate, and a split.

Logs are read with the flight package's reader and cut with its pre-processing (glitch removal,
5 Hz zero-phase low-pass, cutting at the elevator and rudder commands; docs/flight-campaign.md).
After the 5 Hz filter the manoeuvre signals are decimated to about 64 Hz, which keeps their
content and makes every simulation cheap. Signals are deviations from the manoeuvre's run-in
(SI units, body frame of docs/frames.md): states [q (rad/s), u, w (m/s), theta (rad)], input
elevator (rad).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.manoeuvres import ELEVATOR_COLUMN, STATE_COLUMNS, cut_manoeuvres

CHANNELS = ("q", "u", "w", "theta")
CHANNEL_UNITS = ("rad/s", "m/s", "m/s", "rad")
TARGET_RATE_HZ = 64.0
TRAINING_FRACTION = 0.70
MINIMUM_MANOEUVRES = 4


@dataclass(frozen=True)
class FlightRun:
    """One manoeuvre at the reduced rate.

    ``states`` (N, 4) and ``elevator_rad`` (N,) are deviations from the run-in means;
    ``time_s`` counts from the manoeuvre start; ``input_start_s`` is the elevator onset;
    ``theta0_rad`` and ``airspeed_m_s`` are the run-in steady state.
    """

    label: str
    time_s: np.ndarray
    states: np.ndarray
    elevator_rad: np.ndarray
    input_start_s: float
    theta0_rad: float
    airspeed_m_s: float

    @property
    def time_step_s(self) -> float:
        return float(self.time_s[1] - self.time_s[0])


def read_flight_runs(paths: Sequence[str | Path]) -> list[FlightRun]:
    """Every manoeuvre of every log in ``paths``, decimated to about :data:`TARGET_RATE_HZ`."""
    runs: list[FlightRun] = []
    for path in paths:
        log = read_flight_log(path)
        for manoeuvre in cut_manoeuvres(log, str(path)):
            table = manoeuvre.deviations
            time_s = table["time_s"].to_numpy(float)
            rate = 1.0 / float(np.median(np.diff(time_s)))
            step = max(1, int(round(rate / TARGET_RATE_HZ)))
            picked = slice(None, None, step)
            runs.append(
                FlightRun(
                    label=manoeuvre.label,
                    time_s=time_s[picked],
                    states=table[list(STATE_COLUMNS)].to_numpy(float)[picked],
                    elevator_rad=table[ELEVATOR_COLUMN].to_numpy(float)[picked],
                    input_start_s=manoeuvre.input_start_s,
                    theta0_rad=manoeuvre.steady_state.theta_rad,
                    airspeed_m_s=manoeuvre.steady_state.airspeed_m_s,
                )
            )
    if len(runs) < MINIMUM_MANOEUVRES:
        raise UserInputError(
            ", ".join(str(path) for path in paths),
            f"{len(runs)} manoeuvre(s) found; the diagnosis needs at least {MINIMUM_MANOEUVRES} "
            "(some to fit candidate effects on, some withheld to score them)",
        )
    return runs


def split_runs(count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded random split of ``count`` runs into training (70 %) and withheld indices."""
    order = np.random.default_rng(seed).permutation(count)
    training = max(2, min(count - 2, int(round(TRAINING_FRACTION * count))))
    return np.sort(order[:training]), np.sort(order[training:])
