"""Manoeuvre cutting, elevator glitch removal (both rules), uniform time grids and the zero-phase
filter of flight/manoeuvres.py.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from ornitail.core.errors import UserInputError
from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.manoeuvres import (
    REQUIRED_LOG_COLUMNS,
    cut_manoeuvre,
    cut_manoeuvres,
    interpolate_glitches,
    lowpass_zero_phase,
    prepare_log,
    sample_jump_glitch_mask,
    steady_deviation_glitch_mask,
    steady_elevator_rad,
)
from ornitail.sim.configuration import study_configuration
from ornitail.sim.free_flight import FlightPlan, simulate_flight, write_flight_log_csv

PLAN = FlightPlan(duration_s=24.0)  # three 8 s manoeuvre periods, each ending with a turn


@pytest.fixture(scope="module")
def simulated_log() -> pd.DataFrame:
    return simulate_flight(study_configuration("S3", 98.0), plan=PLAN, seed=3)


def test_cutting_finds_every_doublet_with_run_in_and_turn_end(simulated_log):
    manoeuvres = cut_manoeuvres(simulated_log, "sim.csv")
    doublets_flown = int(round(PLAN.duration_s / PLAN.manoeuvre_period_s))
    assert len(manoeuvres) == doublets_flown
    time = simulated_log["time_s"].to_numpy()
    command = simulated_log["elevator_cmd"].to_numpy()
    rudder = simulated_log["rudder_cmd"].to_numpy()
    step = 1.0 / PLAN.log_rate_hz
    for number, manoeuvre in enumerate(manoeuvres):
        doublet_start = number * PLAN.manoeuvre_period_s + PLAN.lead_s
        # the input is found on the sample where the command leaves zero: within one sample
        assert manoeuvre.log_start_s + manoeuvre.input_start_s == pytest.approx(
            doublet_start, abs=step
        )
        assert manoeuvre.input_start_s == pytest.approx(0.5, abs=1e-9)
        inside = (time >= manoeuvre.log_start_s) & (time < manoeuvre.log_end_s)
        assert np.all(command[inside & (time < doublet_start - step)] == 0)
        # ends at (before) the next rudder input: no rudder sample inside, rudder on at the end
        assert np.all(rudder[inside] == 0)
        turn_start = doublet_start + PLAN.turn_after_doublet_s
        assert manoeuvre.log_end_s == pytest.approx(turn_start, abs=step)
        assert rudder[np.searchsorted(time, manoeuvre.log_end_s)] != 0
        # deviations start near zero (run-in mean removed) and the steady state is the trim
        run_in = manoeuvre.deviations[manoeuvre.deviations["time_s"] < 0.5]
        assert abs(run_in["theta_rad"].mean()) < 1e-12
        # S3 at 98 mm trims at 0.594 m/s (docs/simulator.md); 0.03 m/s covers gusts and drift
        assert manoeuvre.steady_state.airspeed_m_s == pytest.approx(0.594, abs=0.03)


def test_cutting_refuses_a_log_with_missing_columns(simulated_log):
    with pytest.raises(UserInputError, match=r"flight3\.csv.*lacks column\(s\) rudder_cmd"):
        cut_manoeuvres(simulated_log.drop(columns=["rudder_cmd"]), "flight3.csv")


def test_cutting_refuses_a_nan_value(simulated_log):
    broken = simulated_log.copy()
    broken.loc[100, "q_rad_s"] = math.nan
    with pytest.raises(UserInputError, match=r"q_rad_s.*row 101 is not a finite number"):
        cut_manoeuvres(broken, "flight3.csv")


def test_cutting_refuses_unevenly_sampled_time(simulated_log):
    broken = simulated_log.drop(index=range(200, 260)).reset_index(drop=True)
    with pytest.raises(UserInputError, match=r"time_s: sample\(s\) missing before row 201"):
        cut_manoeuvres(broken, "flight3.csv")
    # inside a time range, the row is still counted from the top of the file
    with pytest.raises(UserInputError, match=r"missing before row 201 \(t = 0\.507812"):
        cut_manoeuvres(broken, "flight3.csv", time_range_s=(0.2, 16.0))


def test_a_log_on_a_rounded_clock_of_day_is_cut_like_the_exact_one(simulated_log, tmp_path):
    """The simulator's CSV (9 significant digits) of a flight stamped from 53603.56 s: times are
    rounded to 0.1 ms, 5 % of the 512 Hz interval (refused before as uneven), and jittered."""
    clock_of_day = simulated_log.copy()
    jitter = np.random.default_rng(4).normal(0.0, 0.05 / 512.0, len(clock_of_day))
    clock_of_day["time_s"] = clock_of_day["time_s"] + 53603.56 + jitter
    written = read_flight_log(write_flight_log_csv(clock_of_day, tmp_path / "day.csv"))
    exact = cut_manoeuvres(simulated_log, "exact.csv")
    rounded = cut_manoeuvres(written, "day.csv")
    assert len(rounded) == len(exact)
    for reference, manoeuvre in zip(exact, rounded, strict=True):
        # same samples, same grid interval (least-squares slope: its error from 0.1 ms rounding
        # and 5 % jitter over 12288 samples is ~1e-9 of the interval) and the same run-in
        assert len(manoeuvre.deviations) == len(reference.deviations)
        steps = np.diff(manoeuvre.deviations["time_s"])
        np.testing.assert_allclose(steps, 1 / 512.0, rtol=1e-6)
        # the grid's start is the least-squares intercept; its standard error at the first
        # sample is 2 sigma / sqrt(N) = 1.8 us for sigma = 0.098 ms jitter, N = 12288: 10 us
        assert manoeuvre.log_start_s - 53603.56 == pytest.approx(reference.log_start_s, abs=1e-5)
        # the signals are the same numbers written with 9 significant digits
        np.testing.assert_allclose(
            manoeuvre.deviations["q_rad_s"], reference.deviations["q_rad_s"], atol=1e-7
        )


@pytest.mark.parametrize(
    ("start_s", "end_s", "message"),
    [
        (3.0, 7.0, r"no elevator input"),
        (0.8, 4.0, r"input at t = 1\.00 s leaves 0\.20 s of run-in"),
        (0.5, 2.5, r"input at t = 1\.00 s is too close to the end: 1\.50 s"),
        (1.1, 4.5, r"already under way"),
        (20.0, 30.0, r"ends after the log does"),
    ],
)
def test_a_manoeuvre_cut_in_the_wrong_place_is_refused(simulated_log, start_s, end_s, message):
    prepared = prepare_log(simulated_log, "flight3.csv")
    with pytest.raises(UserInputError, match=message) as refusal:
        cut_manoeuvre(prepared, start_s, end_s)
    assert refusal.value.where == f"flight3.csv: manoeuvre at t = {start_s:.2f}-{end_s:.2f} s"


def test_input_too_close_to_the_log_end_refuses_the_log(simulated_log):
    truncated = simulated_log[simulated_log["time_s"] < 17.8]  # third doublet at 17 s
    with pytest.raises(UserInputError, match=r"input at t = 17\.00 s is too close to the end"):
        cut_manoeuvres(truncated, "short.csv")
    # restricting the time range to the complete manoeuvres accepts it
    assert len(cut_manoeuvres(truncated, "short.csv", time_range_s=(0.0, 16.0))) == 2


def test_sample_jump_rule_removes_spikes_and_interpolates():
    time = np.arange(2000) / 512.0
    clean = np.radians(10.0) * np.sin(2 * np.pi * 1.5 * time)
    glitched = clean.copy()
    glitched[[300, 301, 302]] += np.radians(40.0)  # a three-sample marker glitch
    glitched[1200] -= np.radians(30.0)
    glitches = sample_jump_glitch_mask(glitched)
    assert np.flatnonzero(glitches).tolist() == [300, 301, 302, 1200]
    cleaned = interpolate_glitches(time, glitched, glitches, "log.csv")
    # linear interpolation of a smooth signal over <= 3 samples: error <= (h^2/8) max|x''| x few
    max_curvature = np.radians(10.0) * (2 * np.pi * 1.5) ** 2
    bound = (4 / 512.0) ** 2 / 8 * max_curvature
    assert np.max(np.abs(cleaned - clean)) <= bound
    assert not sample_jump_glitch_mask(clean).any()
    step = np.where(np.arange(100) >= 50, np.radians(24.9), 0.0)
    assert not sample_jump_glitch_mask(step).any()


def _doublet_with_marker_glitch() -> tuple[np.ndarray, np.ndarray]:
    """Elevator (rad) at 512 Hz: steady at 3 deg, a doublet of +-13 deg about it from sample 256
    (one-sample switch from + to -, a 26 deg step), and a marker glitch at sample 300 exactly
    25 deg from steady, 12 deg from its neighbours.
    """
    elevator = np.full(1024, 3.0)
    elevator[256:425] += 13.0
    elevator[425:594] -= 13.0
    elevator[300] = 3.0 + 25.0
    return np.radians(elevator), np.arange(1024) / 512.0


def test_steady_deviation_rule_removes_a_glitch_of_exactly_25_degrees():
    elevator, time = _doublet_with_marker_glitch()
    steady = steady_elevator_rad(elevator, np.array([0]), np.array([256]))
    np.testing.assert_array_equal(steady, np.radians(3.0))  # the run-in's median
    glitches = steady_deviation_glitch_mask(elevator, steady)
    assert np.flatnonzero(glitches).tolist() == [300]
    # the old rule sees only a 12 deg jump and keeps the glitch, but cuts the doublet's true
    # 26 deg switch and every sample of the down pulse after it
    old = sample_jump_glitch_mask(elevator)
    assert not old[300] and np.flatnonzero(old).tolist() == list(range(425, 594))
    cleaned = interpolate_glitches(time, elevator, glitches, "log.csv")
    # interpolated between its neighbours, both on the up pulse (3 + 13 deg)
    assert cleaned[300] == pytest.approx(np.radians(16.0), abs=1e-12)
    below = elevator.copy()
    below[300] = np.radians(3.0 + 24.9)
    assert not steady_deviation_glitch_mask(below, steady).any()


def test_steady_elevator_follows_each_manoeuvre_run_in():
    elevator = np.concatenate([np.full(100, 1.0), np.full(100, 2.0), np.full(100, 4.0)])
    elevator[[10, 11, 12]] = 50.0  # glitches inside the first run-in do not move its median
    steady = steady_elevator_rad(elevator, np.array([5, 150]), np.array([50, 200]))
    assert steady[:150].tolist() == [1.0] * 150  # before the first start too
    assert steady[150:].tolist() == [2.0] * 150  # the second run-in's median, up to the end


def test_filter_is_zero_phase_and_removes_flapping_content():
    rate = 512.0
    time = np.arange(int(20 * rate)) / rate
    slow = np.sin(2 * np.pi * 1.0 * time)
    flapping = np.sin(2 * np.pi * 13.5 * time)
    filtered = lowpass_zero_phase(slow + flapping, rate)
    interior = slice(int(3 * rate), int(17 * rate))  # away from the edge transients
    # forward-backward 4th-order Butterworth: gain |H|^2 = 1/(1 + (f/5)^8)
    in_phase = 2 * np.mean(filtered[interior] * np.sin(2 * np.pi * time[interior]))
    quadrature = 2 * np.mean(filtered[interior] * np.cos(2 * np.pi * time[interior]))
    assert in_phase == pytest.approx(1 / (1 + (1 / 5) ** 8), abs=2e-3)
    assert abs(quadrature) < 2e-3  # zero phase: no cosine component (one-pass would give ~0.3)
    residual_flapping = filtered[interior] - in_phase * slow[interior]
    assert np.max(np.abs(residual_flapping)) < 3 * 1 / (1 + (13.5 / 5) ** 8) + 2e-3


def test_a_log_too_short_to_filter_is_refused(simulated_log):
    with pytest.raises(UserInputError, match=r"10 samples are too few to filter"):
        cut_manoeuvres(simulated_log.iloc[:10], "tiny.csv")


def test_required_columns_are_the_simulator_log_columns():
    from ornitail.sim.free_flight import LOG_COLUMNS

    assert set(REQUIRED_LOG_COLUMNS) <= set(LOG_COLUMNS)


@pytest.mark.parametrize("rule", ["steady_deviation", "sample_jump"])
def test_glitches_in_a_log_are_counted_and_do_not_reach_the_manoeuvre(simulated_log, rule):
    glitched = simulated_log.copy()
    # two in manoeuvre 1 (t ~ 1.95 s), one in 2 (10.2 s), one in 3 (17.8 s): all after the
    # doublets (1-1.66 s, 9-9.66 s, 17-17.66 s), where the deflection is back near steady
    rows = [1000, 1001, 5200, 9100]
    glitched.loc[rows, "elevator_rad"] += np.radians(35.0)
    clean = cut_manoeuvres(simulated_log, "clean.csv", glitch_rule=rule)
    repaired = cut_manoeuvres(glitched, "glitched.csv", glitch_rule=rule)
    assert [m.glitches_removed for m in repaired] == [2, 1, 1]
    for before, after in zip(clean, repaired, strict=True):
        # interpolating over <= 2 samples of a smooth (lagged, 0.02 s) deflection: the filtered
        # signals differ by far less than the 35 deg spike (which would leave ~1 deg after 5 Hz)
        difference = before.deviations["elevator_rad"] - after.deviations["elevator_rad"]
        assert np.max(np.abs(difference)) < np.radians(0.05)
