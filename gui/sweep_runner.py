"""Run a sweep plan in a thread: pause (finish the point, resumable), abort now, and report progress.

Pause is the sweep's own stop request (the first Ctrl-C of ``ornitail sweep``): the current set point is finished
and the run ends ``aborted``; Resume continues the newest chain of the plan. Abort is the second Ctrl-C: a
``KeyboardInterrupt`` raised in the sweep thread, which the sweep turns into an ``aborted`` run and a safe rig.
"""

from __future__ import annotations

import ctypes
import threading
from collections.abc import Callable
from pathlib import Path

from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.live_balance import LiveBalance
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.sweep import (
    SweepEvent,
    SweepResult,
    SweepStop,
    previous_sweep_chain,
    run_sweep,
)
from ornitail.acquisition.sweep_plan import SweepPlan


class SweepRunner(threading.Thread):
    """One sweep of ``plan`` on ``rig`` into ``data_root``, in its own thread.

    ``balance_stream`` is the window's live stream (the sweep records through it, so the display goes on).
    ``on_event`` gets every :class:`SweepEvent`, ``on_done`` the :class:`SweepResult` (or the exception that
    ended the sweep), both called in this thread; ``operator_prompt`` must block until the person has acted.
    """

    def __init__(
        self,
        plan: SweepPlan,
        rig: Rig,
        data_root: Path,
        *,
        resume: bool,
        balance_stream: LiveBalance | None,
        on_event: Callable[[SweepEvent], None],
        on_done: Callable[[SweepResult | BaseException], None],
        operator_prompt: Callable[[str], None],
    ) -> None:
        super().__init__(name="sweep", daemon=True)
        self.plan, self.rig, self.data_root, self.resume = plan, rig, data_root, resume
        self.balance_stream = balance_stream
        self.stop_request = SweepStop()
        self._on_event, self._on_done, self._operator_prompt = on_event, on_done, operator_prompt
        self._last_event: SweepEvent | None = None
        self._interruptible = True
        self._interrupt_lock = threading.Lock()

    def run(self) -> None:
        outcome: SweepResult | BaseException
        try:
            outcome = run_sweep(
                self.plan,
                self.rig,
                self.data_root,
                resume=self.resume,
                stop=self.stop_request,
                on_event=self._remember_and_pass_on,
                operator_prompt=self._operator_prompt,
                balance_stream=self.balance_stream,
            )
            with self._interrupt_lock:  # an abort after this point must not interrupt anything else
                self._interruptible = False
        except KeyboardInterrupt:
            outcome = self._aborted_result()
        except BaseException as error:  # handed to the window as a message
            outcome = error
        with self._interrupt_lock:
            self._interruptible = False
        self._on_done(outcome)

    def _remember_and_pass_on(self, event: SweepEvent) -> None:
        self._last_event = event
        self._on_event(event)

    def _aborted_result(self) -> SweepResult:
        """What an abort left: the runs of this plan's chain and the points recorded so far."""
        last = self._last_event
        return SweepResult(
            status="aborted",
            run_directories=previous_sweep_chain(RunCatalog(self.data_root), self.plan),
            completed_points=0 if last is None else last.completed,
            total_points=len(self.plan.set_points),
            message="aborted by the operator",
        )

    def pause(self) -> None:
        """Finish the current set point, then end the run (resumable)."""
        self.stop_request.request()

    def abort(self) -> None:
        """End the sweep now: raise ``KeyboardInterrupt`` in the sweep thread (as a second Ctrl-C does)."""
        self.stop_request.request()
        with self._interrupt_lock:
            if self.ident is not None and self._interruptible:
                ctypes.pythonapi.PyThreadState_SetAsyncExc(
                    ctypes.c_ulong(self.ident), ctypes.py_object(KeyboardInterrupt)
                )
