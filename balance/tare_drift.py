"""The wind-off reference a measurement subtracts, corrected for the balance's drift between bracketing tares.

A strain-gauge balance drifts (warm-up, creep): a wind-off tare taken a minute before a point no longer gives the
gauges' zero at the point. When the plan brackets a block of points with wind-off tares at the same pitch and tail
state (``[protocol] bracketing_tares``, docs/sweep-plan.md), the zero at a point is interpolated linearly between
the tare before and the tare after it:

    V0(t) = (1 - lambda) V_before + lambda V_after,   lambda = (t - t_before) / (t_after - t_before)

in the rig's running time t: the time the motor ran, counted on the run's sample counter (one continuous stream
per run) from the end of each tare record to the end of the last measurement record before the next tare (the
motor is on from the first measurement's settling to the wind-off before a tare, off from then through the tare's
record). The balance warms and creeps while the rig runs, not while it stands for a tare: counted in wall time, the
wind-off and the tare's record (a tenth of a block, and more of a short one) would take a share of the drift that
happened while the motor ran. The two tares' errors are independent, so the variance of V0 is
``(1 - lambda)^2 se_before^2 + lambda^2 se_after^2``; points that share a tare share its error in proportion to
their weights on it (``balance.derivatives.weighted_tare_covariance``). Without a tare after the point in the
same run, the last tare before it is used as it is ("constant since the last tare": its drift since then is not
corrected).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.acquisition.recording_layout import SetPointRecord

DRIFT_MODEL_LINEAR = "linear in running time (motor on) between bracketing tares"
DRIFT_MODEL_CONSTANT = "constant since the last tare (no tare after the point in its run)"


class RunningClock:
    """The rig's running time (motor on) of one run, in samples of its counter, from its records in order.

    ``records`` are ``(is_tare, first_sample_index, last_sample_index)`` of every set point of the run. The motor
    runs from the end of a tare record (or the run's start) to the end of the last measurement record before the
    next tare (or the run's last record).
    """

    def __init__(self, records: list[tuple[bool, float, float]]) -> None:
        ordered = sorted(records, key=lambda record: record[1])
        intervals: list[tuple[float, float]] = []
        start = 0.0
        last_measurement_end: float | None = None
        for is_tare, _first, last in ordered:
            if is_tare:
                if last_measurement_end is not None:
                    intervals.append((start, last_measurement_end))
                start, last_measurement_end = float(last), None
            else:
                last_measurement_end = float(last)
        if last_measurement_end is not None:
            intervals.append((start, last_measurement_end))
        self.intervals = intervals

    def at(self, sample_index: float) -> float:
        """Running time up to ``sample_index``, samples."""
        return float(sum(max(0.0, min(sample_index, end) - begin) for begin, end in self.intervals))


@dataclass(frozen=True)
class RecordedTare:
    """One wind-off tare record: its mean gauge voltages and their standard error (V, shape (6,)), and where it
    sits on its run's running clock (samples)."""

    tare_id: str
    run_id: str
    running_time: float
    volts: np.ndarray
    volts_standard_error: np.ndarray
    record: SetPointRecord | None = None


def middle_sample_index(record: SetPointRecord) -> float:
    """The middle of a record on its run's sample counter."""
    return 0.5 * (record.first_sample_index + record.last_sample_index)


def running_clock_of(records: list[SetPointRecord]) -> RunningClock:
    """The running clock of a run from its set-point records."""
    return RunningClock(
        [
            (record.kind == "tare", record.first_sample_index, record.last_sample_index)
            for record in records
        ]
    )


@dataclass(frozen=True)
class TareCorrection:
    """The zero subtracted from a measurement: the tare before it, and the tare after it with ``after_weight``."""

    before: RecordedTare
    after: RecordedTare | None = None
    after_weight: float = 0.0

    @property
    def volts(self) -> np.ndarray:
        """Interpolated gauge zero at the measurement, V."""
        if self.after is None:
            return self.before.volts
        return (1.0 - self.after_weight) * self.before.volts + self.after_weight * self.after.volts

    @property
    def volts_standard_error(self) -> np.ndarray:
        """Standard error of :attr:`volts`, V (the two tares independent)."""
        if self.after is None:
            return self.before.volts_standard_error
        return np.hypot(
            (1.0 - self.after_weight) * self.before.volts_standard_error,
            self.after_weight * self.after.volts_standard_error,
        )

    @property
    def drift_model(self) -> str:
        """How the drift between the tares was modelled, in words for the output."""
        return DRIFT_MODEL_CONSTANT if self.after is None else DRIFT_MODEL_LINEAR


def tare_correction(
    before: RecordedTare, after: RecordedTare | None, running_time: float, run_id: str
) -> TareCorrection:
    """Bracket a record at ``running_time`` on run ``run_id``'s running clock between ``before`` and ``after``
    when both are in its run and the rig ran between them; else the tare before alone."""
    if after is None or before.run_id != run_id or after.run_id != run_id:
        return TareCorrection(before)
    span = after.running_time - before.running_time
    if span <= 0:
        return TareCorrection(before)
    weight = (running_time - before.running_time) / span
    return TareCorrection(before, after, float(np.clip(weight, 0.0, 1.0)))


def drift_statement(drift_models: list[str]) -> str:
    """One line saying how the balance's drift was treated for a configuration's points (``drift_model`` column)."""
    total = len(drift_models)
    linear = sum(model == DRIFT_MODEL_LINEAR for model in drift_models)
    if linear == total:
        return f"Balance drift: the zero of all {total} points interpolated {DRIFT_MODEL_LINEAR}."
    return (
        f"Balance drift NOT corrected for {total - linear} of {total} points: no tare after them in their run, so "
        "the last tare is subtracted as it is and their drift since it is in their loads (plan "
        "bracketing_tares = true measures it)."
    )
