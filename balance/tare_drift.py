"""The wind-off reference a measurement subtracts, corrected for the balance's drift between bracketing tares.

A strain-gauge balance drifts (warm-up, creep): a wind-off tare taken a minute before a point no longer gives the
gauges' zero at the point. When the plan brackets a block of points with wind-off tares at the same pitch and tail
state (``[protocol] bracketing_tares``, docs/sweep-plan.md), the zero at a point is interpolated linearly between
the tare before and the tare after it:

    V0(t) = (1 - lambda) V_before + lambda V_after,   lambda = (t - t_before) / (t_after - t_before)

in the rig's running time t: the time the motor ran, counted on the run's sample counter (one continuous stream per
run; records and the motor's changes are journalled as rows of the recording, and the samples lost between rows, the
counter's gaps, are added back, so a lossy link does not stop the clock: with a fifth of the samples lost on a
loaded host, counting rows put tares tens of seconds of warm-up early). The sweep journals when the motor started
and stopped (``motor_transitions``: its speed read every 0.1 s of rig time while settling and recording; a motor
told to stop keeps turning for seconds, and counting from the stop command left every bracketing tare a few seconds
of warm-up later than the clock said, ~0.3 mN in X on the simulated rig). Runs recorded without it count from the
end of each tare record to the end of the last measurement record before the next tare. The balance warms and creeps
while the rig runs, not while it stands for a tare: counted in wall time, the wind-off and the tare's record (a
tenth of a block, and more of a short one) would take a share of the drift that happened while the motor ran. The
two tares' errors are independent, so the covariance of V0 is ``(1 - lambda)^2 C_before + lambda^2 C_after``; points
that share a tare share its error in proportion to their weights on it (``balance.point_covariance``). Without a
tare after the point in the same run, the last tare before it is used as it is ("constant since the last tare": its
drift since then is not corrected).

Straight drift is checked, not assumed (:class:`DriftCheck`): three successive tares at one pitch test it. A
balance warming up bends its zero over a minute; when the check rejects straight drift, each point with a third
tare at its pitch (the next after the bracketing pair, else the one before) gets the parabola through the three,
``V0(t) = sum_j L_j(t) V_j`` with Lagrange weights ``L_j`` in running time (the covariance ``sum_j L_j^2 C_j``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from ornitail.acquisition.counter_gaps import CounterGap
from ornitail.acquisition.motor_running_log import MOTOR_TRANSITIONS_KEY
from ornitail.acquisition.recording_layout import SetPointRecord

DRIFT_MODEL_LINEAR = "linear in running time (motor on) between bracketing tares"
DRIFT_MODEL_CONSTANT = "constant since the last tare (no tare after the point in its run)"
DRIFT_MODEL_QUADRATIC = (
    "quadratic in running time (motor on) through three tares (straight drift rejected)"
)
DRIFT_CHECK_SIGNIFICANCE = 0.01
"""Chance of a false alarm of the drift check: straight drift is rejected below this p-value."""


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
    """The zero subtracted from a measurement: the tare before it, the tare after it with ``after_weight`` and,
    when the run's drift bends, a third tare at the same pitch with ``third_weight`` (the tare before weighs the
    rest, ``1 - after_weight - third_weight``)."""

    before: RecordedTare
    after: RecordedTare | None = None
    after_weight: float = 0.0
    third: RecordedTare | None = None
    third_weight: float = 0.0

    @property
    def before_weight(self) -> float:
        return 1.0 - self.after_weight - self.third_weight

    def _terms(self) -> list[tuple[RecordedTare, float]]:
        terms = [(self.before, self.before_weight)]
        if self.after is not None:
            terms.append((self.after, self.after_weight))
        if self.third is not None:
            terms.append((self.third, self.third_weight))
        return terms

    @property
    def volts(self) -> np.ndarray:
        """Interpolated gauge zero at the measurement, V."""
        return sum(weight * tare.volts for tare, weight in self._terms())

    @property
    def volts_covariance(self) -> np.ndarray:
        """Covariance of :attr:`volts`, V^2, shape (6, 6) (the tares independent)."""
        return sum(weight**2 * tare.volts_covariance for tare, weight in self._terms())

    @property
    def drift_model(self) -> str:
        """How the drift between the tares was modelled, in words for the output."""
        if self.after is None:
            return DRIFT_MODEL_CONSTANT
        return DRIFT_MODEL_LINEAR if self.third is None else DRIFT_MODEL_QUADRATIC


def tare_correction(
    before: RecordedTare,
    after: RecordedTare | None,
    running_time: float,
    run_id: str,
    third: RecordedTare | None = None,
) -> TareCorrection:
    """Bracket a record at ``running_time`` on run ``run_id``'s running clock between ``before`` and ``after``
    when both are in its run and the rig ran between them; else the tare before alone. With ``third`` (a third
    tare of the run at the same pitch, before ``before`` or after ``after``), the zero is the parabola through
    the three tares (Lagrange weights in running time)."""
    if after is None or before.run_id != run_id or after.run_id != run_id:
        return TareCorrection(before)
    span = after.running_time - before.running_time
    if span <= 0:
        return TareCorrection(before)
    time = float(np.clip(running_time, before.running_time, after.running_time))
    if third is not None and third.run_id == run_id:
        times = (before.running_time, after.running_time, third.running_time)
        if len({round(t, 6) for t in times}) == 3:
            weights = [
                math.prod((time - times[k]) / (times[j] - times[k]) for k in range(3) if k != j)
                for j in range(3)
            ]
            return TareCorrection(before, after, weights[1], third, weights[2])
    return TareCorrection(before, after, (time - before.running_time) / span)


def drift_statement(drift_models: list[str], drift_checks: Sequence[str] = ()) -> str:
    """One line saying how the balance's drift was treated for a configuration's points (``drift_model`` column)
    and what the runs' drift checks saw (``drift_check`` column, one statement per run)."""
    total = len(drift_models)
    constant = sum(model == DRIFT_MODEL_CONSTANT for model in drift_models)
    quadratic = sum(model == DRIFT_MODEL_QUADRATIC for model in drift_models)
    if constant == 0:
        line = f"Balance drift: the zero of all {total} points interpolated {DRIFT_MODEL_LINEAR}"
        line += f" ({quadratic} of them through three tares)." if quadratic else "."
    else:
        line = (
            f"Balance drift NOT corrected for {constant} of {total} points: no tare after them in their run, so "
            "the last tare is subtracted as it is and their drift since it is in their loads (plan "
            "bracketing_tares = true measures it)."
        )
    checks = list(dict.fromkeys(check for check in drift_checks if check))
    return " ".join([line, *checks])


@dataclass(frozen=True)
class DriftCheck:
    """Whether a run's tares agree with drift that is straight between them, and what is done when they do not.

    Every three successive tares at the same pitch and tail state test the straight line: the middle one's
    departure from the line through its neighbours, against the noise of the three (chi-square, 6 per triple).
    When straight drift is rejected (p below :data:`DRIFT_CHECK_SIGNIFICANCE`), the points of the run that have
    a third tare at their pitch get their zero from the parabola through three tares (:func:`tare_correction`);
    left straight, a bend (second derivative ``c`` of the zero in running time) puts a point between tares at
    ``t_a < t < t_b`` off by ``c / 2 (t - t_a)(t_b - t)``, the same sign for every point of a warming run, so
    it does not average out over repeats (on the simulated rig it was three times the points' noise).
    """

    run_id: str
    triple_chi_squares: tuple[float, ...]

    @property
    def chi_square(self) -> float:
        return float(sum(self.triple_chi_squares))

    @property
    def degrees_of_freedom(self) -> int:
        return 6 * len(self.triple_chi_squares)

    @property
    def p_value(self) -> float:
        """Chance of a chi-square at least this large if the drift were straight (1 without a triple)."""
        if not self.triple_chi_squares:
            return 1.0
        return float(chi2.sf(self.chi_square, self.degrees_of_freedom))

    @property
    def straight_drift_rejected(self) -> bool:
        return self.p_value < DRIFT_CHECK_SIGNIFICANCE

    def statement(self) -> str:
        """One line for the output: what the check saw and whether zeros go through three tares."""
        if not self.triple_chi_squares:
            return f"Drift check ({self.run_id}): fewer than three tares at any pitch, straight drift not tested."
        verdict = (
            "the drift bends between tares, so zeros are interpolated through three tares where a third is "
            "at the pitch"
            if self.straight_drift_rejected
            else "consistent with straight drift between tares"
        )
        return (
            f"Drift check ({self.run_id}): {len(self.triple_chi_squares)} tare triple(s), chi-square "
            f"{self.chi_square:.1f} on {self.degrees_of_freedom} (p = {self.p_value:.2g}): {verdict}."
        )


def drift_check(run_id: str, tares_by_pitch: Sequence[Sequence[RecordedTare]]) -> DriftCheck:
    """Test a run's tares for straight drift (see :class:`DriftCheck`); ``tares_by_pitch`` holds, per pitch and
    tail state, that run's tares in running-time order."""
    chi_squares = []
    for tares in tares_by_pitch:
        for first, middle, last in zip(tares, tares[1:], tares[2:], strict=False):
            before_s = middle.running_time - first.running_time
            after_s = last.running_time - middle.running_time
            if before_s <= 0 or after_s <= 0:
                continue
            weight = before_s / (before_s + after_s)
            departure = middle.volts - ((1 - weight) * first.volts + weight * last.volts)
            covariance = (
                middle.volts_covariance
                + (1 - weight) ** 2 * first.volts_covariance
                + weight**2 * last.volts_covariance
            )
            chi_squares.append(float(departure @ np.linalg.solve(covariance, departure)))
    return DriftCheck(run_id, tuple(chi_squares))
