"""Sweep plans: expansion into set points, validation of fields and of the rig's limits."""

import math
import tomllib
from importlib.resources import files

import pytest

from ornitail.acquisition.sweep_plan import (
    limit_violations,
    load_plan,
    plan_from_document,
    set_point_count,
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
    # 3 tailed + 3 tailless steady states, 4 offsets for each of 3 sweeps with the tail on.
    assert len(measurements) == 3 + 3 + 3 * 4
    # A tare before each pitch's points and one after every block of at most 3: the steady-state pitch tailed has
    # 11 points (3 steady states, 4 velocity and 4 frequency offsets), so 4 blocks and 5 tares; the other 4 pitches
    # one point and 2 tares each; tailless, the 3 steady states between 2 tares.
    assert len(tares) == 5 + 4 * 2 + 2
    assert set_point_count(plan) == len(points)
    assert [p.index for p in points] == list(range(len(points)))
    pitches_deg = sorted({round(math.degrees(p.pitch_rad), 9) for p in measurements})
    assert pitches_deg == [20.0, 22.5, 25.0, 27.5, 30.0]
    velocities = sorted({p.tunnel_velocity_m_s for p in measurements if p.sweep == "velocity"})
    assert velocities == pytest.approx([0.55, 0.675, 0.925, 1.05])
    frequencies = sorted({p.flapping_frequency_hz for p in measurements if p.sweep == "frequency"})
    assert frequencies == pytest.approx([12.1, 12.8, 14.2, 14.9])
    assert all(p.tail_attached for p in measurements if p.sweep != "steady_state")
    assert sum(not p.tail_attached for p in measurements) == 3
    # Every measurement is bracketed by the tares at its own pitch and tail state: one before, one after.
    for point in measurements:
        earlier_tares = [t for t in tares if t.index < point.index]
        later_tares = [t for t in tares if t.index > point.index]
        for tare in (earlier_tares[-1], later_tares[0]):
            assert (tare.pitch_rad, tare.tail_attached) == (point.pitch_rad, point.tail_attached)
    assert all(t.tunnel_velocity_m_s == 0 and t.flapping_frequency_hz == 0 for t in tares)


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
    assert [p.sweep for p in plan.set_points] == ["steady_state"] * 3 + ["velocity"] * 2
    assert all(p.tail_attached for p in plan.set_points)


def test_bracketing_tares_need_wind_off_tares_and_are_off_unless_asked():
    document = study_document()
    document["protocol"].pop("bracketing_tares")
    document["protocol"].pop("points_per_block")
    plain = plan_from_document(document)
    assert not plain.bracketing_tares
    assert sum(p.kind == "tare" for p in plain.set_points) == 5 + 1 == set_point_count(plain) - 18
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
    assert all(len(run) <= (points_per_block or 11) for run in runs_of_measurements)
    assert kinds[-1] == "tare"  # every block ends with its tare
