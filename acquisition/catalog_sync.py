"""Keeping a run's catalog row up to date from a thread of its own, so a locked catalog never stalls a recording.

The run's catalog subscriber (:mod:`ornitail.acquisition.catalog_subscriber`) offers a snapshot of the run's
metadata (``run.json``'s content) at its start, set point and stop documents; :class:`CatalogUpdater` writes the
newest one to the catalog in its own thread, with a short SQLite busy timeout and retries. Older snapshots are
superseded, never queued. Another process holding the catalog's write lock (``BEGIN EXCLUSIVE``, a long
transaction) delays only the catalog row: neither the HDF5 writer nor the recording thread touches SQLite. When
the run stops, the updater tries for at most ``final_wait_s`` more and then gives up; the run directory is the
truth and :meth:`RunCatalog.reconcile` (``ornitail runs``, the next ``--resume``) brings the row up to date later.
"""

from __future__ import annotations

import sqlite3
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ornitail.acquisition.catalog import (
    RunCatalog,
    catalog_entry_from_run_metadata,
    is_lock_error,
)
from ornitail.core.errors import UserInputError

WRITE_BUSY_TIMEOUT_S = 0.5
"""SQLite busy timeout of each attempt, s: how long one write waits for another process's lock."""
RETRY_INTERVAL_S = 1.0
"""Pause between attempts while the catalog stays locked, s."""
FINAL_WAIT_S = 5.0
"""How long closing the updater waits for the last snapshot to be written, s."""


class CatalogUpdater:
    """Write the newest offered metadata snapshot of one run to ``<data_root>/catalog.sqlite``.

    Parameters
    ----------
    data_root : pathlib.Path
        Folder holding the catalog and ``runs/``.
    run_directory_name : str
        The run's folder name under ``runs/`` (its run id).
    on_error : callable, optional
        Called (in the updater's thread) with the text of each failed attempt.
    """

    def __init__(
        self,
        data_root: Path,
        run_directory_name: str,
        on_error: Callable[[str], None] | None = None,
    ) -> None:
        self.data_root = Path(data_root)
        self._relative = f"runs/{run_directory_name}"
        self._on_error = on_error or (lambda text: None)
        self._condition = threading.Condition()
        self._pending: dict[str, Any] | None = None
        self._offered = 0
        self._written = 0
        self._closing = False
        self._catalog: RunCatalog | None = None
        self.failed_attempts = 0
        self._thread = threading.Thread(
            target=self._run, name=f"catalog-{run_directory_name}", daemon=True
        )
        self._thread.start()

    @property
    def up_to_date(self) -> bool:
        """True when the newest offered snapshot is in the catalog."""
        with self._condition:
            return self._written == self._offered

    def wait_up_to_date(self, timeout_s: float) -> bool:
        """Block until the newest offered snapshot is in the catalog or ``timeout_s`` passed; return which."""
        deadline = time.monotonic() + timeout_s
        with self._condition:
            while self._written != self._offered:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not self._thread.is_alive():
                    return False
                self._condition.wait(remaining)
            return True

    def offer(self, metadata: dict[str, Any]) -> None:
        """Queue ``metadata`` (a snapshot the caller no longer changes) for writing; never blocks on SQLite."""
        with self._condition:
            self._pending = metadata
            self._offered += 1
            self._condition.notify_all()

    def close(self, final_wait_s: float | None = None) -> bool:
        """Let the updater write what is pending for at most ``final_wait_s`` (default :data:`FINAL_WAIT_S`),
        then stop it.

        Returns True if the newest snapshot reached the catalog; False leaves it to the next reconcile.
        """
        deadline = time.monotonic() + (FINAL_WAIT_S if final_wait_s is None else final_wait_s)
        with self._condition:
            self._closing = True
            self._condition.notify_all()
            while self._written != self._offered and self._thread.is_alive():
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                self._condition.wait(remaining)
            up_to_date = self._written == self._offered
            self._pending = None
            self._condition.notify_all()
        self._thread.join(timeout=max(0.0, deadline - time.monotonic()) + WRITE_BUSY_TIMEOUT_S)
        return up_to_date

    def _run(self) -> None:
        while True:
            with self._condition:
                while self._pending is None and not self._closing:
                    self._condition.wait()
                if self._pending is None:
                    return
                metadata, number = self._pending, self._offered
            if self._write(metadata):
                with self._condition:
                    self._written = max(self._written, number)
                    if self._offered == number:
                        self._pending = None
                    self._condition.notify_all()
                continue
            with self._condition:  # locked or failed: try again later (or give up when closed)
                if self._pending is None:
                    return
                self._condition.wait(RETRY_INTERVAL_S)

    def _write(self, metadata: dict[str, Any]) -> bool:
        try:
            if self._catalog is None:
                self._catalog = RunCatalog(self.data_root, busy_timeout_s=WRITE_BUSY_TIMEOUT_S)
            self._catalog.upsert_run(catalog_entry_from_run_metadata(metadata, self._relative))
        except (sqlite3.Error, UserInputError, OSError) as error:
            self.failed_attempts += 1
            self._on_error(
                str(error) if is_lock_error(error) else f"{type(error).__name__}: {error}"
            )
            return False
        return True
