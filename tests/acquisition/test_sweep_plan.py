"""Sweep plans: expansion into set points, validation of fields and of the rig's limits."""

import math
import tomllib
from importlib.resources import files
from itertools import groupby

import pytest

from ornitail.acquisition.sweep_plan import (
    estimated_duration_s,
    limit_violations,
    load_plan,
    plan_from_document,
    set_point_count,
    zero_references,
)
from ornitail.core.errors import UserInputError

STUDY_PLAN = files("ornitail.acquisition") / "data" / "study_tunnel_plan.toml"
WIDE_LIMITS = {
    "pitch_rad": (0.0, math.radians(60)),
    "tunnel_velocity_m_s": (0.0, 3.0),
    "flapping_frequency_hz": (0.0, 20.0),
}


def study_document():
    return tomllib.loads(STUDY_PLAN.read_text())


def test_study_plan_expands_to_the_study_protocol():
    plan = load_plan(STUDY_PLAN)
    points = plan.set_points
    measurements = [p for p in points if p.kind == "measurement"]
    tares = [p for p in points if p.kind == "tare"]
    # 3 tailed + 3 tailless steady states, 4 offsets for each of 3 sweeps with the tail on, and a return to the
    # steady state after each of the 3 sweeps.
    assert len(measurements) == 3 + 3 + 3 * 4 + 3
    # A tare before each pitch group and one after every block of at most 2. The first tailed stretch has 11
    # points at the steady-state pitch (a steady state, 4 velocity offsets and a return, 4 frequency offsets and a
    # return): 6 blocks, 7 tares; the 4 other pitches and the return after the pitch sweep one point and 2 tares
    # each; the 5 later stretches (T-less, T, T-less, T, T-less) one steady state between 2 tares each.
    assert len(tares) == 7 + 4 * 2 + 2 + 5 * 2
    assert set_point_count(plan) == len(points) == 48
    assert [p.index for p in points] == list(range(len(points)))
    pitches_deg = sorted({round(math.degrees(p.pitch_rad), 9) for p in measurements})
    assert pitches_deg == [20.0, 22.5, 25.0, 27.5, 30.0]
    velocities = sorted({p.tunnel_velocity_m_s for p in measurements if p.sweep == "velocity"})
    assert velocities == pytest.approx([0.55, 0.675, 0.925, 1.05])
    frequencies = sorted({p.flapping_frequency_hz for p in measurements if p.sweep == "frequency"})
    assert frequencies == pytest.approx([12.1, 12.8, 14.2, 14.9])
    assert all(p.tail_attached for p in measurements if p.sweep not in ("steady_state",))
    assert sum(not p.tail_attached for p in measurements) == 3
    # Every measurement is bracketed by the tares at its own pitch and tail state: one before, one after.
    for point in measurements:
        earlier_tares = [t for t in tares if t.index < point.index]
        later_tares = [t for t in tares if t.index > point.index]
        for tare in (earlier_tares[-1], later_tares[0]):
            assert (tare.pitch_rad, tare.tail_attached) == (point.pitch_rad, point.tail_attached)
    assert all(t.tunnel_velocity_m_s == 0 and t.flapping_frequency_hz == 0 for t in tares)


def test_the_steady_states_alternate_tailed_and_tailless_and_each_sweep_returns_to_the_reference():
    plan = load_plan(STUDY_PLAN)
    measurements = [p for p in plan.set_points if p.kind == "measurement"]
    steady = [p for p in measurements if p.sweep == "steady_state"]
    assert [p.tail_attached for p in steady] == [True, False] * 3
    assert [p.repeat for p in steady] == [0, 0, 1, 1, 2, 2]
    # Tail states in time: the sweeps ride in the first tailed stretch, then five tail changes.
    stretches = [state for state, _ in groupby(p.tail_attached for p in plan.set_points)]
    assert stretches == [True, False] * 3
    # A reference point (the steady state) right after the last point of each sweep.
    sweeps = [p.sweep for p in measurements if p.tail_attached and p.sweep != "steady_state"]
    assert sweeps == ["theta"] * 2 + ["velocity"] * 4 + ["reference"] + ["frequency"] * 4 + [
        "reference"
    ] + ["theta"] * 2 + ["reference"]
    for point in (p for p in measurements if p.sweep == "reference"):
        assert (point.pitch_rad, point.tunnel_velocity_m_s, point.flapping_frequency_hz) == (
            plan.theta0_rad,
            plan.velocity0_m_s,
            plan.frequency0_hz,
        )
    # Each tail change costs tail_change_s in the duration estimate.
    document = study_document()
    document["protocol"]["tail_change_s"] = 0
    without = estimated_duration_s(plan_from_document(document))
    assert estimated_duration_s(plan) == pytest.approx(without + 5 * 120.0)


def test_a_point_recorded_again_takes_the_tares_that_bracket_it_in_its_stretch():
    """A resumed sweep records a point again with its zero: the tare just before and just after it at its pitch,
    never one across a tail change (another run)."""
    plan = load_plan(STUDY_PLAN)
    points = plan.set_points
    stretch = [index for index, _ in enumerate(points)]
    for position in range(1, len(points)):
        same = points[position].tail_attached == points[position - 1].tail_attached
        stretch[position] = stretch[position - 1] if same else position
    for position, point in enumerate(points):
        if point.kind == "tare":
            continue
        same_pitch_tares = [
            other
            for other, candidate in enumerate(points)
            if candidate.kind == "tare"
            and stretch[other] == stretch[position]
            and candidate.pitch_rad == point.pitch_rad
        ]
        before = max(other for other in same_pitch_tares if other < position)
        after = min(other for other in same_pitch_tares if other > position)
        # every block of the study plan is bracketed, and only points of its block lie between a point and the
        # tare before it
        assert zero_references(points, {point.index}) == {before, after}
        assert all(points[other].kind == "measurement" for other in range(before + 1, position))
    assert zero_references(points, set()) == set()
    tares = {p.index for p in points if p.kind == "tare"}
    assert zero_references(points, tares) == set()  # tares need no zero


@pytest.mark.parametrize("interleave", [False, True])
@pytest.mark.parametrize("reference", [False, True])
@pytest.mark.parametrize("tailless_points", ["none", "steady_state", "all"])
@pytest.mark.parametrize("points_per_block", [0, 1, 3])
def test_every_protocol_variant_is_counted_without_expanding(
    interleave, reference, tailless_points, points_per_block
):
    document = study_document()
    document["protocol"].update(
        interleave_tail_states=interleave,
        return_to_reference=reference,
        tailless_points=tailless_points,
        points_per_block=points_per_block,
    )
    plan = plan_from_document(document)
    assert set_point_count(plan) == len(plan.set_points)
    measurements = [p for p in plan.set_points if p.kind == "measurement"]
    assert sum(p.sweep == "reference" for p in measurements) == (
        0 if not reference else 3 * (1 + (tailless_points == "all"))
    )
    changes = sum(1 for _ in groupby(p.tail_attached for p in plan.set_points)) - 1
    expected_changes = 0 if tailless_points == "none" else (5 if interleave else 1)
    assert changes == expected_changes


def test_plan_inside_limits_has_no_violations_and_every_violation_is_listed():
    plan = load_plan(STUDY_PLAN)
    assert limit_violations(plan, WIDE_LIMITS) == []
    narrow = {
        **WIDE_LIMITS,
        "pitch_rad": (0.0, math.radians(26)),
        "flapping_frequency_hz": (10.0, 14.0),
    }
    violations = limit_violations(plan, narrow)
    # Pitches 27.5 and 30 deg: two tares and a measurement each; frequencies 14.2 and 14.9 Hz.
    assert len(violations) == 8
    assert sum("theta = 30.000 deg" in line for line in violations) == 3
    assert any("f = 14.900 Hz" in line and "[10.000, 14.000] Hz" in line for line in violations)


@pytest.mark.parametrize(
    ("table", "key", "value", "message"),
    [
        (
            "steady_state",
            "theta_deg",
            float("nan"),
            r"\[steady_state\]\.theta_deg: nan must be a finite number",
        ),
        ("steady_state", "f_hz", -13.0, r"\[steady_state\]\.f_hz: -13.0 must be > 0"),
        (
            "steady_state",
            "v_m_s",
            "fast",
            r"\[steady_state\]\.v_m_s: 'fast' must be a finite number",
        ),
        ("configuration", "x_h_mm", 0, r"\[configuration\]\.x_h_mm: 0 must be > 0"),
        ("protocol", "steady_state_repeats", 0, r"steady_state_repeats: 0 must be >= 1"),
        (
            "protocol",
            "tailless_points",
            "some",
            r"tailless_points: 'some' must be one of none, steady_state, all",
        ),
        ("protocol", "record_s", 0.2, r"record_s: 0.2 s holds fewer than 5 flapping cycles"),
        ("protocol", "velocity", 1.0, r"\[protocol\]\.velocity: unknown key"),
        ("protocol", "tail_change_s", -5.0, r"\[protocol\]\.tail_change_s: -5.0 must be >= 0"),
        (
            "protocol",
            "tail_change_s",
            1e5,
            r"tail_change_s: 100000 s is more than the 3600 s allowed",
        ),
        (
            "protocol",
            "return_to_reference",
            "yes",
            r"\[protocol\]\.return_to_reference: 'yes' must be",
        ),
        ("sweeps", "theta_deg", [0.0, 5.0], r"offset of 0 is the steady state"),
        ("sweeps", "f_hz", {"span": 1.4, "steps": 0}, r"\[sweeps\.f_hz\]\.steps: 0 must be >= 1"),
    ],
)
def test_bad_fields_are_named(table, key, value, message):
    document = study_document()
    document[table][key] = value
    with pytest.raises(UserInputError, match=message):
        plan_from_document(document, "plan.toml")


def test_missing_required_field_and_bad_file_are_named(tmp_path):
    document = study_document()
    del document["configuration"]["tail_id"]
    with pytest.raises(
        UserInputError, match=r"\[configuration\]\.tail_id: required key is missing"
    ):
        plan_from_document(document, "plan.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("[steady_state\ntheta_deg = 3")
    with pytest.raises(UserInputError, match="broken.toml: not valid TOML"):
        load_plan(broken)
    with pytest.raises(UserInputError, match="absent.toml: file not found"):
        load_plan(tmp_path / "absent.toml")


def test_offsets_as_list_and_no_tailless_points():
    document = study_document()
    document["sweeps"] = {"v_m_s": [-0.2, 0.1]}
    document["protocol"].update(
        tailless_points="none", wind_off_tares=False, bracketing_tares=False, points_per_block=0
    )
    plan = plan_from_document(document)
    assert [p.sweep for p in plan.set_points] == ["steady_state"] * 3 + ["velocity"] * 2 + [
        "reference"
    ]
    assert all(p.tail_attached for p in plan.set_points)


def test_bracketing_tares_need_wind_off_tares_and_are_off_unless_asked():
    document = study_document()
    document["protocol"].pop("bracketing_tares")
    document["protocol"].pop("points_per_block")
    plain = plan_from_document(document)
    assert not plain.bracketing_tares
    # One tare per pitch group: the steady-state pitch, 4 pitch offsets and the return after the pitch sweep in the
    # first tailed stretch, then one for each of the 5 single steady states that follow.
    assert (
        sum(p.kind == "tare" for p in plain.set_points)
        == 1 + 4 + 1 + 5
        == set_point_count(plain) - 21
    )
    document["protocol"].update(points_per_block=3)
    with pytest.raises(UserInputError, match=r"points_per_block.*needs bracketing_tares = true"):
        plan_from_document(document, "p.toml")
    document["protocol"].update(bracketing_tares=True, wind_off_tares=False)
    with pytest.raises(UserInputError, match=r"bracketing_tares.*needs wind_off_tares = true"):
        plan_from_document(document, "p.toml")


@pytest.mark.parametrize("points_per_block", [0, 1, 2, 3, 5, 11, 12])
@pytest.mark.parametrize("tailless_points", ["none", "steady_state", "all"])
def test_blocks_are_bracketed_and_counted_without_expanding(points_per_block, tailless_points):
    document = study_document()
    document["protocol"].update(points_per_block=points_per_block, tailless_points=tailless_points)
    plan = plan_from_document(document)
    assert set_point_count(plan) == len(plan.set_points)
    kinds = [p.kind for p in plan.set_points]
    runs_of_measurements = "".join("t" if kind == "tare" else "m" for kind in kinds).split("t")
    # Without blocks, the longest run of measurements is the steady-state pitch with the tail on and every steady
    # state there (3 steady states, 8 sweep offsets, 2 returns).
    assert all(len(run) <= (points_per_block or 13) for run in runs_of_measurements)
    assert kinds[-1] == "tare"  # every block ends with its tare
