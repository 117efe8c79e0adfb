"""Run a sweep plan in a thread: pause (finish the point, resumable), abort now, and report progress.

Pause is the sweep's own stop request (the first Ctrl-C of ``ornitail sweep``): the current set point is finished
and the run ends ``aborted``; Resume continues the newest chain of the plan. Abort is :meth:`SweepStop.abort`: the
sweep ends at its next short wait (never inside a driver transaction or a file write), drops the point in
progress and ends the run ``aborted`` with the rig safe.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

from ornitail.acquisition.live_balance import LiveBalance
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.run_documents import DocumentDispatcher
from ornitail.acquisition.sweep import (
    SweepEvent,
    SweepResult,
    SweepStop,
    run_sweep,
)
from ornitail.acquisition.sweep_plan import SweepPlan


class SweepRunner(threading.Thread):
    """One sweep of ``plan`` on ``rig`` into ``data_root``, in its own thread.

    ``balance_stream`` is the window's live stream (the sweep records through it, so the display goes on);
    ``documents`` receives the documents of every run the sweep records.
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
        documents: DocumentDispatcher,
        on_event: Callable[[SweepEvent], None],
        on_done: Callable[[SweepResult | BaseException], None],
        operator_prompt: Callable[[str], None],
    ) -> None:
        super().__init__(name="sweep", daemon=True)
        self.plan, self.rig, self.data_root, self.resume = plan, rig, data_root, resume
        self.balance_stream = balance_stream
        self.documents = documents
        self.stop_request = SweepStop()
        self._on_event, self._on_done, self._operator_prompt = on_event, on_done, operator_prompt

    def run(self) -> None:
        outcome: SweepResult | BaseException
        try:
            outcome = run_sweep(
                self.plan,
                self.rig,
                self.data_root,
                resume=self.resume,
                stop=self.stop_request,
                on_event=self._on_event,
                operator_prompt=self._operator_prompt,
                balance_stream=self.balance_stream,
                documents=self.documents,
            )
        except BaseException as error:  # handed to the window as a message
            outcome = error
        self._on_done(outcome)

    def pause(self) -> None:
        """Finish the current set point, then end the run (resumable)."""
        self.stop_request.request()

    def abort(self) -> None:
        """End the sweep at its next wait; the point in progress is dropped."""
        self.stop_request.abort()
