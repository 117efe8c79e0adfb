"""The wind-off reference a measurement subtracts, and the clock its drift runs on.

A strain-gauge balance drifts (warm-up, creep): a wind-off tare taken a minute before a point no longer gives the
gauges' zero at the point. When the plan brackets blocks of points with wind-off tares (``[protocol]
bracketing_tares``, docs/sweep-plan.md), the drift is measured: the zero at a point is a weighted sum of its run's
tares, ``V0 = sum_j w_j V_j``, from the run's drift fit (:mod:`ornitail.balance.run_drift_fit`: one curve in running
time shared by every pitch, an offset per pitch). The tares' errors are independent, so the covariance of V0 is
``sum_j w_j^2 C_j``, and points share each tare's error in proportion to their weights on it
(``balance.point_covariance``). Without a tare after the point in its run, the last tare before it at its pitch is
used as it is ("constant since the last tare": its drift since then is not corrected).

The drift runs on the rig's running time t: the time the motor ran, counted on the run's sample counter (one
continuous stream per run; records and the motor's changes are journalled as rows of the recording, and the samples
lost between rows, the counter's gaps, are added back, so a lossy link does not stop the clock: with a fifth of the
samples lost on a loaded host, counting rows put tares tens of seconds of warm-up early). The sweep journals when
the motor started and stopped (``motor_transitions``: its speed read every 0.1 s of rig time while settling and
recording; a motor told to stop keeps turning for seconds, and counting from the stop command left every bracketing
tare a few seconds of warm-up later than the clock said, ~0.3 mN in X on the simulated rig). Runs recorded without
it count from the end of each tare record to the end of the last measurement record before the next tare. The
balance warms and creeps while the rig runs, not while it stands for a tare: counted in wall time, the wind-off and
the tare's record would take a share of the drift that happened while the motor ran.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ornitail.acquisition.counter_gaps import CounterGap
from ornitail.acquisition.motor_running_log import MOTOR_TRANSITIONS_KEY
from ornitail.acquisition.recording_layout import SetPointRecord

DRIFT_MODEL_CONSTANT = "constant since the last tare (no tare after the point in its run)"


class SampleClockPositions:
    """Where rows of a recording sit on its sample counter: a row plus the samples lost before it (the counter's
    gaps), in samples from the run's first row."""

    def __init__(self, gaps: Sequence[CounterGap] = ()) -> None:
        jumps = sorted(
            (gap.row_index, gap.missing_samples) for gap in gaps if gap.missing_samples > 0
        )
        self._rows = np.array([row for row, _ in jumps], dtype=float)
        self._lost_before = np.cumsum([missing for _, missing in jumps], dtype=float)

    def __call__(self, row: float) -> float:
        """Position of row ``row`` (may be fractional: the middle of a record) on the sample counter, samples."""
        gaps_before = int(np.searchsorted(self._rows, row, side="right"))
        return float(row) + (float(self._lost_before[gaps_before - 1]) if gaps_before else 0.0)


class RunningClock:
    """The rig's running time (motor on) of one run, in samples of its counter, from its records in order.

    ``records`` are ``(is_tare, first_sample_index, last_sample_index)`` of every set point of the run (rows of the
    recording; ``positions`` puts them on the sample counter, default: no sample lost). The motor runs from the end
    of a tare record (or the run's start) to the end of the last measurement record before the next tare (or the
    run's last record).
    """

    def __init__(
        self,
        records: list[tuple[bool, float, float]],
        positions: SampleClockPositions | None = None,
    ) -> None:
        self.positions = positions or SampleClockPositions()
        ordered = sorted(records, key=lambda record: record[1])
        intervals: list[tuple[float, float]] = []
        start = 0.0
        last_measurement_end: float | None = None
        for is_tare, _first, last in ordered:
            if is_tare:
                if last_measurement_end is not None:
                    intervals.append((start, last_measurement_end))
                start, last_measurement_end = self.positions(last), None
            else:
                last_measurement_end = self.positions(last)
        if last_measurement_end is not None:
            intervals.append((start, last_measurement_end))
        self.intervals = intervals

    @classmethod
    def from_motor_transitions(
        cls,
        transitions: list[tuple],
        end_sample_index: float,
        positions: SampleClockPositions | None = None,
    ) -> RunningClock:
        """The clock from the motor's journalled changes (``("started" | "stopped", row index)``, any order, with
        the samples lost before that row as a third item where the change fell into a counter gap); a motor still
        running at the run's end runs to row ``end_sample_index``."""
        clock = cls([], positions)
        start: float | None = None
        for kind, row, *lost in sorted(transitions, key=lambda transition: transition[1]):
            position = clock.positions(row) - float(lost[0] if lost else 0)
            if kind == "started" and start is None:
                start = position
            elif kind == "stopped" and start is not None:
                clock.intervals.append((start, position))
                start = None
        if start is not None:
            clock.intervals.append((start, clock.positions(end_sample_index)))
        return clock

    def at(self, sample_index: float) -> float:
        """Running time up to row ``sample_index``, samples of the counter."""
        position = self.positions(sample_index)
        return float(sum(max(0.0, min(position, end) - begin) for begin, end in self.intervals))


@dataclass(frozen=True)
class RecordedTare:
    """One wind-off tare record: its mean gauge voltages (V, shape (6,)) and their covariance (V^2, (6, 6)), and
    where it sits on its run's running clock (samples)."""

    tare_id: str
    run_id: str
    running_time: float
    volts: np.ndarray
    volts_covariance: np.ndarray
    record: SetPointRecord | None = None


def middle_sample_index(record: SetPointRecord) -> float:
    """The middle of a record on its run's sample counter."""
    return 0.5 * (record.first_sample_index + record.last_sample_index)


def running_clock_of(
    records: list[SetPointRecord], gaps: Sequence[CounterGap] = ()
) -> RunningClock:
    """The running clock of a run from its set-point records and its sample counter's ``gaps``: from the motor's
    changes between standing and running where the sweep journalled them (``motor_transitions``; the motor spins
    down for seconds after it is told to stop, and warms the balance meanwhile), else from the records alone
    (:class:`RunningClock`)."""
    positions = SampleClockPositions(gaps)
    journalled = [record.extra.get(MOTOR_TRANSITIONS_KEY) for record in records]
    if records and all(transitions is not None for transitions in journalled):
        return RunningClock.from_motor_transitions(
            [tuple(transition) for transitions in journalled for transition in transitions],
            max(record.last_sample_index for record in records),
            positions,
        )
    return RunningClock(
        [
            (record.kind == "tare", record.first_sample_index, record.last_sample_index)
            for record in records
        ],
        positions,
    )


@dataclass(frozen=True)
class TareCorrection:
    """The zero subtracted from a measurement: a weighted sum of its run's wind-off tares (``terms``: tare and
    weight; :mod:`ornitail.balance.run_drift_fit`), or the tare before alone. ``before`` is the newest tare before
    the point at its pitch and tail state (its ``tare_id``); ``covariance_inflation`` scales the tares' covariance
    where the run's drift fit disagreed with their noise."""

    before: RecordedTare
    terms: tuple[tuple[RecordedTare, float], ...]
    drift_model: str = DRIFT_MODEL_CONSTANT
    covariance_inflation: float = 1.0

    @classmethod
    def constant(cls, before: RecordedTare) -> TareCorrection:
        """The tare before, subtracted as it is (no later tare in the run to measure the drift since)."""
        return cls(before, ((before, 1.0),))

    @property
    def volts(self) -> np.ndarray:
        """Interpolated gauge zero at the measurement, V."""
        return sum(weight * tare.volts for tare, weight in self.terms)

    @property
    def volts_covariance(self) -> np.ndarray:
        """Covariance of :attr:`volts`, V^2, shape (6, 6) (the tares independent)."""
        return self.covariance_inflation * sum(
            weight**2 * tare.volts_covariance for tare, weight in self.terms
        )


def drift_statement(drift_models: list[str], drift_checks: Sequence[str] = ()) -> str:
    """One line saying how the balance's drift was treated for a configuration's points (``drift_model`` column)
    and what the runs' drift checks saw (``drift_check`` column, one statement per run)."""
    total = len(drift_models)
    constant = sum(model == DRIFT_MODEL_CONSTANT for model in drift_models)
    if constant == 0:
        line = (
            f"Balance drift: the zero of all {total} points from their run's drift fit (one curve in running time "
            "shared by every pitch of the run, an offset per pitch)."
        )
    else:
        line = (
            f"Balance drift NOT corrected for {constant} of {total} points: no tare after them in their run, so "
            "the last tare is subtracted as it is and their drift since it is in their loads (plan "
            "bracketing_tares = true measures it)."
        )
    checks = list(dict.fromkeys(check for check in drift_checks if check))
    return " ".join([line, *checks])
