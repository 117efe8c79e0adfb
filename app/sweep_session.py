"""Running a sweep plan headless: progress, signal handling, resume, the result record and the exit code.

What ``ornitail sweep`` and the demo run. Exit paths (docs/sweep-plan.md): every one writes the stop record of the
run being recorded and brings motor, fan and strut to their safe state as far as the instruments still answer.

- 0 completed; 4 incomplete (points to record again by resuming); 2 a mistake in the plan, rig file or
  options (one line, nothing moved);
- 3 an instrument failed (absent port, unplugged, no reply; at connect or mid-run): one line naming instrument,
  port and failure, then the summary of what was recorded;
- 5 the rig's ports or the sweep's chain of runs are held by another process (one line naming it; nothing sent);
- 130 Ctrl-C (SIGINT): the first finishes the current set point and stops, the second stops at once;
- 143 SIGTERM (``kill``, ``systemctl stop``) and 129 SIGHUP (terminal closed): stop at once, like a second Ctrl-C.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import signal
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import CodeType, FrameType
from typing import Any

import click

from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.catalog_subscriber import CatalogSubscriber
from ornitail.acquisition.instrument_errors import InstrumentError, InstrumentInUse
from ornitail.acquisition.live_balance import LiveBalance
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.run_documents import (
    Document,
    DocumentDispatcher,
    DocumentName,
    RunStart,
    SetPointDocument,
)
from ornitail.acquisition.sweep import (
    SweepChainBusy,
    SweepEvent,
    SweepResult,
    SweepStop,
    check_plan_against_rig,
    completed_plan_points,
    holding_sweep_chain,
    previous_sweep_chain,
    run_sweep,
)
from ornitail.acquisition.sweep_plan import SweepPlan, load_plan
from ornitail.app.progress import Progress
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import prepare_output_directory

EXIT_ABORTED = 130
"""Ctrl-C (SIGINT, 128 + 2): stopped after the current point (first) or at once (second)."""
EXIT_FAILED = 3
EXIT_INCOMPLETE = 4
"""Every point visited, but some still lost samples after their retakes: ``--resume`` records them again."""
EXIT_BUSY = 5
"""The rig's ports or the sweep's chain of runs are held by another process; nothing was sent or moved."""
END_NOW_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""Signals that stop the sweep at once, like a second Ctrl-C; the exit code is 128 + the signal number."""
REDELIVERY_S = 0.05
"""A signal that arrives while a stop record is written or the rig is made safe is raised this much later."""


class SweepInterrupted(KeyboardInterrupt):
    """The sweep was stopped at once by a signal (a second Ctrl-C, SIGTERM or SIGHUP).

    It is a ``KeyboardInterrupt``, so the recorder ends the run ``aborted`` with this text as the reason
    (``"stopped at once by SIGTERM"``); :attr:`exit_code` is 128 + the signal number (130, 143, 129).
    """

    def __init__(self, signal_number: int) -> None:
        self.signal_number = int(signal_number)
        self.signal_name = signal.Signals(signal_number).name
        self.exit_code = 128 + self.signal_number
        cause = " (second Ctrl-C)" if signal_number == signal.SIGINT else ""
        super().__init__(f"stopped at once by {self.signal_name}{cause}")


def _protected_code() -> frozenset[CodeType]:
    """Code during which an end-now signal is held back: writing a stop record and the catalog's last wait for
    it, making the rig safe."""
    names = (
        (Recorder, ("__enter__", "__exit__", "_finish")),
        (CatalogSubscriber, ("close_run",)),
        (Rig, ("close", "safe_state")),
        (LiveBalance, ("detach", "stop")),
    )
    functions = [getattr(owner, name, None) for owner, members in names for name in members]
    return frozenset(function.__code__ for function in functions if hasattr(function, "__code__"))


class SweepSignals:
    """How ``ornitail sweep`` answers SIGINT, SIGTERM and SIGHUP (installed by :meth:`install`, main thread only).

    - First SIGINT (Ctrl-C): finish the current set point, journal it, stop (the run ends ``aborted``).
    - A second SIGINT, or SIGTERM or SIGHUP at any time: raise :class:`SweepInterrupted` in the main thread, which
      ends the run ``aborted`` naming the signal; the rig is closed (safe state) on the way out.
    - Such a signal arriving while a stop record is being written or the rig made safe (see
      :func:`_protected_code`) is held back and raised ``REDELIVERY_S`` later (:attr:`pending_signal`).
    - Once stopping at once, or once the sweep is over (:meth:`closing`), further signals are noted and
      ignored, so the stop records and the safe state are always completed.
    - SIGHUP also points stdin, stdout and stderr at ``/dev/null`` where they were a terminal: a closed terminal
      would make every later print fail.
    """

    def __init__(self, stop: SweepStop) -> None:
        self.stop = stop
        self.interrupt: SweepInterrupted | None = None
        self.late_signals: list[str] = []
        self._closing = False
        self._pending: int | None = None
        self._timer: threading.Timer | None = None
        self._previous: dict[int, Any] = {}
        self._protected = _protected_code()

    def install(self) -> SweepSignals:
        """Install the handlers (a no-op outside the main thread); returns self."""
        if threading.current_thread() is threading.main_thread():
            for number in (signal.SIGINT, *END_NOW_SIGNALS):
                self._previous[number] = signal.signal(number, self._handle)
        return self

    def restore(self) -> None:
        """Put the previous handlers back."""
        for number, previous in self._previous.items():
            signal.signal(number, previous)
        self._previous.clear()

    @property
    def pending_signal(self) -> int | None:
        """An end-now signal held back and not raised yet (the sweep ended before it could be), or None."""
        return self._pending if self.interrupt is None else None

    def ignore_from_now(self) -> None:
        """Ignore the three signals outright (just before exit: the interpreter's teardown would otherwise
        reinstate their default action, and a late Ctrl-C would kill a process that has finished its work)."""
        if threading.current_thread() is threading.main_thread():
            for number in (signal.SIGINT, *END_NOW_SIGNALS):
                signal.signal(number, signal.SIG_IGN)

    def closing(self) -> None:
        """The sweep is over (the rig is being closed, the summary printed): from now on signals are noted only."""
        self._closing = True

    def _handle(self, signal_number: int, frame: FrameType | None) -> None:
        if signal_number == signal.SIGHUP:
            _detach_from_terminal()
        name = signal.Signals(signal_number).name
        if self._closing or self.interrupt is not None:
            if signal_number != self._pending:
                self.late_signals.append(name)
                _say(f"ornitail: {name} received while stopping; the rig is being made safe")
            return
        if signal_number == signal.SIGINT and not self.stop.requested:
            self.stop.request()
            _say(
                "\nornitail: finishing the current set point, then stopping (Ctrl-C again to stop now)"
            )
            return
        if self._in_protected_code(frame):
            self._pending = signal_number
            if self._timer is None or not self._timer.is_alive():
                self._timer = threading.Timer(REDELIVERY_S, os.kill, (os.getpid(), signal_number))
                self._timer.daemon = True
                self._timer.start()
            return
        self._pending = None
        self.interrupt = SweepInterrupted(signal_number)
        raise self.interrupt

    def _in_protected_code(self, frame: FrameType | None) -> bool:
        while frame is not None:
            if frame.f_code in self._protected:
                return True
            frame = frame.f_back
        return False


def _detach_from_terminal() -> None:
    """Point stdin, stdout and stderr at /dev/null where they are a terminal (it may have been closed)."""
    with contextlib.suppress(OSError):
        null = os.open(os.devnull, os.O_RDWR)
        for descriptor in (0, 1, 2):
            with contextlib.suppress(OSError):
                if os.isatty(descriptor):
                    os.dup2(null, descriptor)
        os.close(null)


def _say(line: str) -> None:
    """One line on stderr; never fails (stderr may be a closed terminal or pipe)."""
    with contextlib.suppress(OSError, ValueError):
        click.echo(line, err=True)


@dataclass
class SweepCommandResult(SweepResult):
    """A sweep as the command ended it: ``exit_code`` (None: from the status) and the ``error`` line printed on
    stderr (None: none)."""

    exit_code: int | None = None
    error: str | None = None


_RESULT_FIELDS = tuple(field.name for field in dataclasses.fields(SweepResult))


def _operator_prompt(instruction: str) -> None:
    click.pause(f"ornitail: {instruction} Press any key when done.", err=True)


class ProgressFromDocuments:
    """A subscriber of the sweep's run documents that moves ``progress`` at each run's start and set point
    document (the set points of the chain done and the time left, as the document's
    :class:`~ornitail.acquisition.run_documents.PlanProgress` says them) and prints the warning lines a set point
    document carries.

    Attributes
    ----------
    eta_s : float or None
        The time left the last document said, s (None before the first).
    """

    def __init__(self, progress: Progress) -> None:
        self.progress = progress
        self.eta_s: float | None = None

    def __call__(self, name: DocumentName, document: Document) -> None:
        """Update the progress from a start or set point document that carries the plan's progress; print the
        set point document's warnings."""
        if isinstance(document, RunStart) and document.progress is not None:
            self.eta_s = document.progress.eta_s
            self.progress.update(document.progress.done, self.eta_s)
        elif isinstance(document, SetPointDocument):
            if document.progress is not None:
                self.eta_s = document.progress.eta_s
                self.progress.update(
                    document.progress.done, self.eta_s, f"#{document.plan_point_index} recorded"
                )
            for line in document.warnings:
                self.progress.message(line)

    def point_under_way(self, label: str) -> None:
        """Name the set point being moved to beside the count of those done (the count does not change)."""
        self.progress.update(self.progress.done, self.eta_s, label)


def run_sweep_with_progress(
    plan_path: Path,
    rig_path: Path,
    data_root: Path,
    *,
    resume: bool = False,
    time_scale: float | None = None,
    signals: SweepSignals | None = None,
) -> SweepResult:
    """Load plan and rig, take the chain's lock, connect, run the sweep with a progress bar on stderr.

    The rig is always closed, safe state first. An instrument that fails (at connect or during the sweep) and a
    signal that stops the sweep at once end in a :class:`SweepCommandResult` summarising what the chain holds,
    with its one-line ``error`` (printed on stderr here) and exit code. ``signals`` are the command's handlers
    (installed here for the call when not given).

    Raises
    ------
    UserInputError
        A mistake in the plan, the rig file or the limits (nothing connected).
    SweepChainBusy, InstrumentInUse
        Another process records this chain or holds the rig's ports (nothing sent to any instrument).
    """
    own_signals = signals is None
    signals = signals or SweepSignals(SweepStop()).install()
    try:
        plan = load_plan(plan_path)
        rig = Rig.from_file(rig_path, time_scale=time_scale)
        check_plan_against_rig(plan, rig)  # before connecting: connecting homes the strut
        prepare_output_directory(data_root)
        with holding_sweep_chain(Path(data_root), plan):  # refused before anything connects
            result = _connect_and_sweep(plan, rig, Path(data_root), resume, signals)
    finally:
        if own_signals:
            signals.closing()
            signals.restore()
    if isinstance(result, SweepCommandResult) and result.error:
        _say(result.error)
    return result


def _run_names(data_root: Path) -> set[str]:
    runs = data_root / "runs"
    return {path.name for path in runs.iterdir()} if runs.is_dir() else set()


def _connect_and_sweep(
    plan: SweepPlan, rig: Rig, data_root: Path, resume: bool, signals: SweepSignals
) -> SweepResult:
    """Connect, sweep, close (always); turn failures and signals into a summarising result."""
    runs_before = _run_names(data_root)
    result: SweepResult | None = None
    failure: InstrumentError | None = None
    interrupt: SweepInterrupted | None = None
    try:
        rig.connect()
        with Progress(f"sweep {plan.name}", len(plan.set_points), "set points") as progress:
            documents = DocumentDispatcher()
            from_documents = ProgressFromDocuments(progress)
            documents.subscribe(from_documents)

            def on_event(event: SweepEvent) -> None:  # what the documents do not say
                if event.stage == "moving" and event.set_point is not None:
                    from_documents.point_under_way(event.set_point.label)
                elif event.stage == "tail_change":
                    progress.stage("tail change")

            result = run_sweep(
                plan,
                rig,
                data_root,
                resume=resume,
                stop=signals.stop,
                on_event=on_event,
                operator_prompt=_operator_prompt,
                documents=documents,
            )
    except SweepInterrupted as raised:
        interrupt = raised
    except InstrumentInUse:
        raise
    except (
        InstrumentError
    ) as error:  # at connect, or outside the sweep's own handling (tail change)
        failure = error
    finally:
        signals.closing()
        close_errors = rig.close(raise_errors=False)
    if result is None:
        result = _summary_from_files(plan, data_root, runs_before, resume, interrupt, failure)
    else:
        interrupt = None  # it came after run_sweep had ended (while the progress bar closed): nothing it stopped
    result = _with_exit_path(result, interrupt, close_errors, rig)
    held_back = signals.pending_signal
    if interrupt is None and held_back is not None and result.status == "aborted":
        result.exit_code = (
            128 + held_back
        )  # the signal stopped the sweep while it was being made safe
    return result


def _summary_from_files(
    plan: SweepPlan,
    data_root: Path,
    runs_before: set[str],
    resume: bool,
    interrupt: SweepInterrupted | None,
    failure: InstrumentError | None,
) -> SweepCommandResult:
    """What the sweep's chain holds on disk after it was stopped at once or failed outside ``run_sweep``."""
    new_runs = sorted(_run_names(data_root) - runs_before)
    chain: list[Path] = []
    if new_runs or resume:
        try:
            chain = previous_sweep_chain(RunCatalog(data_root), plan)
        except Exception:  # the catalog is unusable: list this process's new runs only
            chain = [data_root / "runs" / name for name in new_runs]
    done = completed_plan_points(chain, plan)
    total = len(plan.set_points)
    recorded = (
        f"recorded {len(done)} of {total} set points"
        if chain
        else f"nothing recorded (0 of {total} set points)"
    )
    if interrupt is not None:
        status, cause = "aborted", str(interrupt)
    else:
        status, cause = "failed", str(failure)
    return SweepCommandResult(
        status=status,
        run_directories=chain,
        completed_points=len(done),
        total_points=total,
        message=f"{cause}; {recorded}; `ornitail sweep --resume` records the rest"
        if len(done) < total
        else f"{cause}; {recorded}",
    )


def _with_exit_path(
    result: SweepResult,
    interrupt: SweepInterrupted | None,
    close_errors: list[InstrumentError],
    rig: Rig,
) -> SweepCommandResult:
    """Add the safe-state outcome, the one-line error and the exit code to ``result``."""
    if not isinstance(result, SweepCommandResult):
        result = SweepCommandResult(**{name: getattr(result, name) for name in _RESULT_FIELDS})
    unsafe = sorted({error.instrument_name for error in close_errors})
    result.warnings = [
        *result.warnings,
        *(
            f"warning: could not bring {error.instrument_name} to its safe state: {error.problem}"
            for error in close_errors
        ),
    ]
    safe_text = rig.safe_state_summary(unsafe)
    if interrupt is not None:
        result.exit_code = interrupt.exit_code
        result.error = f"ornitail: sweep {interrupt}; every recorded set point is kept; {safe_text}"
    elif result.status == "failed":
        result.exit_code = EXIT_FAILED
        result.error = f"ornitail: error: {_one_line(result.message)}; {safe_text}"
    elif unsafe:
        result.exit_code = EXIT_FAILED
        result.error = f"ornitail: error: sweep {result.status} but {safe_text}"
    return result


def _one_line(text: str) -> str:
    return " ".join(line.strip() for line in str(text).splitlines() if line.strip())


def run_link_health(run_directory: Path) -> dict[str, Any]:
    """Link health of one run from its files: samples lost (counter gaps, the count ``ornitail runs`` shows),
    CRC errors, garbage bytes and resyncs, retaken set points, set points with saturated or over-range rows."""
    recording = load_recording(run_directory)
    metadata = recording.effective_metadata
    link_health = metadata["link_health"]
    return {
        "run_directory": str(run_directory),
        "exit_status": recording.status,
        "samples_lost": int(metadata["counter_gaps"]["missing_samples"]),
        "crc_errors": int(link_health["crc_errors"]),
        "garbage_bytes": int(link_health.get("garbage_bytes", 0)),
        "resyncs": int(link_health.get("resyncs", 0)),
        "set_points_retaken": sum(
            1 for record in recording.set_points if record.extra.get("retakes")
        ),
        "set_points_saturated": sum(1 for record in recording.set_points if record.is_flagged),
    }


def sweep_result_record(result: SweepResult) -> dict[str, Any]:
    """The JSON record of a sweep result, with the link health of each run."""
    return {
        "status": result.status,
        "message": result.message,
        "completed_points": result.completed_points,
        "total_points": result.total_points,
        "run_directories": [str(path) for path in result.run_directories],
        "incomplete_points": list(result.incomplete_points),
        "warnings": list(result.warnings),
        "link_health": [run_link_health(path) for path in result.run_directories],
    }


def exit_code_of(result: SweepResult) -> int:
    """0 completed, 4 incomplete (points to record again with --resume), 130 aborted, 3 failed; a sweep stopped
    at once by a signal exits with 128 + its number (143 SIGTERM, 129 SIGHUP), one whose rig could not be made
    safe with 3."""
    code = getattr(result, "exit_code", None)
    if code is not None:
        return int(code)
    codes = {"completed": 0, "incomplete": EXIT_INCOMPLETE, "aborted": EXIT_ABORTED}
    return codes.get(result.status, EXIT_FAILED)


def render_sweep_result(record: dict[str, Any]) -> str:
    lines = [f"sweep {record['status']}: {record['message']}"]
    lines += [f"  {warning}" for warning in record.get("warnings", [])]
    for health in record["link_health"]:
        lines.append(f"  run: {health['run_directory']} ({health['exit_status']})")
        if (
            health["samples_lost"]
            or health["crc_errors"]
            or health["garbage_bytes"]
            or health["set_points_retaken"]
        ):
            lines.append(
                f"    link: {health['samples_lost']} samples lost, {health['crc_errors']} CRC "
                f"errors, {health['garbage_bytes']} garbage bytes in {health['resyncs']} resync(s); "
                f"{health['set_points_retaken']} set point(s) recorded again after losing samples"
            )
        if health["set_points_saturated"]:
            lines.append(
                f"    saturation: {health['set_points_saturated']} set point(s) with saturated or "
                "over-range samples (refused by ornitail process)"
            )
    return "\n".join(lines)


def check_time_scale_option(time_scale: float | None) -> None:
    """Refuse a ``--time-scale`` that is not a finite number > 0."""
    if time_scale is not None and not (math.isfinite(time_scale) and time_scale > 0):
        raise UserInputError("--time-scale", f"{time_scale!r} must be a finite number > 0")


def guarded(action: Callable[[], SweepResult]) -> SweepResult:
    """Run ``action``; a rig or chain held by another process ends the command with one line and exit code 5, an
    interrupt outside the sweep (while the plan and rig file are read) with 130 (or 128 + its signal)."""
    try:
        return action()
    except (SweepChainBusy, InstrumentInUse) as error:
        _say(f"ornitail: error: {_one_line(str(error))}")
        sys.exit(EXIT_BUSY)
    except KeyboardInterrupt as interrupt:
        _say(f"ornitail: sweep {interrupt or 'stopped at once'}; every recorded set point is kept")
        sys.exit(getattr(interrupt, "exit_code", EXIT_ABORTED))
