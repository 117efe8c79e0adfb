"""Free-flight logs as the gap diagnosis sees them: manoeuvres at a reduced rate, and the split of runs.

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
VALIDATION_FRACTION = 0.25
TEST_FRACTION = 0.25
MINIMUM_PER_PART = 2
MINIMUM_RUNS = 3 * MINIMUM_PER_PART
MINIMUM_MANOEUVRES = MINIMUM_RUNS
OUTER_FOLDS = 4


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
            "(some to fit candidate effects on, some to choose among them, some to test the choice)",
        )
    return runs


@dataclass(frozen=True)
class RunSplit:
    """Indices of the three disjoint parts of a set of runs (manoeuvres, set points, rows).

    ``training``: candidates (and the detection rule's null directions) are fitted on them;
    ``validation``: candidates are ranked, the indistinguishable set and the verdict are decided on
    them; ``test``: how far the gap shrinks is reported on them only.
    """

    training: np.ndarray
    validation: np.ndarray
    test: np.ndarray
    method: str


def nested_splits(count: int, seed: int, where: str = "data") -> list[RunSplit]:
    """Seeded nested splits of ``count`` runs: the runs are cut into ``min(``:data:`OUTER_FOLDS`
    ``, count // ``:data:`MINIMUM_PER_PART```)`` test folds; for each, the other runs are split
    into training (2/3) and validation (1/3), each at least :data:`MINIMUM_PER_PART` runs. With 20
    runs every fold is 10/5/5 (training/validation/test), the 50/25/25 split. Every run is a test
    run exactly once, and never a training or validation run of its own fold. Fewer than
    :data:`MINIMUM_RUNS` runs stop with a one-line error naming ``where``."""
    if count < MINIMUM_RUNS:
        raise UserInputError(
            where,
            f"{count} runs; the diagnosis needs at least {MINIMUM_RUNS} ({MINIMUM_PER_PART} each to "
            "fit candidates on, to choose among them and to test the choice)",
        )
    order = np.random.default_rng(seed).permutation(count)
    folds = min(OUTER_FOLDS, count // MINIMUM_PER_PART)
    splits = []
    for index, test in enumerate(np.array_split(order, folds)):
        rest = order[~np.isin(order, test)]
        validation = max(
            MINIMUM_PER_PART, int(round(len(rest) * VALIDATION_FRACTION / (1.0 - TEST_FRACTION)))
        )
        training = len(rest) - validation
        splits.append(
            RunSplit(
                training=np.sort(rest[:training]),
                validation=np.sort(rest[training:]),
                test=np.sort(test),
                method=f"fold {index + 1} of {folds}: {training}/{validation}/{len(test)} "
                f"(training/validation/test, seed {seed})",
            )
        )
    return splits


def nested_split_counts(splits: list[RunSplit], count: int) -> dict[str, object]:
    """The report's ``split`` field for :func:`nested_splits` of ``count`` runs: the first fold's
    training and validation counts (they rank, detect and give the verdict), ``test`` = every run
    (each tested once, in its own fold), ``folds`` and the ``method``."""
    first = splits[0]
    return {
        "training": len(first.training),
        "validation": len(first.validation),
        "test": count,
        "folds": len(splits),
        "method": f"nested: {count} runs in {len(splits)} seeded test folds; each run is a test run "
        "once, scored with the effect chosen on validation runs and fitted on training runs of its "
        f"fold without it; ranking, detection rule and verdict from fold 1 "
        f"({len(first.training)}/{len(first.validation)}/{len(first.test)} training/validation/test)",
    }
