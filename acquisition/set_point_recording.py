"""Recording one set point into an open run: the rows the board sampled from now on, the rig's conditions read
while they arrive, retakes of a record that lost samples, and its journal entry.

The one place a set point becomes rows of a recording: sweeps (:mod:`ornitail.acquisition.sweep`) and the
window's manual records and tares (``gui/rig_session.py``) both call :func:`record_set_point` with a
:class:`RecordingContext` of their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

from ornitail.acquisition.instrument_errors import InstrumentDisconnected
from ornitail.acquisition.live_balance import LiveBalance
from ornitail.acquisition.motor_running_log import MotorRunningLog
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import SetPointRecord
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.sweep_plan import SetPoint

RECORD_START_DELAY_S = 0.1
"""Rig time between settling and the first recorded row: covers the driver's ~10 ms block latency."""
POLL_INTERVAL_S = 0.1
"""Rig time between readings while settling."""
MAX_RETAKES = 3
"""Times a set point's record is taken again when samples were lost inside it."""
ROWS_STALLED_S = 30.0
"""Rig time a record waits without one new row before the balance stream counts as failed, s. An unplugged device
fails its port at once; a board whose firmware hung, or a reader that stopped, keeps the port open and sends
nothing, and without this a sweep would wait for its rows for ever. Rows arrive every 10 ms or so; a busy host
delays them by seconds at most."""


class RecordingContext(Protocol):
    """What recording a set point needs from whoever runs the run (a sweep, the window)."""

    rig: Rig
    stream: LiveBalance
    motor_log: MotorRunningLog

    def wait_rig_s(self, seconds: float) -> None:
        """Wait ``seconds`` of rig time; raise if the stream failed or the run is to stop now."""

    def observe_motor(self, running: bool) -> None:
        """Note a reading of the motor (running or standing) for the drift clock."""


@dataclass
class RecordConditions:
    """The rig's conditions read around one record, every ``POLL_INTERVAL_S`` of rig time, and where each reading
    falls on the balance's sample count.

    The set point is reached only within the settle tolerances and the fan still creeps towards it during the
    record (first-order lag), so the conditions the loads belong to are these, not the set values. The readings
    reach the control computer later than the samples they go with (rows arrive after their latency), and a creeping
    fan makes that a bias: the mean of the raw readings sat about 0.1 mm/s above the record's, which moved Z0 and M0
    by one to two of their sigmas. So each condition is fitted with a straight line in the sample count and taken
    at the record's middle sample (the record's mean of a quantity changing linearly). Velocity in m/s from the
    fan's rpm and the tunnel table, pitch in rad from the strut, motor speed in rpm.
    """

    first_sample: int
    """The record's first sample, counted as :meth:`Rig.balance_samples_since_start` counts."""
    samples: int
    sample_counts: list[int] = field(default_factory=list)
    velocities_m_s: list[float] = field(default_factory=list)
    pitches_rad: list[float] = field(default_factory=list)
    motor_rpms: list[float] = field(default_factory=list)

    def read(self, rig: Rig) -> None:
        """Take one reading of every condition the rig can report."""
        self.sample_counts.append(rig.balance_samples_since_start())
        self.velocities_m_s.append(rig.read_tunnel_velocity_m_s())
        self.pitches_rad.append(rig.read_pitch_rad())
        if rig.motor is not None:
            self.motor_rpms.append(rig.motor.read_rpm())

    def motor_rpm_mean(self) -> float | None:
        """Mean motor speed over the readings, rpm (None without a motor)."""
        return math.fsum(self.motor_rpms) / len(self.motor_rpms) if self.motor_rpms else None

    def at_record_middle(self, values: list[float]) -> float:
        """``values`` (one per reading) on a least-squares line in the sample count, at the record's middle."""
        middle = self.first_sample + 0.5 * (self.samples - 1)
        count = len(values)
        mean_count = math.fsum(self.sample_counts) / count
        mean_value = math.fsum(values) / count
        spread = math.fsum((c - mean_count) ** 2 for c in self.sample_counts)
        if count < 2 or spread <= 0.0:
            return mean_value
        slope = (
            math.fsum(
                (c - mean_count) * (v - mean_value)
                for c, v in zip(self.sample_counts, values, strict=True)
            )
            / spread
        )
        return mean_value + slope * (middle - mean_count)

    def journal_values(self) -> dict[str, float | int]:
        """For the set point's ``extra``: ``tunnel_velocity_mean_m_s`` and ``pitch_mean_rad`` (the record's
        mean, from the line through the readings), ``condition_readings``."""
        return {
            "tunnel_velocity_mean_m_s": self.at_record_middle(self.velocities_m_s),
            "pitch_mean_rad": self.at_record_middle(self.pitches_rad),
            "condition_readings": len(self.velocities_m_s),
        }


def take_rows(
    context: RecordingContext, recorder: Recorder, count: int
) -> tuple[int, int, RecordConditions]:
    """Wait for ``count`` rows sampled from now on, with the stream's alignment held until they arrived; return the
    first one's row index, the samples of the record's window the link lost before that row (a counter gap over
    its start: the rows then begin that much later, at most ``count`` counted) and the conditions read from then
    on."""
    # Every row of the record is placed on the host clock with the same counter lines (two devices' balance).
    with context.stream.alignment_held():
        context.wait_rig_s(RECORD_START_DELAY_S)
        samples_since_start = context.rig.balance_samples_since_start()
        conditions = RecordConditions(samples_since_start, count)
        found = None
        rows_seen, rows_seen_at_s = recorder.next_sample_index, context.rig.now_s()
        while True:
            conditions.read(context.rig)
            if conditions.motor_rpms:
                context.observe_motor(conditions.motor_rpms[-1] > 0.0)
            if found is None:
                found = context.stream.row_sampled_at(samples_since_start)
            if found is not None and recorder.next_sample_index >= found[0] + count:
                first, lost_before_first = found
                return first, min(lost_before_first, count), conditions
            if recorder.next_sample_index != rows_seen:
                rows_seen, rows_seen_at_s = recorder.next_sample_index, context.rig.now_s()
            elif context.rig.now_s() - rows_seen_at_s > ROWS_STALLED_S:
                raise InstrumentDisconnected(
                    context.rig.balance.name,
                    f"no samples arrived for {ROWS_STALLED_S:g} s of rig time while recording a set point (the "
                    "stream's port is open but silent: a hung board or a stalled reader)",
                )
            context.wait_rig_s(POLL_INTERVAL_S)


def record_set_point(
    context: RecordingContext,
    recorder: Recorder,
    point: SetPoint,
    sample_rate_hz: float,
    settle_s: float | None = None,
) -> SetPointRecord:
    """Take the ``record_s`` of the stream sampled from now on as this point's rows and journal it.

    Rows still in transit (pty, driver queue) when the point settled were sampled before it settled; the board's
    counter, not the arrival order, decides where the point begins. A record with samples lost over its start or
    inside it (counter gaps: an overloaded link) is taken again, up to ``MAX_RETAKES`` times; what the kept record
    lost is journalled as ``samples_missing_in_record``. A gap over the start counts because the rows after it
    were sampled that much later: a board that dropped a whole record's worth put the next point's samples (the
    motor already running) into a tare's rows. The recorder fills in the record's saturated and over-range row
    counts.
    """
    stream = context.stream
    count = int(round(point.record_s * sample_rate_hz))

    def take() -> tuple[int, int, RecordConditions]:
        first, lost_at_start, conditions = take_rows(context, recorder, count)
        return first, lost_at_start + stream.samples_missing_in_rows(first, count), conditions

    retakes = 0
    first, missing, conditions = take()
    while missing and retakes < MAX_RETAKES:
        retakes += 1
        first, missing, conditions = take()
    record = SetPointRecord(
        plan_point_index=point.index,
        kind=point.kind,
        first_sample_index=first,
        last_sample_index=first + count - 1,
        pitch_rad=point.pitch_rad,
        tunnel_velocity_m_s=point.tunnel_velocity_m_s,
        flapping_frequency_hz=point.flapping_frequency_hz,
        tail_attached=point.tail_attached,
        repeat_index=point.repeat,
        settle_time_s=settle_s,
        motor_rpm_mean=conditions.motor_rpm_mean(),
        extra={
            "sweep": point.sweep,
            "retakes": retakes,
            "samples_missing_in_record": missing,
            **conditions.journal_values(),
            **context.motor_log.journal_values(stream),
            **stream.alignment_values(),
        },
    )
    recorder.complete_set_point(record)
    return record
