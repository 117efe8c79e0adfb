"""A recording as data: the plain steps a plan is made of, and the steps of a sweep plan.

:func:`~ornitail.acquisition.run_engine.run_plan` runs the steps in order:

- :class:`ChangeTail` fits or removes the tail (fan and motor to rest first);
- :class:`StartRun` opens a new run with that tail state, :class:`StopRun` closes it (the engine opens every run
  with :func:`~ornitail.acquisition.run_engine.open_run`, so it emits its start, set point and stop documents);
- :class:`MoveAndSettle` sets pitch, tunnel velocity and flapping frequency and waits until they hold;
- :class:`RecordSetPoint` records the set point into the open run.

:func:`sweep_steps` builds a sweep's steps from its :class:`~ornitail.acquisition.sweep_plan.SweepPlan`; the
window's Tare and Record are one :class:`RecordSetPoint` each, run inside its open manual run.
"""

from __future__ import annotations

from collections.abc import Set
from dataclasses import dataclass
from itertools import groupby

from ornitail.acquisition.sweep_plan import SetPoint, SweepPlan, zero_references


@dataclass(frozen=True)
class ChangeTail:
    """Fit (``tail_attached``) or remove the tail."""

    tail_attached: bool


@dataclass(frozen=True)
class StartRun:
    """Open a run with this tail state, to record ``set_points_planned`` set points."""

    tailed: bool
    set_points_planned: int


@dataclass(frozen=True)
class MoveAndSettle:
    """Set ``point``'s pitch (rad), tunnel velocity (m/s) and flapping frequency (Hz); wait until they hold."""

    point: SetPoint


@dataclass(frozen=True)
class RecordSetPoint:
    """Record ``point`` (its ``record_s``, s) into the open run."""

    point: SetPoint


@dataclass(frozen=True)
class StopRun:
    """Close the open run."""


PlanStep = ChangeTail | StartRun | MoveAndSettle | RecordSetPoint | StopRun


def points_to_record(plan: SweepPlan, done: Set[int] = frozenset()) -> list[SetPoint]:
    """The set points of ``plan`` a sweep records when those of plan indices ``done`` are recorded whole: the
    missing ones, and with each missing measurement the tares that zero it
    (:func:`~ornitail.acquisition.sweep_plan.zero_references`), so its zero comes from its own run."""
    missing = {point.index for point in plan.set_points if point.index not in done}
    again = missing | zero_references(plan.set_points, missing)
    return [point for point in plan.set_points if point.index in again]


def sweep_steps(plan: SweepPlan, done: Set[int] = frozenset()) -> tuple[PlanStep, ...]:
    """The steps of a sweep of ``plan`` whose set points of plan indices ``done`` are recorded whole already (a
    resume): for each tail state in turn, change the tail, open a run, move, settle and record each of its points
    in plan order, close the run. No steps when nothing is left to record."""
    steps: list[PlanStep] = []
    for tail_attached, group in groupby(
        points_to_record(plan, done), key=lambda point: point.tail_attached
    ):
        points = list(group)
        steps += [ChangeTail(tail_attached), StartRun(tail_attached, len(points))]
        for point in points:
            steps += [MoveAndSettle(point), RecordSetPoint(point)]
        steps.append(StopRun())
    return tuple(steps)
