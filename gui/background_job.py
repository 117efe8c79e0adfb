"""Run a slow library call (processing, a design proposal) off the GUI thread and hand back its result there."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

from PySide6 import QtCore

from ornitail.core.errors import UserInputError

POLL_INTERVAL_MS = 100


class BackgroundJobs(QtCore.QObject):
    """One worker thread; results and errors are delivered in the GUI thread by a polling timer."""

    def __init__(
        self, on_problem: Callable[[str, str], None], parent: QtCore.QObject | None = None
    ):
        super().__init__(parent)
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gui-job")
        self._pending: list[tuple[Future, Callable[[Any], None]]] = []
        self._on_problem = on_problem
        self._timer = QtCore.QTimer(self)
        self._timer.timeout.connect(self._poll)

    @property
    def busy(self) -> bool:
        """True while a job runs or waits (docs/screenshots/make_screenshots.py waits on it)."""
        return bool(self._pending)

    def run(self, function: Callable[..., Any], on_done: Callable[[Any], None], *args: Any) -> None:
        """Call ``function(*args)`` in the worker; ``on_done(result)`` in the GUI thread afterwards."""
        self._pending.append((self._executor.submit(function, *args), on_done))
        self._timer.start(POLL_INTERVAL_MS)

    def _poll(self) -> None:
        still = []
        for future, on_done in self._pending:
            if not future.done():
                still.append((future, on_done))
                continue
            error = future.exception()
            if isinstance(error, UserInputError):
                self._on_problem("Input problem", str(error))
            elif error is not None:
                self._on_problem("Problem", f"{type(error).__name__}: {error}")
            else:
                on_done(future.result())
        self._pending = still
        if not still:
            self._timer.stop()
