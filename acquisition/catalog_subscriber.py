"""The catalog as a subscriber of a run's documents: the run's row in ``<data_root>/catalog.sqlite`` follows its
start, set point and stop documents, and a locked catalog never holds up the recording.

Each document carries the run's metadata as it stood (``run_metadata``, ``run.json``'s content); the subscriber
offers it to a :class:`~ornitail.acquisition.catalog_sync.CatalogUpdater`, which writes the newest one from a
thread of its own (older ones are superseded). A set point document's snapshot may not count that set point yet
(the recorder's writer journals it a moment later); the next document, at the latest the stop, brings the row up
to date. At the stop the updater gets at most ``catalog_sync.FINAL_WAIT_S``; a row still behind is rewritten
from ``run.json`` by the next :meth:`~ornitail.acquisition.catalog.RunCatalog.reconcile`. The failed attempts
(up to ``MAX_CATALOG_ERRORS_KEPT``) are then added to ``run.json`` as ``catalog_errors``.
"""

from __future__ import annotations

import threading
from pathlib import Path

from ornitail.acquisition import catalog_sync
from ornitail.acquisition.recording_layout import RUN_METADATA_FILE_NAME
from ornitail.acquisition.run_documents import Document, DocumentName, RunStart, RunStop
from ornitail.acquisition.run_files import write_json_atomically

MAX_CATALOG_ERRORS_KEPT = 20
"""Failed catalog writes of a run kept in its ``run.json`` (``catalog_errors``)."""


class CatalogSubscriber:
    """Keep the catalog row of one run (the first whose start document it receives) up to date.

    Parameters
    ----------
    data_root : pathlib.Path
        Folder holding the catalog and ``runs/``.

    Attributes
    ----------
    run_id : str or None
        The run it follows, once its start document arrived.
    synced : bool or None
        After the stop document: True if the stop record reached the catalog, False if the catalog stayed
        locked (the next reconcile brings the row up to date); None before.
    errors : list of str
        The first failed catalog writes (``run.json``'s ``catalog_errors``).
    """

    def __init__(self, data_root: Path) -> None:
        self.data_root = Path(data_root)
        self.run_id: str | None = None
        self.synced: bool | None = None
        self.errors: list[str] = []
        self._errors_lock = threading.Lock()
        self._updater: catalog_sync.CatalogUpdater | None = None
        self._run_directory: Path | None = None

    def __call__(self, name: DocumentName, document: Document) -> None:
        """Offer the document's metadata snapshot to the catalog; at the stop, close the updater."""
        if isinstance(document, RunStart) and self.run_id is None:
            self.run_id = document.run_id
            self._run_directory = Path(document.run_directory)
            self._updater = catalog_sync.CatalogUpdater(
                self.data_root, document.run_id, on_error=self._note_error
            )
        if self._updater is None or document.run_id != self.run_id:
            return
        self._updater.offer(dict(document.run_metadata))
        if isinstance(document, RunStop):
            self.close_run(document)

    def close_run(self, stop: RunStop) -> None:
        """Give the updater its final wait, then add the failed writes to the stop record in ``run.json``."""
        assert self._updater is not None and self._run_directory is not None
        self.synced = self._updater.close()
        self._updater = None
        with self._errors_lock:
            errors = list(self.errors)
        if errors:
            write_json_atomically(
                self._run_directory / RUN_METADATA_FILE_NAME,
                {**stop.run_metadata, "catalog_errors": errors},
            )

    def wait_up_to_date(self, timeout_s: float) -> bool:
        """Block until the row holds the newest snapshot offered (or ``timeout_s`` passed); return which.

        Recording never needs this: it is for callers that read the catalog right after a change (tests).
        """
        updater = self._updater
        return updater is not None and updater.wait_up_to_date(timeout_s)

    def _note_error(self, text: str) -> None:
        """Keep the first failed writes (called from the updater's thread)."""
        with self._errors_lock:
            if len(self.errors) < MAX_CATALOG_ERRORS_KEPT:
                self.errors.append(text)
