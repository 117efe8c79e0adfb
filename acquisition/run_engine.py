"""The one way a recording runs: every run (a sweep's, a manual run of the window) is opened by :func:`open_run`
and records its set points with :meth:`OpenRun.record`.

:func:`open_run` frames the recorder's run with its start and stop documents
(:func:`~ornitail.acquisition.run_documents.documented_run`) and subscribes the run's catalog row
(:class:`~ornitail.acquisition.catalog_subscriber.CatalogSubscriber`) for as long as it is open;
:meth:`OpenRun.record` records one set point (:func:`~ornitail.acquisition.set_point_recording.record_set_point`)
and emits its set point document. What moves the rig between set points is the caller's: a sweep moves and
settles, the window records where the person set it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from ornitail.acquisition.catalog_subscriber import CatalogSubscriber
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import SetPointRecord
from ornitail.acquisition.run_documents import (
    DocumentDispatcher,
    PlanProgress,
    RunDocuments,
    documented_run,
)
from ornitail.acquisition.set_point_recording import RecordingContext, record_set_point
from ornitail.acquisition.sweep_plan import SetPoint


@dataclass
class OpenRun:
    """A run :func:`open_run` opened: its recorder, its documents, the subscriber keeping its catalog row."""

    recorder: Recorder
    documents: RunDocuments
    catalog: CatalogSubscriber

    def record(
        self,
        context: RecordingContext,
        point: SetPoint,
        sample_rate_hz: float,
        settle_s: float | None = None,
        progress: Callable[[SetPointRecord], PlanProgress] | None = None,
    ) -> SetPointRecord:
        """Record ``point`` (its ``record_s`` from now on, at ``sample_rate_hz``, Hz) into the run and emit its set
        point document; ``settle_s`` is the rig time it took to settle, s (None: not settled by the run).

        ``progress`` counts the record into its plan and says where the plan stands, for the document (None: a
        run without a plan).
        """
        record = record_set_point(context, self.recorder, point, sample_rate_hz, settle_s)
        self.documents.set_point(record, None if progress is None else progress(record))
        return record


@contextmanager
def open_run(
    recorder: Recorder,
    dispatcher: DocumentDispatcher,
    *,
    set_points_planned: int,
    progress: PlanProgress | None = None,
) -> Iterator[OpenRun]:
    """Open ``recorder``'s run for the block with its documents sent through ``dispatcher`` and its catalog row
    kept up to date by a :class:`CatalogSubscriber` (subscribed for the block only).

    ``set_points_planned`` (0 when the set points are not known in advance) and ``progress`` (where the plan
    stands as the run begins; None: a run without a plan) go into the start document.
    """
    catalog = CatalogSubscriber(recorder.data_root)
    token = dispatcher.subscribe(catalog)
    try:
        with documented_run(
            recorder, dispatcher, set_points_planned=set_points_planned, progress=progress
        ) as documents:
            yield OpenRun(recorder, documents, catalog)
    finally:
        dispatcher.unsubscribe(token)
