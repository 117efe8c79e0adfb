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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ornitail.acquisition.catalog import default_data_root
from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.live_balance import LiveBalance, balance_stream_layout
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import (
    SET_POINT_KIND_MEASUREMENT,
    SET_POINT_KIND_TARE,
    RunConfiguration,
    SetPointRecord,
)
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.sweep import SweepEvent, SweepResult
from ornitail.acquisition.sweep_plan import SettleCriteria, load_plan
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.core.errors import UserInputError
from ornitail.gui.instrument_poller import InstrumentPoller, InstrumentReadings
from ornitail.gui.sweep_runner import SweepRunner

WIND_OFF_TIMEOUT_S = 60.0
"""Rig time the fan and motor get to come to rest before a tare."""
SHUTDOWN_TIMEOUT_S = 60.0
"""Wall time the window waits for the disconnect (sweep aborted, streams stopped, rig closed) when closing, s."""


@dataclass(frozen=True)
class SessionMessage:
    """Something for the window: ``kind`` is ``"info"``, ``"error"`` (instrument or bug), ``"user_error"``
    (a :class:`UserInputError`), ``"sweep_event"``, ``"sweep_done"``, ``"prompt"`` (``payload`` is a
    :class:`threading.Event` to set once the person has acted), ``"connected"`` or ``"tare"``."""

    kind: str
    text: str
    payload: Any = None


@dataclass
class ManualRecording:
    """The manual run being recorded: its recorder and how many points it holds."""

    recorder: Recorder
    tailed: bool
    points: int = 0
    plan_indices: list[int] = field(default_factory=list)


class RigSession:
    """One connected rig as the window uses it.

    Parameters
    ----------
    data_root : pathlib.Path, optional
        Where runs and the catalog are written (default: ``ornitail``'s data root).
    display_decimation : int
        Every n-th balance row goes to the display.
    """

    def __init__(self, data_root: Path | None = None, display_decimation: int = 10) -> None:
        self.data_root = Path(data_root) if data_root is not None else default_data_root()
        self.display_decimation = display_decimation
        self.messages: queue.Queue[SessionMessage] = queue.Queue()
        self.rig: Rig | None = None
        self.live: LiveBalance | None = None
        self.poller: InstrumentPoller | None = None
        self.calibration: AtiCalibration | None = None
        self.tare_volts: np.ndarray | None = None
        self.tare_pitch_rad: float | None = None
        self.tail_attached = True
        self.recording: ManualRecording | None = None
        self.sweep: SweepRunner | None = None
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
                self.post("error", f"{what}: {error}")
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

    # -- connection -------------------------------------------------------------------------
    def connect(self, rig_file: Path, time_scale: float | None = None) -> Future:
        """Connect the rig file's instruments (simulators first for a simulated rig) and start streaming."""
        return self.submit("connect", self._connect, Path(rig_file), time_scale)

    def _connect(self, rig_file: Path, time_scale: float | None) -> None:
        self._disconnect()
        rig = Rig.from_file(rig_file, time_scale=time_scale)
        rig.connect()
        try:
            self.live = LiveBalance(rig, self.display_decimation)
            self.live.start()
        except BaseException:
            rig.close(raise_errors=False)
            self.live = None
            raise
        self.rig = rig
        self.calibration = rig.calibration.with_tool_transform(rig.description.tool_transform)
        self.poller = InstrumentPoller(rig, lambda error: self.post("error", str(error)))
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

    # -- tare and recording -------------------------------------------------------------------
    def tare(self, record_s: float) -> Future:
        """Wind-off tare at the current pitch: fan and motor to rest, then average ``record_s`` of gauges."""
        return self.submit("tare", self._tare, record_s)

    def _wait_wind_off(self, rig: Rig) -> None:
        rig.set_tunnel_velocity(0.0)
        rig.set_flapping_frequency(0.0)
        criteria = SettleCriteria()
        started_s = rig.now_s()
        while (
            rig.read_tunnel_velocity_m_s() > criteria.velocity_tolerance_m_s
            or rig.read_flapping_frequency_hz() > criteria.frequency_tolerance_hz
        ):
            if rig.now_s() - started_s > WIND_OFF_TIMEOUT_S:
                raise InstrumentError(
                    "tunnel", f"fan and motor not at rest within {WIND_OFF_TIMEOUT_S:g} s"
                )
            rig.wait_simulated_s(0.1)

    def _measure(self, rig: Rig, record_s: float):
        assert self.live is not None
        scale = rig.description.time_scale if rig.description.simulated else 1.0
        return self.live.measure(record_s, timeout_s=record_s / scale + 10.0)

    def _tare(self, record_s: float) -> None:
        rig = self._require_rig()
        self._require_idle("tare")
        self._wait_wind_off(rig)
        pitch_rad = rig.read_pitch_rad()
        rows = self._measure(rig, record_s)
        self.tare_volts, self.tare_pitch_rad = rows.mean_volts[:6].copy(), pitch_rad
        self._journal_point(SET_POINT_KIND_TARE, rows, pitch_rad, 0.0, 0.0)
        self.post(
            "tare",
            f"wind-off tare at theta = {math.degrees(pitch_rad):.2f} deg over {rows.rows} samples",
            self.tare_volts,
        )

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
        recorder.__enter__()
        self.recording = ManualRecording(recorder, tailed)
        self.live.attach(recorder)
        self.post("info", f"recording run {recorder.run_id}")

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
        if self.recording is None:
            raise UserInputError("record point", "no recording running: start one first")
        rows = self._measure(rig, record_s)
        self._journal_point(
            SET_POINT_KIND_MEASUREMENT,
            rows,
            rig.read_pitch_rad(),
            rig.read_tunnel_velocity_m_s(),
            rig.read_flapping_frequency_hz(),
        )

    def _journal_point(self, kind, rows, pitch_rad, velocity_m_s, frequency_hz) -> None:
        recording, rig = self.recording, self.rig
        if recording is None or rows.first_row_index is None or rig is None:
            return
        index = recording.points
        recording.recorder.complete_set_point(
            SetPointRecord(
                plan_point_index=index,
                kind=kind,
                first_sample_index=rows.first_row_index,
                last_sample_index=rows.last_row_index,
                pitch_rad=pitch_rad,
                tunnel_velocity_m_s=velocity_m_s,
                flapping_frequency_hz=frequency_hz,
                tail_attached=recording.tailed,
                motor_rpm_mean=rig.motor.read_rpm() if rig.motor is not None else None,
                extra={"sweep": "manual" if kind == SET_POINT_KIND_MEASUREMENT else "tare"},
            )
        )
        recording.points += 1
        self.post("info", f"recorded {kind} #{index}: {rows.rows} samples")

    def stop_recording(self) -> Future:
        """Close the manual run (``completed``)."""
        return self.submit("stop recording", self._stop_recording, None)

    def _stop_recording(self, abort_reason: str | None) -> None:
        recording = self.recording
        if recording is None:
            return
        try:
            if self.live is not None:
                self.live.detach()
            if abort_reason is not None:
                recording.recorder.mark_aborted(abort_reason)
            recording.recorder.__exit__(None, None, None)
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


def _event_text(event: SweepEvent) -> str:
    if event.message:  # a warning: saturated samples, or samples still lost after the retakes
        return event.message
    point = "" if event.set_point is None else f" {event.set_point.label}"
    return f"{event.stage}{point} ({event.completed}/{event.total})"
