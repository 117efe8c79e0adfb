"""A sweep as data: the steps of the shipped study plan (tail changes, runs, moves, records), and those of a resume,
built without a rig."""

from importlib.resources import files

from ornitail.acquisition.recording_plan import (
    ChangeTail,
    MoveAndSettle,
    RecordSetPoint,
    StartRun,
    StopRun,
    sweep_steps,
)
from ornitail.acquisition.sweep_plan import load_plan, zero_references

STUDY_PLAN = files("ornitail.acquisition") / "data" / "study_tunnel_plan.toml"


def test_the_study_plan_is_a_run_per_tail_state_moving_settling_and_recording_each_point_in_order():
    plan = load_plan(STUDY_PLAN)
    steps = sweep_steps(plan)
    # The tail states alternate (T, T-less, T, T-less, T, T-less): one tail change and one run each; the sweeps
    # are in the first tailed run, the steady states in every run.
    frames = [step for step in steps if not isinstance(step, MoveAndSettle | RecordSetPoint)]
    assert frames == [
        step
        for tailed, planned in [
            (True, 33),
            (False, 3),
            (True, 3),
            (False, 3),
            (True, 3),
            (False, 3),
        ]
        for step in (ChangeTail(tailed), StartRun(tailed, planned), StopRun())
    ]
    # Inside each run: every point of its tail state moved to, settled and recorded, in plan order.
    recorded = [step.point for step in steps if isinstance(step, RecordSetPoint)]
    assert recorded == list(plan.set_points)
    run_of = None
    for step, following in zip(steps, steps[1:], strict=False):
        if isinstance(step, StartRun):
            run_of = step.tailed
        if isinstance(step, MoveAndSettle):
            assert following == RecordSetPoint(step.point)
            assert step.point.tail_attached is run_of
    assert sum(isinstance(step, MoveAndSettle) for step in steps) == len(plan.set_points) == 48


def test_a_resume_records_the_missing_point_with_the_tares_that_zero_it_in_one_run_and_nothing_when_done():
    plan = load_plan(STUDY_PLAN)
    missing = next(p for p in plan.set_points if p.kind == "measurement" and not p.tail_attached)
    references = zero_references(plan.set_points, {missing.index})
    assert references and all(plan.set_points[i].kind == "tare" for i in references)
    done = {point.index for point in plan.set_points} - {missing.index}
    again = sorted({missing.index} | references)
    assert sweep_steps(plan, done) == (
        ChangeTail(False),
        StartRun(False, len(again)),
        *(
            step
            for index in again
            for step in (
                MoveAndSettle(plan.set_points[index]),
                RecordSetPoint(plan.set_points[index]),
            )
        ),
        StopRun(),
    )
    assert sweep_steps(plan, done | {missing.index}) == ()
