"""The documents a recording run emits, in the style of bluesky, and the dispatcher that hands them out.

Every run recorded through :func:`documented_run` (a sweep's, a manual run of the window; both open it with
:func:`ornitail.acquisition.run_engine.open_run`) emits, in this order:

- one :class:`RunStart` (name ``"start"``) once its recording directory is open,
- one :class:`SetPointDocument` (name ``"set_point"``) per set point journalled in it,
- one :class:`RunStop` (name ``"stop"``) with the run's exit status, always, whatever ended the run.

A subscriber is any callable taking ``(name, document)``. It is called in the recording thread, so it must be
quick and must not block; one that raises is logged and counted by the :class:`DocumentDispatcher`, and the run
goes on. Keys carry their units (``_rad``, ``_m_s``, ``_hz``, ``_s``). Each document also carries
``run_metadata``, a copy of the run's ``run.json`` content as it stood (the stop record in the stop document),
from which the catalog subscriber writes the run's row.

A set point the operator must know about (rows saturated or over the rated load; samples still lost after the
retakes) carries one line per finding in its document's ``warnings``: there is no separate warning document, a
warning always belongs to one recorded set point.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from ornitail.acquisition.catalog import utc_now_iso
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import EXIT_STATUS_FAILED, SetPointRecord

logger = logging.getLogger(__name__)

DocumentName = Literal["start", "set_point", "stop"]


@dataclass(frozen=True)
class RunStart:
    """A run has begun: its recording directory exists and holds ``run.json``.

    Attributes
    ----------
    run_id, run_directory : str
        The run and where it is recorded.
    plan_name : str
        The plan it runs.
    configuration : mapping
        Tail id, ``x_h_m``, tailed, plan name, ``resumed_from_run_id`` (as in ``run.json``).
    rig : mapping
        The rig's description at start (devices, ports, firmware, gear ratio).
    set_points_planned : int
        Set points this run is to record.
    time_utc : str
        ISO 8601 start time.
    run_metadata : mapping
        ``run.json`` as written at start.
    progress : PlanProgress or None
        Where the run's plan stands as the run begins (None: a run without a plan).
    """

    run_id: str
    run_directory: str
    plan_name: str
    configuration: Mapping[str, Any]
    rig: Mapping[str, Any]
    set_points_planned: int
    time_utc: str
    run_metadata: Mapping[str, Any] = field(default_factory=dict)
    progress: PlanProgress | None = None


@dataclass(frozen=True)
class PlanProgress:
    """Where the plan a run belongs to stands once a set point is recorded.

    Attributes
    ----------
    done, total : int
        Set points of the plan recorded whole so far (those of earlier runs of a resumed sweep's chain included)
        and in the plan.
    eta_s : float
        Estimated rig time left, s.
    """

    done: int
    total: int
    eta_s: float


@dataclass(frozen=True)
class SetPointDocument:
    """One set point of a run was recorded and handed to the journal.

    Attributes
    ----------
    run_id : str
        The run it belongs to.
    sequence : int
        1 for the run's first set point document, then 2, 3, ...
    plan_point_index : int
        Its index in the plan.
    kind : str
        ``"tare"`` or ``"measurement"``.
    pitch_rad, tunnel_velocity_m_s, flapping_frequency_hz : float
        The set values.
    tail_attached : bool
        The tail state.
    first_sample_index, last_sample_index : int
        Its rows in the run's sample stream.
    samples_missing_in_record : int
        Samples the kept record lost inside it.
    saturated_samples, over_range_samples : int or None
        Rows flagged saturated or over the rated load (None: the balance does not flag rows).
    time_utc : str
        ISO 8601 time it was handed to the journal.
    run_metadata : mapping
        The run's metadata as it stood (it may not count this set point yet: the writer journals it a moment
        later).
    progress : PlanProgress or None
        The plan's progress with this set point counted (None: a run without a plan, e.g. the window's manual
        run).
    warnings : tuple of str
        One line per finding the operator must see (saturated or over-range rows, samples still lost after the
        retakes), each naming the set point; empty for a clean record.
    """

    run_id: str
    sequence: int
    plan_point_index: int
    kind: str
    pitch_rad: float
    tunnel_velocity_m_s: float
    flapping_frequency_hz: float
    tail_attached: bool
    first_sample_index: int
    last_sample_index: int
    samples_missing_in_record: int
    saturated_samples: int | None
    over_range_samples: int | None
    time_utc: str
    run_metadata: Mapping[str, Any] = field(default_factory=dict)
    progress: PlanProgress | None = None
    warnings: tuple[str, ...] = ()

    @classmethod
    def of_record(
        cls,
        run_id: str,
        sequence: int,
        record: SetPointRecord,
        time_utc: str,
        run_metadata: Mapping[str, Any],
        progress: PlanProgress | None = None,
        warnings: Sequence[str] = (),
    ) -> SetPointDocument:
        """The document of ``record``, the run's ``sequence``-th set point, with its ``warnings`` lines."""
        return cls(
            run_id=run_id,
            sequence=sequence,
            plan_point_index=record.plan_point_index,
            kind=record.kind,
            pitch_rad=record.pitch_rad,
            tunnel_velocity_m_s=record.tunnel_velocity_m_s,
            flapping_frequency_hz=record.flapping_frequency_hz,
            tail_attached=record.tail_attached,
            first_sample_index=record.first_sample_index,
            last_sample_index=record.last_sample_index,
            samples_missing_in_record=record.samples_missing_in_record,
            saturated_samples=record.saturated_samples,
            over_range_samples=record.over_range_samples,
            time_utc=time_utc,
            run_metadata=run_metadata,
            progress=progress,
            warnings=tuple(warnings),
        )


@dataclass(frozen=True)
class RunStop:
    """A run has ended; its stop record is written to ``run.json``.

    Attributes
    ----------
    run_id : str
        The run.
    exit_status : str
        ``"completed"``, ``"incomplete"``, ``"aborted"`` or ``"failed"`` (as in ``run.json``).
    reason : str or None
        Why it did not complete.
    set_points_recorded : int
        Set point documents emitted for this run.
    time_utc : str
        ISO 8601 stop time.
    run_metadata : mapping
        The stop record as written to ``run.json``.
    """

    run_id: str
    exit_status: str
    reason: str | None
    set_points_recorded: int
    time_utc: str
    run_metadata: Mapping[str, Any] = field(default_factory=dict)


Document = RunStart | SetPointDocument | RunStop
Subscriber = Callable[[DocumentName, Document], None]


class DocumentDispatcher:
    """Hands every document to every subscriber, in the order they subscribed; never raises into the run.

    Attributes
    ----------
    subscriber_failures : int
        Calls of a subscriber that raised (each is logged with its traceback).
    """

    def __init__(self) -> None:
        self.subscriber_failures = 0
        self._subscribers: dict[int, Subscriber] = {}
        self._next_token = 0
        self._lock = threading.Lock()

    def subscribe(self, subscriber: Subscriber) -> int:
        """Add ``subscriber``; return the token that :meth:`unsubscribe` takes."""
        with self._lock:
            token = self._next_token
            self._next_token += 1
            self._subscribers[token] = subscriber
        return token

    def unsubscribe(self, token: int) -> None:
        """Remove the subscriber of ``token`` (nothing if it is gone already)."""
        with self._lock:
            self._subscribers.pop(token, None)

    def emit(self, name: DocumentName, document: Document) -> None:
        """Call every subscriber with ``(name, document)``; log and count any that raises."""
        with self._lock:
            subscribers = list(self._subscribers.values())
        for subscriber in subscribers:
            try:
                subscriber(name, document)
            except Exception:
                with self._lock:
                    self.subscriber_failures += 1
                logger.exception("run document subscriber %r failed on %s", subscriber, name)


class RunDocuments:
    """The documents of one open run: numbers its set point documents and sends each through ``dispatcher``."""

    def __init__(self, dispatcher: DocumentDispatcher, recorder: Recorder) -> None:
        self.dispatcher = dispatcher
        self.recorder = recorder
        self.run_id = recorder.run_id
        self.set_points_recorded = 0

    def set_point(
        self,
        record: SetPointRecord,
        progress: PlanProgress | None = None,
        warnings: Sequence[str] = (),
    ) -> None:
        """Emit the document of ``record``, just handed to this run's journal, with its plan's ``progress`` and the
        ``warnings`` lines about it."""
        self.set_points_recorded += 1
        self.dispatcher.emit(
            "set_point",
            SetPointDocument.of_record(
                self.run_id,
                self.set_points_recorded,
                record,
                utc_now_iso(),
                self.recorder.metadata_snapshot(),
                progress,
                warnings,
            ),
        )


@contextmanager
def documented_run(
    recorder: Recorder,
    dispatcher: DocumentDispatcher,
    *,
    set_points_planned: int,
    progress: PlanProgress | None = None,
) -> Iterator[RunDocuments]:
    """Open ``recorder``'s run for the block, emitting its start document once it is open and its stop document
    (with the exit status of the stop record) after it closed, however the block ends.

    The plan name and the rig's description are the recorder's; ``progress`` is where the plan stands as the run
    begins (None: a run without a plan). A recorder that fails to open emits nothing:
    there is no run.
    """
    documents: RunDocuments | None = None
    try:
        with recorder:
            documents = RunDocuments(dispatcher, recorder)
            dispatcher.emit(
                "start",
                RunStart(
                    run_id=recorder.run_id,
                    run_directory=str(recorder.run_directory),
                    plan_name=recorder.configuration.plan_name,
                    configuration=asdict(recorder.configuration),
                    rig=recorder.rig_description,
                    set_points_planned=set_points_planned,
                    time_utc=utc_now_iso(),
                    run_metadata=recorder.metadata_snapshot(),
                    progress=progress,
                ),
            )
            yield documents
    finally:
        if documents is not None:
            dispatcher.emit(
                "stop",
                RunStop(
                    run_id=recorder.run_id,
                    exit_status=recorder.exit_status or EXIT_STATUS_FAILED,
                    reason=recorder.exit_reason,
                    set_points_recorded=documents.set_points_recorded,
                    time_utc=utc_now_iso(),
                    run_metadata=recorder.metadata_snapshot(),
                ),
            )
