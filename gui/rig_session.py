"""The window's connection to a rig: commands off the GUI thread, live balance, recording, sweeps, emergency stop.

Nothing here touches a widget. Commands run one at a time on a worker thread; what they produce (results,
errors, sweep progress, operator prompts) goes into :attr:`RigSession.messages`, which the window drains from
its redraw timer. The emergency stop does not queue behind anything: it aborts a running sweep and brings motor
and fan to a safe state from its own thread at once.
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ornitail.acquisition.catalog import default_data_root
from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.live_balance import LiveBalance, balance_stream_layout
from ornitail.acquisition.motor_running_log import MotorRunningLog
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import (
    SET_POINT_KIND_MEASUREMENT,
    SET_POINT_KIND_TARE,
    RunConfiguration,
    SetPointRecord,
)
from ornitail.acquisition.recording_plan import RecordSetPoint
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.run_documents import DocumentDispatcher
from ornitail.acquisition.run_engine import OpenRun, open_run, run_plan
from ornitail.acquisition.sweep import SweepEvent, SweepResult
from ornitail.acquisition.sweep_plan import SetPoint, SettleCriteria, load_plan
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.core.errors import UserInputError
from ornitail.gui.instrument_poller import InstrumentPoller, InstrumentReadings
from ornitail.gui.sweep_runner import SweepRunner

_SAME_PITCH_RAD = 1e-9
"""Commanded pitches this close are the same set point (processing pairs tares by pitch to 1e-9 rad)."""
WIND_OFF_TIMEOUT_S = 60.0
"""Rig time the fan and motor get to come to rest before a tare."""
FAULT_SHOWN_S = 10.0
"""Wall time the status strip stays red after an instrument fault that did not last, s."""
SHUTDOWN_TIMEOUT_S = 60.0
"""Wall time the window waits for the disconnect (sweep aborted, streams stopped, rig closed) when closing, s."""


@dataclass(frozen=True)
class SessionMessage:
    """Something for the window: ``kind`` is ``"info"``, ``"error"`` (instrument or bug), ``"user_error"``
    (a :class:`UserInputError`), ``"sweep_event"``, ``"sweep_done"``, ``"prompt"`` (``payload`` is a
    :class:`threading.Event` to set once the person has acted), ``"connected"``, ``"tare"`` or ``"document"`` (a
    run document the window subscribed to: ``text`` is its name, ``payload`` the document)."""

    kind: str
    text: str
    payload: Any = None


@dataclass
class ManualRecording:
    """The manual run being recorded: the run :func:`~ornitail.acquisition.run_engine.open_run` opened (and the
    stack that closes it), the rig and balance stream it records from, its tares.

    It is the :class:`~ornitail.acquisition.set_point_recording.RecordingContext` of the window's records and the
    performer of their plans: each Tare and Record is a one-step plan (a
    :class:`~ornitail.acquisition.recording_plan.RecordSetPoint`) that
    :func:`~ornitail.acquisition.run_engine.run_plan` runs inside the open run. Tares and points become rows of the
    run exactly as a sweep's do (by the board's sample counter, retaken when samples were lost, with the conditions
    read during the record and the motor's starts and stops), each recorded with :meth:`OpenRun.record`, so the run
    emits its start, set point and stop documents as a sweep's runs do.
    """

    run: OpenRun
    closing: ExitStack
    rig: Rig
    stream: LiveBalance
    tailed: bool
    motor_log: MotorRunningLog = field(default_factory=MotorRunningLog)
    points: int = 0
    tare_pitches_rad: list[float] = field(default_factory=list)
    last_record: SetPointRecord | None = None

    @property
    def recorder(self) -> Recorder:
        """The run's recorder."""
        return self.run.recorder

    def wait_rig_s(self, seconds: float) -> None:
        """Wait ``seconds`` of rig time; raise if the balance stream failed."""
        self.rig.wait_simulated_s(seconds)
        self.stream.raise_if_failed()

    def observe_motor(self, running: bool) -> None:
        """Note a reading of the motor (running or standing) for the drift clock."""
        self.motor_log.observe(running, self.rig.balance_samples_since_start(), self.stream)

    def record(self, run: OpenRun, point: SetPoint, settle_s: float | None) -> None:
        """Record ``point`` into ``run`` (this run) as its next set point, at the stream's sample rate."""
        self.last_record = run.record(self, point, self.stream.sample_rate_hz, settle_s)
        self.points += 1

    def has_tare_at(self, pitch_rad: float) -> bool:
        """Whether the run holds a wind-off tare at this commanded pitch (rad)."""
        return any(abs(pitch_rad - tare) <= _SAME_PITCH_RAD for tare in self.tare_pitches_rad)


class RigSession:
    """One connected rig as the window uses it.

    Parameters
    ----------
    data_root : pathlib.Path, optional
        Where runs and the catalog are written (default: ``ornitail``'s data root).
    display_decimation : int
        Every n-th balance row goes to the display.

    Attributes
    ----------
    documents : DocumentDispatcher
        Receives the start, set point and stop documents of every run recorded from the window (manual runs
        and sweeps), in the recording's thread.
    """

    def __init__(self, data_root: Path | None = None, display_decimation: int = 10) -> None:
        self.data_root = Path(data_root) if data_root is not None else default_data_root()
        self.display_decimation = display_decimation
        self.documents = DocumentDispatcher()
        self.messages: queue.Queue[SessionMessage] = queue.Queue()
        self.rig: Rig | None = None
        self.live: LiveBalance | None = None
        self.poller: InstrumentPoller | None = None
        self.calibration: AtiCalibration | None = None
        self.tare_volts: np.ndarray | None = None
        self.tare_pitch_rad: float | None = None
        self.tail_attached = True
        self.commanded: dict[str, float] = {}
        """The set point last commanded from the window: ``pitch_rad``, ``tunnel_velocity_m_s``,
        ``flapping_frequency_hz`` (what a manual record journals as its set point, as a sweep does)."""
        self.recording: ManualRecording | None = None
        self.sweep: SweepRunner | None = None
        self.instrument_fault: str | None = None
        """The last instrument failure (a command's or the display readings'), None once they answer again."""
        self.instrument_fault_time_s = -math.inf
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rig-command")

    # -- plumbing ---------------------------------------------------------------------------
    def post(self, kind: str, text: str, payload: Any = None) -> None:
        """Queue a message for the window (any thread)."""
        self.messages.put(SessionMessage(kind, text, payload))

    def submit(self, what: str, function: Callable[..., Any], *args: Any) -> Future:
        """Run ``function(*args)`` on the command thread; its errors become messages naming ``what``."""

        def run() -> Any:
            try:
                return function(*args)
            except UserInputError as error:
                self.post("user_error", str(error))
            except (InstrumentError, TimeoutError, OSError) as error:
                self._instrument_failed(f"{what}: {error}")
            except Exception as error:  # a bug: still a message, never a dead window
                self.post("error", f"{what}: {type(error).__name__}: {error}")
            return None

        return self._worker.submit(run)

    @property
    def connected(self) -> bool:
        """True while a rig is connected."""
        return self.rig is not None

    @property
    def sweep_running(self) -> bool:
        """True while a sweep thread runs."""
        return self.sweep is not None and self.sweep.is_alive()

    @property
    def readings(self) -> InstrumentReadings:
        """Latest line-instrument readings (NaN before the first)."""
        return self.poller.latest if self.poller is not None else InstrumentReadings()

    def _require_rig(self) -> Rig:
        if self.rig is None:
            raise UserInputError("rig", "no rig connected: connect a rig file first")
        return self.rig

    def _require_idle(self, action: str) -> None:
        if self.sweep_running:
            raise UserInputError(action, "a sweep is running: pause or abort it first")

    # -- instrument faults ------------------------------------------------------------------
    def _instrument_failed(self, error: object) -> None:
        """An instrument did not answer as it should: a message, and the status strip turns red."""
        self.instrument_fault = str(error)
        self.instrument_fault_time_s = time.monotonic()
        self.post("error", str(error))

    def _instruments_answer_again(self) -> None:
        self.instrument_fault = None
        self.post("info", "instruments answer again")

    def fault_text(self) -> str | None:
        """The instrument fault to show: one the instruments still have, or one at most
        ``FAULT_SHOWN_S`` old (a command that failed once), else None."""
        if self.instrument_fault is None:
            return None
        if self.poller_failing or time.monotonic() - self.instrument_fault_time_s < FAULT_SHOWN_S:
            return self.instrument_fault
        return None

    @property
    def poller_failing(self) -> bool:
        """True while the display's readings of the line instruments fail."""
        return self.poller is not None and self.poller.failing

    # -- connection -------------------------------------------------------------------------
    def connect(self, rig_file: Path, time_scale: float | None = None) -> Future:
        """Connect the rig file's instruments (simulators first for a simulated rig) and start streaming."""
        return self.submit("connect", self._connect, Path(rig_file), time_scale)

    def _connect(self, rig_file: Path, time_scale: float | None) -> None:
        self._disconnect()
        rig = Rig.from_file(rig_file, time_scale=time_scale)
        try:
            rig.connect()
        except InstrumentError as error:  # connect() made safe and closed what it had opened
            self.post("error", f"connect: {error}; {rig.safe_state_summary()}")
            return
        try:
            self.live = LiveBalance(rig, self.display_decimation)
            self.live.start()
        except BaseException:
            rig.close(raise_errors=False)
            self.live = None
            raise
        self.rig = rig
        self.calibration = rig.calibration.with_tool_transform(rig.description.tool_transform)
        self.poller = InstrumentPoller(rig, self._instrument_failed, self._instruments_answer_again)
        self.poller.start()
        self.post("connected", f"connected {rig.description.name} ({rig.description.path})")

    def disconnect(self) -> Future:
        """Stop everything, bring the rig to a safe state and close it."""
        return self.submit("disconnect", self._disconnect)

    def _disconnect(self) -> None:
        if self.sweep_running:
            assert self.sweep is not None
            self.sweep.abort()
            self.sweep.join(timeout=30.0)
        if self.recording is not None:
            self._stop_recording("the rig was disconnected")
        if self.poller is not None:
            self.poller.stop()
            self.poller = None
        if self.live is not None:
            self.live.stop()
            self.live = None
        if self.rig is not None:
            rig, self.rig = self.rig, None
            rig.close()
            self.post("info", "rig disconnected, motor and fan off")

    def shutdown(self) -> None:
        """Disconnect and end the command thread (window closing).

        A command thread stuck behind an instrument that never answers does not keep the window open: after
        ``SHUTDOWN_TIMEOUT_S`` the rig is brought to its safe state from here and the thread is left behind.
        """
        try:
            self.disconnect().result(timeout=SHUTDOWN_TIMEOUT_S)
        except TimeoutError:
            rig = self.rig
            if rig is not None:
                rig.safe_state()
        self._worker.shutdown(wait=False, cancel_futures=True)

    # -- set points -------------------------------------------------------------------------
    def set_pitch_deg(self, pitch_deg: float) -> Future:
        """Move the strut to ``pitch_deg`` (degrees at the edge; radians inside)."""
        return self.submit(
            "set pitch", self._set, "set pitch", "set_pitch", math.radians(pitch_deg)
        )

    def set_tunnel_velocity(self, velocity_m_s: float) -> Future:
        """Set the tunnel velocity, m/s."""
        return self.submit(
            "set tunnel speed", self._set, "set tunnel speed", "set_tunnel_velocity", velocity_m_s
        )

    def set_flapping_frequency(self, frequency_hz: float) -> Future:
        """Set the flapping frequency, Hz."""
        return self.submit(
            "set flapping frequency",
            self._set,
            "set flapping frequency",
            "set_flapping_frequency",
            frequency_hz,
        )

    def _set(self, action: str, method: str, value: float) -> None:
        rig = self._require_rig()
        self._require_idle(action)
        getattr(rig, method)(value)
        key, to_user, unit = _COMMANDED[method]
        self.commanded[key] = value
        recording = self.recording
        if recording is not None and method == "set_flapping_frequency":
            recording.motor_log.commanded(
                value, rig.balance_samples_since_start(), recording.stream
            )
            if value == 0.0:  # the drift clock needs the stop: wait for it while reading the motor
                self._wait_motor_at_rest(rig, recording)
        self.post("info", f"{action}: {to_user(value):.3f} {unit}")

    def _wait_motor_at_rest(self, rig: Rig, recording: ManualRecording | None) -> None:
        criteria = SettleCriteria()
        started_s = rig.now_s()
        while (frequency_hz := rig.read_flapping_frequency_hz()) > criteria.frequency_tolerance_hz:
            if recording is not None:
                recording.observe_motor(True)
            if rig.now_s() - started_s > WIND_OFF_TIMEOUT_S:
                raise InstrumentError(
                    "motor",
                    f"still flapping at {frequency_hz:.2f} Hz after {WIND_OFF_TIMEOUT_S:g} s",
                )
            rig.wait_simulated_s(0.1)
        if recording is not None:
            recording.observe_motor(False)

    # -- tare and recording -------------------------------------------------------------------
    def tare(self, record_s: float) -> Future:
        """Wind-off tare at the current pitch: fan and motor to rest, then average ``record_s`` of gauges."""
        return self.submit("tare", self._tare, record_s)

    def _wait_wind_off(self, rig: Rig) -> None:
        rig.set_tunnel_velocity(0.0)
        rig.set_flapping_frequency(0.0)
        self.commanded.update(tunnel_velocity_m_s=0.0, flapping_frequency_hz=0.0)
        self._wait_motor_at_rest(rig, self.recording)
        criteria = SettleCriteria()
        started_s = rig.now_s()
        while rig.read_tunnel_velocity_m_s() > criteria.velocity_tolerance_m_s:
            if rig.now_s() - started_s > WIND_OFF_TIMEOUT_S:
                raise InstrumentError("tunnel", f"fan not at rest within {WIND_OFF_TIMEOUT_S:g} s")
            rig.wait_simulated_s(0.1)

    def _measure(self, rig: Rig, record_s: float):
        assert self.live is not None
        scale = rig.time_scale
        return self.live.measure(record_s, timeout_s=record_s / scale + 10.0)

    def _tare(self, record_s: float) -> None:
        rig = self._require_rig()
        self._require_idle("tare")
        self._wait_wind_off(rig)
        pitch_rad = self._set_value("pitch_rad", rig.read_pitch_rad)
        rows = self._measure(rig, record_s)
        self.tare_volts, self.tare_pitch_rad = rows.mean_volts[:6].copy(), pitch_rad
        recording = self.recording
        where = "display only: no run is recording, so processing cannot use it"
        if recording is not None:
            self._record(recording, SET_POINT_KIND_TARE, record_s, pitch_rad, 0.0, 0.0)
            recording.tare_pitches_rad.append(pitch_rad)
            where = f"in run {recording.recorder.run_id}"
        self.post(
            "tare",
            f"wind-off tare at theta = {math.degrees(pitch_rad):.2f} deg over {rows.rows} samples ({where})",
            self.tare_volts,
        )

    def _set_value(self, key: str, read: Callable[[], float]) -> float:
        """The set point a record journals for ``key``: the value last commanded from the window, else the
        instrument's reading. A reading off the commanded value by more than the settle tolerance (a move still
        under way, or a strut halted by a tail change or an emergency stop) refuses the record, naming both."""
        reading = read()
        if key not in self.commanded:
            return reading
        commanded = self.commanded[key]
        tolerance, to_user, unit = _SETTLED[key]
        if abs(reading - commanded) > tolerance:
            raise UserInputError(
                "record",
                f"the rig is not at its set point: {_NAMES[key]} reads {to_user(reading):.2f} {unit}, set "
                f"{to_user(commanded):.2f} {unit}; wait until it settles or set it again",
            )
        return commanded

    def start_recording(self, tail_id: str, x_h_mm: float, tailed: bool) -> Future:
        """Open a manual run for this configuration (the tail is fitted or removed first if needed)."""
        return self.submit("start recording", self._start_recording, tail_id, x_h_mm, tailed)

    def _start_recording(self, tail_id: str, x_h_mm: float, tailed: bool) -> None:
        rig = self._require_rig()
        self._require_idle("record")
        if self.recording is not None:
            raise UserInputError("record", "a recording is already running: stop it first")
        if not tail_id.strip():
            raise UserInputError("tail id", "empty: name the tail (e.g. S3)")
        if not (math.isfinite(x_h_mm) and x_h_mm > 0):
            raise UserInputError("x_h (mm)", f"{x_h_mm!r} must be a positive number")
        rig.mount_vehicle(tail_id.strip(), x_h_mm / 1000.0)
        if tailed != self.tail_attached:
            self.change_tail(rig, tailed)
        assert self.live is not None
        recorder = Recorder(
            self.data_root,
            RunConfiguration(tail_id.strip(), x_h_mm / 1000.0, tailed, plan_name="manual"),
            balance_stream_layout(self.live.sample_rate_hz),
            rig_description=rig.recording_description(),
            calibration_files=rig.calibration_files(),
        )
        closing = ExitStack()
        run = closing.enter_context(open_run(recorder, self.documents, set_points_planned=0))
        # A run that cannot start recording is closed at once, as failed:
        with ExitStack() as on_failure:
            on_failure.push(closing)
            recording = ManualRecording(run, closing, rig, self.live, tailed)
            recording.motor_log.running = rig.read_flapping_frequency_hz() > 0.0
            self.live.attach(recorder)
            recording.motor_log.start_run()
            on_failure.pop_all()
        self.recording = recording
        self.post(
            "info",
            f"recording run {recorder.run_id}: take a wind-off tare at each pitch before its points",
        )

    def change_tail(self, rig: Rig, tailed: bool) -> None:
        """Fit or remove the tail (motor and fan are brought to rest first)."""
        rig.change_tail(tailed, self._operator_prompt)
        self.tail_attached = tailed
        self.tare_volts = None

    def record_point(self, record_s: float) -> Future:
        """Record ``record_s`` at the current set point as a measurement of the manual run."""
        return self.submit("record point", self._record_point, record_s)

    def _record_point(self, record_s: float) -> None:
        rig = self._require_rig()
        recording = self.recording
        if recording is None:
            raise UserInputError("record point", "no recording running: start one first")
        pitch_rad = self._set_value("pitch_rad", rig.read_pitch_rad)
        if not recording.has_tare_at(pitch_rad):
            raise UserInputError(
                "record point",
                f"this run has no wind-off tare at theta = {math.degrees(pitch_rad):.2f} deg: take one first "
                "(processing subtracts a tare of the same run at the same pitch)",
            )
        self._record(
            recording,
            SET_POINT_KIND_MEASUREMENT,
            record_s,
            pitch_rad,
            self._set_value("tunnel_velocity_m_s", rig.read_tunnel_velocity_m_s),
            self._set_value("flapping_frequency_hz", rig.read_flapping_frequency_hz),
        )

    def _record(
        self,
        recording: ManualRecording,
        kind: str,
        record_s: float,
        pitch_rad: float,
        velocity_m_s: float,
        frequency_hz: float,
    ) -> None:
        """Record ``record_s`` from now on into the manual run as its next set point (commanded values, SI): a
        one-step plan run inside the open run."""
        point = SetPoint(
            index=recording.points,
            kind=kind,  # type: ignore[arg-type]
            sweep="manual" if kind == SET_POINT_KIND_MEASUREMENT else "tare",
            tail_attached=recording.tailed,
            pitch_rad=pitch_rad,
            tunnel_velocity_m_s=velocity_m_s,
            flapping_frequency_hz=frequency_hz,
            repeat=0,
            record_s=record_s,
        )
        run_plan((RecordSetPoint(point),), recording, self.documents, run=recording.run)
        record = recording.last_record
        assert record is not None
        rows = record.last_sample_index - record.first_sample_index + 1
        lost = (
            f", {record.samples_missing_in_record} samples lost inside it after its retakes"
            if record.samples_missing_in_record
            else ""
        )
        self.post("info", f"recorded {kind} #{point.index}: {rows} samples{lost}")

    def stop_recording(self) -> Future:
        """Close the manual run (``completed``)."""
        return self.submit("stop recording", self._stop_recording, None)

    def _stop_recording(self, abort_reason: str | None) -> None:
        recording = self.recording
        if recording is None:
            return
        try:
            # The run's stop record and stop document are written whatever is raised in this block:
            with recording.closing:
                if self.live is not None:
                    self.live.detach()
                if abort_reason is not None:
                    recording.recorder.mark_aborted(abort_reason)
        finally:  # only once the stop record is written: the window reads this as "run closed"
            self.recording = None
        status = "aborted" if abort_reason else "completed"
        self.post(
            "info",
            f"run {recording.recorder.run_id} {status} with {recording.points} set point(s)",
        )

    # -- sweeps -----------------------------------------------------------------------------
    def start_sweep(self, plan_file: Path, resume: bool = False) -> Future:
        """Run (or resume) a sweep plan; it records through the live balance stream, so the display goes on."""
        return self.submit("sweep", self._start_sweep, Path(plan_file), resume)

    def _start_sweep(self, plan_file: Path, resume: bool) -> None:
        rig = self._require_rig()
        self._require_idle("sweep")
        if self.recording is not None:
            raise UserInputError("sweep", "a manual recording is running: stop it first")
        plan = load_plan(plan_file)
        self.sweep = SweepRunner(
            plan,
            rig,
            self.data_root,
            resume=resume,
            balance_stream=self.live,
            documents=self.documents,
            on_event=lambda event: self.post("sweep_event", _event_text(event), event),
            on_done=self._sweep_done,
            operator_prompt=self._operator_prompt,
        )
        self.sweep.start()
        self.post("info", f"sweep {plan.name}: {len(plan.set_points)} set points")

    def _sweep_done(self, outcome: SweepResult | BaseException) -> None:
        if isinstance(outcome, BaseException):
            kind = "user_error" if isinstance(outcome, UserInputError) else "error"
            self.post(kind, f"sweep: {outcome}")
            outcome = SweepResult(status="failed", message=str(outcome))
        self.post("sweep_done", f"sweep {outcome.status}: {outcome.message}", outcome)
        self.submit("restart the live view", self._restart_live)

    def _restart_live(self) -> None:
        if self.live is not None and not self.live.running and self.rig is not None:
            self.live.start()

    def pause_sweep(self) -> None:
        """Finish the current set point, then stop (resumable)."""
        if self.sweep_running:
            assert self.sweep is not None
            self.sweep.pause()
            self.post("info", "sweep pausing after the current set point")

    def abort_sweep(self) -> None:
        """Stop the sweep now (the run ends ``aborted``; completed points stay)."""
        if self.sweep_running:
            assert self.sweep is not None
            self.sweep.abort()
            self.post("info", "sweep aborting")

    def _operator_prompt(self, instruction: str) -> None:
        done = threading.Event()
        self.post("prompt", instruction, done)
        done.wait()

    # -- emergency stop -----------------------------------------------------------------------
    def emergency_stop(self) -> threading.Thread:
        """Abort any sweep, end any manual recording as aborted, motor off and fan to zero, now."""
        thread = threading.Thread(target=self._emergency_stop, name="emergency-stop", daemon=True)
        thread.start()
        return thread

    def _emergency_stop(self) -> None:
        rig = self.rig
        if rig is None:
            return
        if self.sweep_running:
            assert self.sweep is not None
            self.sweep.abort()
        errors = rig.safe_state()
        started = time.monotonic()
        while self.sweep_running and time.monotonic() - started < 10.0:
            time.sleep(0.02)
        errors += rig.safe_state()  # again, after the sweep thread let go of the rig
        for error in errors:
            self.post("error", f"emergency stop: {error}")
        self.submit("emergency stop", self._stop_recording, "emergency stop")
        self.post("info", "EMERGENCY STOP: motor off, fan stopped, strut halted")


_SETTLED = {
    "pitch_rad": (SettleCriteria.pitch_tolerance_rad, math.degrees, "deg"),
    "tunnel_velocity_m_s": (SettleCriteria.velocity_tolerance_m_s, float, "m/s"),
    "flapping_frequency_hz": (SettleCriteria.frequency_tolerance_hz, float, "Hz"),
}
"""Set-point key -> how far a reading may be from it (a sweep's default settle tolerance), unit conversion, unit."""
_NAMES = {
    "pitch_rad": "pitch",
    "tunnel_velocity_m_s": "tunnel speed",
    "flapping_frequency_hz": "flapping frequency",
}
_COMMANDED = {
    "set_pitch": ("pitch_rad", math.degrees, "deg"),
    "set_tunnel_velocity": ("tunnel_velocity_m_s", float, "m/s"),
    "set_flapping_frequency": ("flapping_frequency_hz", float, "Hz"),
}
"""Rig method -> key of :attr:`RigSession.commanded`, conversion to the window's unit, that unit."""


def _event_text(event: SweepEvent) -> str:
    point = "" if event.set_point is None else f" {event.set_point.label}"
    return f"{event.stage.replace('_', ' ')}{point}"
