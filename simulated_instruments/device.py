"""Lifecycle shared by the simulated instruments: one thread that answers on a real transport."""

from __future__ import annotations

import threading
from typing import Self


class SimulatedDevice:
    """Base of the simulated DAQ board, NETCANOEM board and line instruments.

    A subclass calls :meth:`_prepare_thread` in its ``__init__``, implements ``_run`` (which returns once
    ``self._closing`` is set) and ``_close_transport`` (close its pty or leave its CAN bus).
    """

    _closing: threading.Event
    _thread: threading.Thread

    def _prepare_thread(self, thread_name: str) -> None:
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._run, name=thread_name, daemon=True)

    def _run(self) -> None:
        raise NotImplementedError

    def _close_transport(self) -> None:
        raise NotImplementedError

    def start(self) -> Self:
        """Start answering; returns self."""
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the thread, then close the transport."""
        self._closing.set()
        if self._thread.is_alive():
            self._thread.join(2.0)
        self._close_transport()

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.close()
