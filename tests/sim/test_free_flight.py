"""Simulated flight logs: format, doublets, turns, flapping content, linear-model agreement."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pandas as pd
import pytest
from scipy.signal import butter, filtfilt, lsim

from ornitail.core.errors import UserInputError
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import linearise
from ornitail.sim.effects import EffectSet
from ornitail.sim.free_flight import LOG_COLUMNS, FlightPlan, simulate_flight, write_flight_log_csv

S3_98 = study_configuration("S3", 98)


@cache
def standard_log(seed: int = 1) -> pd.DataFrame:
    return simulate_flight(S3_98, EffectSet(), FlightPlan(duration_s=20.0), seed=seed)


def test_log_format_and_rate() -> None:
    log = standard_log()
    assert tuple(log.columns) == LOG_COLUMNS
    assert len(log) == 20 * 512
    assert np.diff(log.time_s.to_numpy()) == pytest.approx(1 / 512)
    assert log.notna().all().all()


def test_doublets_are_65_percent_of_the_elevator_limit_for_033s_each() -> None:
    log = standard_log()
    plan = FlightPlan()
    assert set(np.round(log.elevator_cmd.unique(), 6)) == {0.0, 0.65, -0.65}
    assert log.elevator_rad.abs().max() == pytest.approx(0.65 * plan.elevator_limit_rad, rel=1e-3)
    positive = (log.elevator_cmd > 0).to_numpy()
    starts = np.flatnonzero(positive[1:] & ~positive[:-1]) + 1
    assert len(starts) == 3  # 20 s flight, one doublet every 8 s starting 1 s in: at 1, 9, 17 s
    assert positive.sum() / 512 / len(starts) == pytest.approx(0.33, abs=2 / 512)


def test_a_turn_ends_every_manoeuvre() -> None:
    log = standard_log()
    command = log.elevator_cmd.to_numpy()
    rudder = log.rudder_cmd.to_numpy()
    doublet_starts = log.time_s[(command > 0) & (np.roll(command, 1) <= 0)].to_numpy()
    turn_starts = log.time_s[(rudder != 0) & (np.roll(rudder, 1) == 0)].to_numpy()
    assert (
        len(turn_starts) == len(doublet_starts) - 1
    )  # the last manoeuvre is still running at 20 s
    np.testing.assert_allclose(turn_starts - doublet_starts[: len(turn_starts)], 4.0, atol=2 / 512)
    assert set(np.unique(rudder)) <= {-1.0, 0.0, 1.0}


def test_logs_are_deterministic_by_seed() -> None:
    plan = FlightPlan(duration_s=3.0)
    first = simulate_flight(S3_98, None, plan, seed=4)
    assert first.equals(simulate_flight(S3_98, None, plan, seed=4))
    assert not first.equals(simulate_flight(S3_98, None, plan, seed=5))


def test_flapping_content_sits_at_the_flapping_frequency() -> None:
    log = standard_log()
    q = log.q_rad_s.to_numpy()
    spectrum = np.abs(np.fft.rfft(q - q.mean()))
    frequencies = np.fft.rfftfreq(len(q), 1 / 512)
    band = frequencies > 8.0
    peak = frequencies[band][np.argmax(spectrum[band])]
    flapping = log.flapping_frequency_hz.mean()
    harmonics = np.arange(1, 7) * flapping
    assert (
        np.min(np.abs(harmonics - peak)) < 0.2
    )  # the strongest high-frequency line is a flap harmonic


def test_cycle_averaged_response_matches_the_linear_model_for_small_doublets() -> None:
    effects = EffectSet().without("flapping_frequency_coupling")
    plan = FlightPlan(
        duration_s=6.0,
        doublet_fraction=0.15,
        gust_moment_n_m=0.0,
        turn_moment_n_m=0.0,
        q_noise_rad_s=0.0,
        velocity_noise_m_s=0.0,
        theta_noise_rad=0.0,
        turn_after_doublet_s=4.5,
    )
    log = simulate_flight(S3_98, effects, plan, seed=0)
    model = linearise(S3_98, effects)
    b, a = butter(4, 5.0 / 256)
    states = filtfilt(b, a, log[["q_rad_s", "u_m_s", "w_m_s", "theta_rad"]].to_numpy(), axis=0)
    trim = model.trim
    deviation = states - np.array([0.0, trim.u0_m_s, trim.w0_m_s, trim.theta_rad])
    elevator = filtfilt(b, a, log.elevator_rad.to_numpy())
    _, linear, _ = lsim(
        (model.a_matrix, model.b_matrix, np.eye(4), np.zeros((4, 1))),
        elevator,
        log.time_s.to_numpy(),
    )
    window = slice(256, len(log) - 256)  # avoid filter edge transients
    for column in range(4):
        scale = np.abs(linear[window, column]).max()
        error = np.abs(deviation[window, column] - linear[window, column]).max()
        # nonlinearity of a 3 deg doublet plus the filtered flapping residue: within 15 % of the
        # peak
        assert error < 0.15 * scale, (column, error, scale)


def test_frequency_coupling_makes_the_flapping_frequency_move() -> None:
    plan = FlightPlan(duration_s=4.0)
    coupled = simulate_flight(S3_98, EffectSet(), plan, seed=2).flapping_frequency_hz
    frozen = simulate_flight(
        S3_98, EffectSet().without("flapping_frequency_coupling"), plan, seed=2
    ).flapping_frequency_hz
    assert np.ptp(frozen) == 0.0
    # the motor model's load sensitivity is small (calibrated to keep the study's Zw): a few mHz
    assert np.ptp(coupled) > 1e-3


def test_csv_round_trip(tmp_path) -> None:
    log = simulate_flight(S3_98, None, FlightPlan(duration_s=2.0), seed=1)
    path = write_flight_log_csv(log, tmp_path / "log.csv")
    again = pd.read_csv(path)
    assert list(again.columns) == list(LOG_COLUMNS)
    np.testing.assert_allclose(again.to_numpy(), log.to_numpy(), rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize(
    ("field", "value"),
    [("duration_s", -1.0), ("doublet_fraction", 1.5), ("elevator_limit_rad", math.nan)],
)
def test_bad_plans_are_user_errors(field, value) -> None:
    with pytest.raises(UserInputError, match=field):
        simulate_flight(S3_98, None, FlightPlan(**{field: value}))
