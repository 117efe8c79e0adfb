"""Run a sweep plan on a rig: move, settle, record, journal; resumable; always ending in a safe state.

One sweep records one run per tail state (the tailed run, then the tailless run), each a recording directory
with its own journal and stop record. The runs of one sweep form a chain through ``resumed_from_run_id``, and
``resume=True`` continues the newest chain of the same plan with the set points it lacks, in new runs, each with
the wind-off tares that bracket it recorded again (:func:`~ornitail.acquisition.sweep_plan.zero_references`): a
point's zero comes from its own run, not from another stream taken minutes or hours before.

The balance streams without pause for the whole of a run, moves and settling included, so the sample counter
never jumps; every set point is a range of rows in that stream. Stopping:

- :meth:`SweepStop.request` (the first Ctrl-C) finishes the current set point and then ends the run as
  ``aborted``;
- :meth:`SweepStop.abort` (the window's Abort) ends it at its next wait, also as ``aborted``; the point in
  progress is dropped;
- a ``KeyboardInterrupt`` (the second Ctrl-C) ends it at once, also as ``aborted``;
- an instrument error (unplugged, no reply) ends it as ``failed`` with the instrument named.

A point whose record still lost samples after ``MAX_RETAKES`` retakes is journalled as it is (with what it lost)
and the sweep goes on; its run and the sweep end as ``incomplete`` naming it, and ``resume=True`` records it
again. A record with saturated or over-range samples is kept, with a warning (processing refuses it).

Whatever happens, motor and fan are brought to a safe state and every completed set point stays on disk.

A sweep is a plan handed to the run engine: :func:`~ornitail.acquisition.recording_plan.sweep_steps` makes the
plan's steps (tail changes, runs, moves and settles, records) from the sweep plan and what the chain holds, and
:func:`~ornitail.acquisition.run_engine.run_plan` runs them with the sweep's performer (:class:`_SweepContext`:
what each step does on the rig). Every run is opened by :func:`~ornitail.acquisition.run_engine.open_run`: it
emits its start, set point and stop documents (:mod:`ornitail.acquisition.run_documents`) to the subscribers of
the ``documents`` dispatcher given to :func:`run_sweep` (the stop document whatever ends the run), and the
catalog subscriber keeps its row. Each set
point document carries the sweep's progress (set points of the chain done, in the plan, time left) and the
warning lines about its record (:func:`record_warnings`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from ornitail.acquisition.catalog import RunCatalog, RunFilter
from ornitail.acquisition.exclusive_locks import ExclusiveLock, LockHeld
from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.live_balance import LiveBalance, balance_stream_layout
from ornitail.acquisition.motor_running_log import MotorRunningLog
from ornitail.acquisition.recorder import Recorder, RunAborted
from ornitail.acquisition.recording_layout import (
    RunConfiguration,
    SetPointRecord,
)
from ornitail.acquisition.recording_plan import StartRun, sweep_steps
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.run_documents import DocumentDispatcher, PlanProgress
from ornitail.acquisition.run_engine import OpenRun, run_plan
from ornitail.acquisition.run_files import read_journal, run_is_live
from ornitail.acquisition.set_point_recording import POLL_INTERVAL_S
from ornitail.acquisition.sweep_plan import (
    SetPoint,
    SweepPlan,
    limit_violations,
    motor_rpm_violations,
    sample_rate_violation,
    zero_references,
)
from ornitail.core.errors import UserInputError


class SweepStop:
    """Thread-safe stop requests: after the current set point (the first Ctrl-C), or now (the GUI's Abort).

    Both are flags the sweep reads between its short waits (at most ``POLL_INTERVAL_S`` of rig time apart), so a
    stop never lands inside a driver transaction or a file write.
    """

    def __init__(self) -> None:
        self._after_point = threading.Event()
        self._now = threading.Event()

    def request(self) -> None:
        """Ask the sweep to stop once the current set point is recorded."""
        self._after_point.set()

    def abort(self) -> None:
        """Ask the sweep to stop at its next wait; the set point in progress is dropped."""
        self._after_point.set()
        self._now.set()

    @property
    def requested(self) -> bool:
        """True once :meth:`request` or :meth:`abort` was called."""
        return self._after_point.is_set()

    @property
    def abort_requested(self) -> bool:
        """True once :meth:`abort` was called."""
        return self._now.is_set()


class SettleTimeout(InstrumentError):
    """A set point was not reached within the plan's settle timeout."""


@dataclass(frozen=True)
class SweepEvent:
    """What a sweep is doing between its documents, passed to the ``on_event`` callback.

    The sweep's progress (set points done, time left) and its warnings are in the run documents
    (:mod:`ornitail.acquisition.run_documents`); an event says what the documents do not: the point under way
    while it moves and settles, and a tail change.

    Attributes
    ----------
    stage : str
        ``"moving"``, ``"settled"``, ``"recorded"`` (after its set point document) or ``"tail_change"``.
    set_point : SetPoint or None
        The point concerned (None at a tail change).
    """

    stage: str
    set_point: SetPoint | None


@dataclass
class SweepResult:
    """What a sweep did.

    Attributes
    ----------
    status : str
        ``"completed"``, ``"incomplete"`` (every point visited, but ``incomplete_points`` still lost samples
        after their retakes: ``resume=True`` records them again), ``"aborted"`` or ``"failed"`` (the last
        with ``message`` naming the cause).
    run_directories : list of pathlib.Path
        Every run of the sweep's chain, oldest first (earlier runs of a resumed sweep included).
    completed_points, total_points : int
        Set points recorded so far in the chain, and in the plan.
    message : str
        One line for the operator.
    incomplete_points : list of int
        Plan indices of the points whose kept record lost samples (not counted in ``completed_points``).
    warnings : list of str
        One line per recorded point with saturated or over-range samples, or still lossy.
    """

    status: str
    run_directories: list[Path] = field(default_factory=list)
    completed_points: int = 0
    total_points: int = 0
    message: str = ""
    incomplete_points: list[int] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def check_plan_against_rig(plan: SweepPlan, rig: Rig) -> None:
    """Raise :class:`UserInputError` listing every set point outside the rig's limits.

    Checked before anything connects or moves: pitch, velocity and frequency limits, the motor rpm
    every flapping frequency needs (f * 60 * gear ratio <= ``[limits].max_motor_rpm``) and the
    sample rate the balance board can do at the rig's baud rate.
    """
    description = rig.description
    violations = limit_violations(plan, rig.set_point_limits())
    violations += motor_rpm_violations(
        plan,
        description.gear_ratio,
        description.limits.max_motor_rpm,
        description.limits.flapping_frequency_max_hz,
    )
    rate_problem = sample_rate_violation(plan, description.balance_sample_rate_ceiling_hz())
    problems = [rate_problem] if rate_problem is not None else []
    if violations:
        problems.insert(
            0,
            f"{len(violations)} set point(s) outside the rig's limits ({description.path}): "
            + "; ".join(violations),
        )
    elif problems:
        problems[0] += f" ({description.path})"
    if problems:
        raise UserInputError(plan.source, "; ".join(problems))
    if not rig.description.carries_flap_channels:
        raise UserInputError(
            f"{rig.description.path}: [balance].route",
            'sweeps record the Hall line and the hot-wire with the balance; use route = "serial_daq", or add '
            "the serial board beside the CAN or Net F/T balance as [balance.aux_daq]",
        )


def previous_sweep_chain(catalog: RunCatalog, plan: SweepPlan) -> list[Path]:
    """Run directories of the newest sweep of ``plan`` (same plan name, tail and x_h), oldest first.

    The catalog is reconciled with the run directories first, so a run whose catalog row is stale or missing
    (the catalog was locked while it recorded) is found as its ``run.json`` says.
    """
    matching, _ = catalog.runs_reconciled(RunFilter(tail_id=plan.tail_id, x_h_m=plan.x_h_m))
    runs = [run for run in matching if run.plan_name == plan.name]
    if not runs:
        return []
    by_id = {run.run_id: run for run in runs}
    newest = max(runs, key=lambda run: run.start_time_utc)
    chain = [newest]
    while chain[-1].resumed_from_run_id in by_id:
        chain.append(by_id[chain[-1].resumed_from_run_id])
    return [catalog.data_root / run.run_directory for run in reversed(chain)]


def completed_plan_points(run_directories: Iterable[Path], plan: SweepPlan) -> set[int]:
    """Plan indices of the set points of ``plan`` journalled with a whole record in these runs: a tare whole, a
    measurement whole with the tares that zero it (:func:`zero_references`) whole in its own run. A record that
    still lost samples after its retakes does not count, nor does a measurement whose tare did: a resume
    records them again."""
    done: set[int] = set()
    for directory in run_directories:
        whole = {
            record.plan_point_index
            for record in read_journal(Path(directory))
            if record.samples_missing_in_record == 0
        }
        for index in whole:
            if index >= len(plan.set_points) or plan.set_points[index].index != index:
                continue  # not a point of this plan
            if (
                plan.set_points[index].kind == "tare"
                or zero_references(plan.set_points, {index}) <= whole
            ):
                done.add(index)
    return done


class SweepChainBusy(UserInputError):
    """Another process (or thread) is recording this plan's chain of runs; the message names it."""


SWEEP_LOCK_FOLDER = "locks"
"""Folder under the data root that holds one lock file per chain of runs (plan name, tail, x_h)."""
_chains_held: dict[Path, tuple[int, int]] = {}  # lock path -> (owning thread id, nesting depth)
_chains_held_guard = threading.Lock()


def sweep_chain_lock_path(data_root: Path, plan: SweepPlan) -> Path:
    """The lock file of the chain of runs of ``plan`` (same plan name, tail and x_h) under ``data_root``."""
    key = json.dumps([plan.name, plan.tail_id, round(plan.x_h_m, 9)])
    digest = hashlib.sha256(key.encode("utf-8")).hexdigest()[:12]
    slug = re.sub(r"[^A-Za-z0-9._-]+", "_", plan.name).strip("_.")[:40] or "plan"
    return Path(data_root) / SWEEP_LOCK_FOLDER / f"sweep-{slug}-{digest}.lock"


def _chain_busy_message(data_root: Path, plan: SweepPlan, held: LockHeld) -> str:
    holder = held.holder.describe() if held.holder else "another process"
    live: list[str] = []
    try:
        live = [
            directory.name
            for directory in previous_sweep_chain(RunCatalog(data_root), plan)
            if run_is_live(directory)
        ]
    except Exception:  # the catalog is busy or unreadable: name the process only
        live = []
    run = f"run {live[-1]}" if live else "no run open at this moment (between runs)"
    stop_hint = f"`kill -TERM {held.holder.pid}`" if held.holder and held.holder.pid else "Ctrl-C"
    return (
        f"sweep {plan.name!r} (tail {plan.tail_id}, x_h {plan.x_h_m * 1000:g} mm) is being recorded by "
        f"{holder}: {run} in {Path(data_root) / 'runs'}; wait for it to end or stop it ({stop_hint}) "
        "before starting or resuming it"
    )


@contextmanager
def holding_sweep_chain(data_root: Path, plan: SweepPlan) -> Iterator[None]:
    """Hold the chain lock of ``plan`` under ``data_root`` for the block (re-entrant within one thread).

    Raises
    ------
    SweepChainBusy
        Another process or thread holds it (a sweep or a ``--resume`` of the same chain is running); the
        message names the process and the run it records.
    """
    path = sweep_chain_lock_path(data_root, plan).resolve()
    me = threading.get_ident()
    with _chains_held_guard:
        owner, depth = _chains_held.get(path, (None, 0))
        if owner == me:
            _chains_held[path] = (me, depth + 1)
            nested = True
        else:
            nested = False
    if nested:
        try:
            yield
        finally:
            with _chains_held_guard:
                _chains_held[path] = (me, _chains_held[path][1] - 1)
        return
    lock = ExclusiveLock(path)
    try:
        lock.acquire(
            detail=f"sweep {plan.name} (tail {plan.tail_id}, x_h {plan.x_h_m * 1000:g} mm)"
        )
    except LockHeld as held:
        raise SweepChainBusy(str(plan.source), _chain_busy_message(data_root, plan, held)) from None
    with _chains_held_guard:
        _chains_held[path] = (me, 1)
    try:
        yield
    finally:
        with _chains_held_guard:
            _chains_held.pop(path, None)
        lock.release()


_Sweep = TypeVar("_Sweep", bound=Callable[..., "SweepResult"])


def _holding_the_chain(sweep: _Sweep) -> _Sweep:
    """Run ``sweep(plan, rig, data_root, ...)`` holding the plan's chain lock (see :func:`holding_sweep_chain`)."""

    @functools.wraps(sweep)
    def locked(
        plan: SweepPlan, rig: Rig, data_root: Path, *args: Any, **kwargs: Any
    ) -> SweepResult:
        with holding_sweep_chain(Path(data_root), plan):
            return sweep(plan, rig, data_root, *args, **kwargs)

    return locked  # type: ignore[return-value]


@dataclass
class _SweepContext:
    """A sweep's :class:`~ornitail.acquisition.run_engine.PlanPerformer`: what each step of its plan does on the
    rig, and what the sweep counts meanwhile (set points done, durations, warnings, lossy points, its runs)."""

    plan: SweepPlan
    rig: Rig
    stop: SweepStop
    on_event: Callable[[SweepEvent], None]
    completed: int
    stream: LiveBalance
    data_root: Path
    operator_prompt: Callable[[str], None]
    run_directories: list[Path]
    previous_run_id: str | None
    durations_s: list[float] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    lossy_points: dict[int, str] = field(default_factory=dict)  # plan index -> what it lost
    recorded_before: set[int] = field(
        default_factory=set
    )  # plan indices whole in earlier runs of the chain
    motor_log: MotorRunningLog = field(default_factory=MotorRunningLog)
    point_started_s: float = 0.0  # rig time the point under way began to move, s
    run_points: list[SetPoint] = field(
        default_factory=list
    )  # the points recorded into the open run

    def observe_motor(self, running: bool) -> None:
        """Note a reading of the motor (running or standing) for the drift clock."""
        self.motor_log.observe(running, self.rig.balance_samples_since_start(), self.stream)

    def wait_rig_s(self, seconds: float) -> None:
        """Wait ``seconds`` of rig time, then check the balance stream for errors and the stop for an abort."""
        self.rig.wait_simulated_s(seconds)
        self.stream.raise_if_failed()
        if self.stop.abort_requested:
            raise RunAborted("aborted by the operator")

    def eta_s(self) -> float:
        remaining = (
            self.plan.set_points[self.completed :] if self.completed else self.plan.set_points
        )
        typical_s = (
            sum(self.durations_s) / len(self.durations_s)
            if self.durations_s
            else self.plan.record_s + self.plan.settle.stable_for_s + 5.0
        )
        return typical_s * len(remaining)

    def count(self, point: SetPoint, started_s: float, record: SetPointRecord) -> PlanProgress:
        """Count ``point``'s ``record`` (moved to from rig time ``started_s``, s) into the sweep: done unless it
        is still lossy or was done in an earlier run of the chain; where the sweep stands then."""
        if record.samples_missing_in_record:
            self.lossy_points[point.index] = (
                f"set point {point.label} lost {record.samples_missing_in_record} samples "
                f"inside its record after {record.extra['retakes']} retakes"
            )
        else:
            self.lossy_points.pop(point.index, None)
            if point.index not in self.recorded_before:
                self.completed += 1
        self.durations_s.append(self.rig.now_s() - started_s)
        return PlanProgress(self.completed, len(self.plan.set_points), self.eta_s())

    def emit(self, stage: str, point: SetPoint | None) -> None:
        self.on_event(SweepEvent(stage, point))

    def warn(self, point: SetPoint, record: SetPointRecord) -> list[str]:
        """The warning lines about ``point``'s ``record`` (:func:`record_warnings`), kept for the result; they go
        into its set point document."""
        lines = record_warnings(point, record)
        self.warnings.extend(lines)
        return lines

    # -- the plan's steps -------------------------------------------------------------------------------------
    def change_tail(self, tail_attached: bool) -> None:
        """Fit or remove the tail (a person acts on a real rig)."""
        self.emit("tail_change", None)
        self.rig.change_tail(tail_attached, self.operator_prompt)

    def recorder(self, step: StartRun) -> Recorder:
        """The recorder of the sweep's next run, resumed from its previous one."""
        configuration = RunConfiguration(
            tail_id=self.plan.tail_id,
            x_h_m=self.plan.x_h_m,
            tailed=step.tailed,
            plan_name=self.plan.name,
            resumed_from_run_id=self.previous_run_id,
        )
        return Recorder(
            self.data_root,
            configuration,
            balance_stream_layout(self.plan.sample_rate_hz),
            rig_description=self.rig.recording_description(),
            calibration_files=self.rig.calibration_files(),
            display_decimation=None,
        )

    def progress(self) -> PlanProgress:
        """Where the sweep stands as a run starts."""
        return PlanProgress(self.completed, len(self.plan.set_points), self.eta_s())

    @contextmanager
    def recording_into(self, run: OpenRun) -> Iterator[None]:
        """Stream the balance into ``run`` for the block; a run that ends with points still lossy after their
        retakes is marked incomplete, naming them."""
        recorder = run.recorder
        self.run_directories.append(recorder.run_directory)
        self.previous_run_id = recorder.run_id
        self.run_points = []
        stream = self.stream
        if not stream.running or stream.sample_rate_hz != self.plan.sample_rate_hz:
            stream.stop()
            stream.start(self.plan.sample_rate_hz)
        stream.attach(recorder)
        self.motor_log.start_run()
        try:
            yield
            lossy = [
                self.lossy_points[p.index] for p in self.run_points if p.index in self.lossy_points
            ]
            if lossy:
                recorder.mark_incomplete(
                    "; ".join(lossy) + "; resuming the sweep records these points again"
                )
        finally:
            stream.detach()

    def move_and_settle(self, point: SetPoint) -> float:
        """Move to ``point`` and wait until it holds; the rig time it took to settle, s. A stop requested before
        it ends the run."""
        if self.stop.requested:
            raise RunAborted(f"stopped by the operator before set point #{point.index}")
        self.point_started_s = self.rig.now_s()
        self.emit("moving", point)
        _move(self.rig, point)
        self.motor_log.commanded(
            point.flapping_frequency_hz, self.rig.balance_samples_since_start(), self.stream
        )
        settle_s = _settle(self, point)
        self.emit("settled", point)
        return settle_s

    def record(self, run: OpenRun, point: SetPoint, settle_s: float | None) -> None:
        """Record ``point`` into ``run``, counted into the sweep, with its warnings in its document."""
        run.record(
            self,
            point,
            self.plan.sample_rate_hz,
            settle_s,
            progress=functools.partial(self.count, point, self.point_started_s),
            warnings=functools.partial(self.warn, point),
        )
        self.run_points.append(point)
        self.emit("recorded", point)

    def run_stopped(self) -> None:
        """A stop requested during the run just closed ends the sweep, unless every point is done."""
        if self.stop.requested and self.completed < len(self.plan.set_points):
            raise RunAborted("stopped by the operator")


def _move(rig: Rig, point: SetPoint) -> None:
    rig.set_pitch(point.pitch_rad)
    rig.set_tunnel_velocity(point.tunnel_velocity_m_s)
    rig.set_flapping_frequency(point.flapping_frequency_hz)


def _settle(context: _SweepContext, point: SetPoint) -> float:
    """Wait until pitch, velocity and frequency stay within tolerance; return the rig time it took, s."""
    rig, criteria = context.rig, context.plan.settle
    targets = (
        (
            "pitch",
            rig.read_pitch_rad,
            point.pitch_rad,
            criteria.pitch_tolerance_rad,
            math.degrees,
            "deg",
        ),
        (
            "tunnel velocity",
            rig.read_tunnel_velocity_m_s,
            point.tunnel_velocity_m_s,
            criteria.velocity_tolerance_m_s,
            float,
            "m/s",
        ),
        (
            "flapping frequency",
            rig.read_flapping_frequency_hz,
            point.flapping_frequency_hz,
            criteria.frequency_tolerance_hz,
            float,
            "Hz",
        ),
    )
    started_s = rig.now_s()
    stable_since_s: float | None = None
    while True:
        readings = [
            (name, read(), target, tolerance, to_user, unit)
            for name, read, target, tolerance, to_user, unit in targets
        ]
        context.observe_motor(
            next(value for name, value, *_ in readings if name == "flapping frequency") > 0.0
        )
        off = [reading for reading in readings if abs(reading[1] - reading[2]) > reading[3]]
        now_s = rig.now_s()
        if off:
            stable_since_s = None
            if now_s - started_s > criteria.timeout_s:
                name, value, target, _, to_user, unit = off[0]
                raise SettleTimeout(
                    name,
                    f"set point #{point.index} not reached within {criteria.timeout_s:g} s: reads "
                    f"{to_user(value):.3f} {unit}, set {to_user(target):.3f} {unit}",
                )
        elif stable_since_s is None:
            stable_since_s = now_s
        elif now_s - stable_since_s >= criteria.stable_for_s:
            return now_s - started_s
        context.wait_rig_s(POLL_INTERVAL_S)


def record_warnings(point: SetPoint, record: SetPointRecord) -> list[str]:
    """One warning line for a record of ``point`` with saturated or over-range rows, one for a record still lossy
    after its retakes (none for a clean record)."""
    rows = record.last_sample_index - record.first_sample_index + 1
    lines = []
    if record.is_flagged:
        lines.append(
            f"warning: set point {point.label}: {record.saturated_samples} of {rows} samples saturated (a "
            f"channel at the ADC limit or the board's over-range flag), {record.over_range_samples} over the "
            "balance's rated load; `ornitail process` refuses this point",
        )
    if record.samples_missing_in_record:
        lines.append(
            f"warning: set point {point.label}: {record.samples_missing_in_record} of {rows} samples still "
            f"lost inside the record after {record.extra['retakes']} retakes; the run ends incomplete and "
            "resuming the sweep records the point again",
        )
    return lines


@_holding_the_chain
def run_sweep(
    plan: SweepPlan,
    rig: Rig,
    data_root: Path,
    *,
    resume: bool = False,
    stop: SweepStop | None = None,
    on_event: Callable[[SweepEvent], None] | None = None,
    operator_prompt: Callable[[str], None] | None = None,
    balance_stream: LiveBalance | None = None,
    documents: DocumentDispatcher | None = None,
) -> SweepResult:
    """Run ``plan`` on a connected ``rig``, recording under ``data_root``.

    Parameters
    ----------
    plan : SweepPlan
        The checked plan (see :func:`ornitail.acquisition.sweep_plan.load_plan`).
    rig : Rig
        A connected rig.
    data_root : pathlib.Path
        Where runs and the catalog live.
    resume : bool
        Continue the newest sweep of this plan at its first unfinished set point.
    stop : SweepStop, optional
        Set it (e.g. on the first Ctrl-C) to stop after the current point.
    on_event : callable, optional
        Receives a :class:`SweepEvent` at every stage: the point under way, tail changes.
    operator_prompt : callable, optional
        Called with an instruction when a person must act (fit or remove the tail on a real rig).
    balance_stream : LiveBalance, optional
        A balance stream that feeds a display (the GUI's); the sweep records through it and leaves it
        streaming. Without one the sweep streams the balance itself and stops it at the end.
    documents : DocumentDispatcher, optional
        Receives the start, set point and stop documents of every run the sweep records
        (:mod:`ornitail.acquisition.run_documents`); the stop document whatever ends the run. Set point documents
        carry the sweep's progress (:class:`~ornitail.acquisition.run_documents.PlanProgress`) and the warning
        lines about their record (also in the result's ``warnings``).

    Raises
    ------
    UserInputError
        If the plan does not fit the rig (every violation listed), before anything moves.
    InstrumentError
        If an instrument fails; the runs so far keep their data and end as ``failed``.
    KeyboardInterrupt
        Passed on after the run is closed as ``aborted`` and the rig made safe.
    """
    check_plan_against_rig(plan, rig)
    data_root = Path(data_root)
    stop = stop or SweepStop()
    chain = previous_sweep_chain(RunCatalog(data_root), plan) if resume else []
    done = completed_plan_points(chain, plan)
    steps = sweep_steps(plan, done)
    result = SweepResult(
        status="completed",
        run_directories=list(chain),
        completed_points=len(done),
        total_points=len(plan.set_points),
    )
    if not steps:
        result.message = "nothing to do: every set point of this plan is already recorded"
        return result
    stream = balance_stream or LiveBalance(rig, sample_rate_hz=plan.sample_rate_hz)
    context = _SweepContext(
        plan,
        rig,
        stop,
        on_event or (lambda event: None),
        completed=len(done),
        stream=stream,
        data_root=data_root,
        operator_prompt=operator_prompt or _refuse_operator_action,
        run_directories=result.run_directories,
        previous_run_id=chain[-1].name if chain else None,
        recorded_before=done,
    )
    rig.mount_vehicle(plan.tail_id, plan.x_h_m)
    try:
        run_plan(steps, context, documents or DocumentDispatcher())
    except RunAborted as reason:
        result.status, result.message = "aborted", str(reason)
    except InstrumentError as error:
        result.status, result.message = "failed", str(error)
    finally:
        if balance_stream is None:
            try:
                stream.stop()
            except InstrumentError as error:
                # a balance that failed mid-run is already the run's reason
                if result.status == "completed":
                    result.status, result.message = "failed", str(error)
        rig.safe_state()
        result.completed_points = context.completed
        result.warnings = list(context.warnings)
        result.incomplete_points = sorted(context.lossy_points)
    if result.status == "completed" and result.incomplete_points:
        result.status = "incomplete"
        result.message = (
            f"recorded {result.completed_points} of {result.total_points} set points; "
            + "; ".join(context.lossy_points[index] for index in result.incomplete_points)
            + "; resume the sweep to record them"
        )
    elif result.status == "completed":
        result.message = f"recorded {result.completed_points} of {result.total_points} set points"
    return result


def resumed_while_incomplete(sweep: Callable[[bool], SweepResult], resumes: int = 3) -> SweepResult:
    """``sweep(False)``, then ``sweep(True)`` (its resume) while it ends ``incomplete`` (records still lossy after
    their retakes: a host too busy to read the link in time), at most ``resumes`` times, as a user would; the last
    result, whose ``run_directories`` hold the whole chain."""
    result = sweep(False)
    for _ in range(resumes):
        if result.status != "incomplete":
            break
        result = sweep(True)
    return result


def run_sweep_to_completion(
    plan: SweepPlan, rig: Rig, data_root: Path, resumes: int = 3, **options: Any
) -> SweepResult:
    """:func:`run_sweep` resumed while it ends ``incomplete`` (:func:`resumed_while_incomplete`). ``options`` go to
    every call."""
    return resumed_while_incomplete(
        lambda resume: run_sweep(plan, rig, data_root, resume=resume, **options), resumes
    )


def _refuse_operator_action(instruction: str) -> None:
    raise UserInputError(
        "operator", f"this rig needs a person to act ({instruction}) but none was asked"
    )
