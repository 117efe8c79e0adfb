"""The one way a recording runs: every recording is a plan (:mod:`ornitail.acquisition.recording_plan`) that
:func:`run_plan` runs; every run is opened by :func:`open_run` and records its set points with
:meth:`OpenRun.record`.

:func:`run_plan` runs a plan's steps in order: it opens and closes the runs the plan asks for and hands each step
to the plan's :class:`PlanPerformer` (what a step does on the rig: the sweep's in
:mod:`ornitail.acquisition.sweep`, the window's manual run in ``gui/rig_session.py``, whose Tare and Record are a
one-step plan run inside its open run). :func:`open_run` frames the recorder's run with its start and stop
documents (:func:`~ornitail.acquisition.run_documents.documented_run`) and subscribes the run's catalog row
(:class:`~ornitail.acquisition.catalog_subscriber.CatalogSubscriber`) for as long as it is open;
:meth:`OpenRun.record` records one set point (:func:`~ornitail.acquisition.set_point_recording.record_set_point`)
and emits its set point document.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import AbstractContextManager, ExitStack, contextmanager
from dataclasses import dataclass
from typing import Protocol

from ornitail.acquisition.catalog_subscriber import CatalogSubscriber
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import SetPointRecord
from ornitail.acquisition.recording_plan import (
    ChangeTail,
    MoveAndSettle,
    PlanStep,
    RecordSetPoint,
    StartRun,
)
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
        warnings: Callable[[SetPointRecord], Sequence[str]] | None = None,
    ) -> SetPointRecord:
        """Record ``point`` (its ``record_s`` from now on, at ``sample_rate_hz``, Hz) into the run and emit its set
        point document; ``settle_s`` is the rig time it took to settle, s (None: not settled by the run).

        ``progress`` counts the record into its plan and says where the plan stands, for the document (None: a
        run without a plan); ``warnings`` gives the lines about the record the operator must see, for the
        document's ``warnings`` (None: none).
        """
        record = record_set_point(context, self.recorder, point, sample_rate_hz, settle_s)
        self.documents.set_point(
            record,
            None if progress is None else progress(record),
            () if warnings is None else warnings(record),
        )
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


class PlanPerformer(Protocol):
    """What a plan's steps do on a rig; :func:`run_plan` sequences them and opens and closes the runs.

    A plan run inside a run already open (the window's Tare and Record) holds :class:`RecordSetPoint` steps only
    and needs only :meth:`record`.
    """

    def change_tail(self, tail_attached: bool) -> None:
        """Fit or remove the tail (:class:`ChangeTail`)."""

    def recorder(self, step: StartRun) -> Recorder:
        """The recorder of the run ``step`` opens."""

    def progress(self) -> PlanProgress | None:
        """Where the plan stands as a run starts, for its start document (None: a run without a plan)."""

    def recording_into(self, run: OpenRun) -> AbstractContextManager[object]:
        """Stream the balance into ``run`` for the block (until its :class:`StopRun` or an exception)."""

    def move_and_settle(self, point: SetPoint) -> float:
        """Move to ``point`` and wait until it holds (:class:`MoveAndSettle`); the rig time it took, s."""

    def record(self, run: OpenRun, point: SetPoint, settle_s: float | None) -> None:
        """Record ``point`` into ``run`` (:class:`RecordSetPoint`); ``settle_s`` as :meth:`move_and_settle` said
        (None: not settled by the plan)."""

    def run_stopped(self) -> None:
        """The run of the last :class:`StopRun` is closed (its stop document emitted)."""


def run_plan(
    steps: Iterable[PlanStep],
    performer: PlanPerformer,
    dispatcher: DocumentDispatcher,
    run: OpenRun | None = None,
) -> None:
    """Run ``steps`` in order with ``performer``: each :class:`StartRun` opens a run with :func:`open_run` (its
    documents through ``dispatcher``) and the performer's :meth:`~PlanPerformer.recording_into`, each
    :class:`StopRun` closes it; the other steps go to the performer. ``run`` is a run already open that the
    steps record into (the window's manual run).

    Whatever ends the plan early (an exception, a stop of the operator's) closes the open run with it, so its stop
    record and stop document say why.
    """
    with ExitStack() as open_runs:
        this_run = ExitStack()  # closes the run open now: its recording_into, then open_run
        settle_s: float | None = None
        for step in steps:
            if isinstance(step, ChangeTail):
                performer.change_tail(step.tail_attached)
            elif isinstance(step, StartRun):
                this_run = ExitStack()
                open_runs.enter_context(this_run)
                run = this_run.enter_context(
                    open_run(
                        performer.recorder(step),
                        dispatcher,
                        set_points_planned=step.set_points_planned,
                        progress=performer.progress(),
                    )
                )
                this_run.enter_context(performer.recording_into(run))
            elif isinstance(step, MoveAndSettle):
                settle_s = performer.move_and_settle(step.point)
            elif isinstance(step, RecordSetPoint):
                if run is None:
                    raise ValueError(
                        f"plan step {step!r} records outside a run: no StartRun before it"
                    )
                performer.record(run, step.point, settle_s)
                settle_s = None
            else:
                this_run.close()
                run = None
                performer.run_stopped()
