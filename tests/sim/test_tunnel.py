"""Simulated tunnel signals: gauges, tares, Hall pulses, rpm, continuity, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ornitail.core.errors import UserInputError
from ornitail.sim.configuration import study_configuration
from ornitail.sim.effects import EffectSet
from ornitail.sim.instruments import HALL_HIGH_V, balance_calibration_matrix_si
from ornitail.sim.tunnel import (
    CHANNELS,
    TunnelSignalSource,
    record_tunnel_point,
    true_cycle_average,
)
from ornitail.vehicle.constants import DELFLY_GEAR_RATIO, STANDARD_GRAVITY_M_S2

MATRIX = balance_calibration_matrix_si()
CONFIGURATION = study_configuration("S3", 98)
NO_DRIFT = EffectSet().without("balance_thermal_drift")


def _rising_edges(hall: np.ndarray) -> np.ndarray:
    high = hall > HALL_HIGH_V / 2
    return np.flatnonzero(high[1:] & ~high[:-1]) + 1


def test_packaged_matrix_is_the_real_nano17_in_si_units() -> None:
    # FT8884.cal: Fz row first value 21.68095 / scale 3.07423790488014 N/V; Tx row in N-mm -> N m,
    # moved by the file's BasicTransform Dz = 6.096 mm: Tx' = Tx + Dz Fy (Fy row: -1.27992 / scale)
    assert MATRIX[2, 0] == pytest.approx(21.68095 / 3.07423790488014)
    fy = -1.27992 / 5.41651440383645
    assert MATRIX[3, 2] == pytest.approx(38.02439 / 0.965832440764422 / 1000 + 0.006096 * fy)


def test_record_columns_and_shape() -> None:
    table = record_tunnel_point(CONFIGURATION, None, 0.4, 0.8, 13.5, True, duration_s=0.5)
    assert list(table.columns) == ["time_s", *CHANNELS, "motor_rpm"]
    assert len(table) == 5000
    assert table.time_s.iloc[1] == pytest.approx(1e-4)


@pytest.mark.parametrize("tail_attached", [True, False])
@pytest.mark.parametrize("pitch_deg", [20.0, 25.0, 30.0])
def test_gauges_mapped_back_through_the_matrix_give_the_true_load(pitch_deg, tail_attached) -> None:
    source = TunnelSignalSource(CONFIGURATION, NO_DRIFT, seed=3)
    source.set_operating_point(
        pitch_rad=math.radians(pitch_deg),
        tunnel_velocity_m_s=0.8,
        flapping_frequency_hz=13.5,
        tail_attached=tail_attached,
    )
    volts = source.next_block(20_000)
    edges = _rising_edges(volts[:, 8])
    whole_cycles = volts[edges[0] : edges[-1]]  # the flap harmonics average out over whole cycles
    loads = (whole_cycles[:, :6] - source.gauges.bias_v) @ MATRIX.T
    measured = loads.mean(axis=0)
    truth = source.true_cycle_average.sensor_loads
    # tolerance: resolution noise 1.46e-3 N / sqrt(~19000) ~ 1e-5 N plus the cycle-cut and 0.2 %
    # frequency wander residual of the 0.1-0.2 N thrust ripple (~1e-4 N); torques likewise / ~20 mm
    np.testing.assert_allclose(measured[:3], truth[:3], atol=5e-4)
    np.testing.assert_allclose(measured[3:], truth[3:], atol=1e-5)


@pytest.mark.parametrize("pitch_deg", [0.0, 15.0, 30.0, -10.0])
def test_wind_off_tare_is_the_weight_rotating_with_pitch(pitch_deg) -> None:
    quiet = EffectSet.none()
    source = TunnelSignalSource(CONFIGURATION, quiet, seed=1)
    source.set_operating_point(pitch_rad=math.radians(pitch_deg))
    volts = source.next_block(100)
    loads = (volts[:, :6] - source.gauges.bias_v) @ MATRIX.T
    theta = math.radians(pitch_deg)
    weight = source.true_cycle_average.mass_kg * STANDARD_GRAVITY_M_S2
    # sensor x = x_b, sensor z = -z_b (BalanceMounting): body weight (-W sin, 0, W cos)
    expected_force = np.array([-weight * math.sin(theta), 0.0, -weight * math.cos(theta)])
    np.testing.assert_allclose(loads[:, :3], np.tile(expected_force, (100, 1)), atol=1e-12)
    assert len(_rising_edges(volts[:, 8])) == 0  # motor off: the Hall line does not toggle


def test_tail_removal_lowers_mass_and_removes_tail_force() -> None:
    with_tail = true_cycle_average(CONFIGURATION, None, 0.4, 0.8, 13.5, True)
    without = true_cycle_average(CONFIGURATION, None, 0.4, 0.8, 13.5, False)
    assert without.mass_kg < with_tail.mass_kg - 0.001
    assert without.tail_x_n == 0.0 and with_tail.tail_x_n > 0.003
    # docs/background.md section 3: the tail force is of order 0.01-0.03 N, mostly along x_b
    assert 0.003 < with_tail.tail_x_n < 0.04 and abs(with_tail.tail_z_n) < with_tail.tail_x_n


@pytest.mark.parametrize("frequency_hz", [12.1, 13.5, 14.9])
def test_hall_pulses_count_the_flaps(frequency_hz) -> None:
    table = record_tunnel_point(CONFIGURATION, None, 0.4, 0.8, frequency_hz, True, seed=5)
    edges = _rising_edges(table.hall_v.to_numpy())
    assert abs(len(edges) - frequency_hz * 2.0) <= 1
    rpm = table.motor_rpm.mean()
    assert rpm == pytest.approx(frequency_hz * 60 * DELFLY_GEAR_RATIO, rel=0.01)


def test_phase_is_continuous_across_blocks_and_set_point_changes() -> None:
    source = TunnelSignalSource(CONFIGURATION, None, seed=2)
    source.set_operating_point(pitch_rad=0.4, tunnel_velocity_m_s=0.8, flapping_frequency_hz=12.0)
    blocks = [source.next_block(997) for _ in range(10)]
    source.set_operating_point(flapping_frequency_hz=15.0)
    blocks += [source.next_block(1009) for _ in range(10)]
    hall = np.vstack(blocks)[:, 8]
    expected = 12.0 * 9970 / 1e4 + 15.0 * 10090 / 1e4
    assert abs(len(_rising_edges(hall)) - expected) <= 1.5
    assert source.time_s == pytest.approx(20060 / 1e4)
    assert 15.0 * 60 * 21.33 * 0.98 < source.motor_rpm < 15.0 * 60 * 21.33 * 1.02


def test_records_are_deterministic_by_seed() -> None:
    first = record_tunnel_point(CONFIGURATION, None, 0.4, 0.8, 13.5, True, duration_s=0.2, seed=7)
    again = record_tunnel_point(CONFIGURATION, None, 0.4, 0.8, 13.5, True, duration_s=0.2, seed=7)
    other = record_tunnel_point(CONFIGURATION, None, 0.4, 0.8, 13.5, True, duration_s=0.2, seed=8)
    assert first.equals(again)
    assert not first.equals(other)


def test_hotwire_and_thermocouple_follow_their_laws() -> None:
    table = record_tunnel_point(
        CONFIGURATION, EffectSet().without("hotwire_temperature"), 0.4, 0.8, 13.5, True
    )
    expected_bridge = math.sqrt(2.0 + 1.2 * 0.8**0.45)
    # turbulence 1 % of U changes E by ~0.45 % * B U^n / (2 E^2) ~ 0.1 %: mean within 1 mV
    assert table.hotwire_bridge_v.mean() == pytest.approx(expected_bridge, abs=1e-3)
    temperature = (table.thermocouple_v - 1.25) / 0.005
    assert temperature.mean() == pytest.approx(21.5 + 0.005 * 1.0, abs=0.05)


def test_bad_operating_points_are_user_errors() -> None:
    source = TunnelSignalSource(CONFIGURATION)
    with pytest.raises(UserInputError, match="tunnel_velocity_m_s"):
        source.set_operating_point(tunnel_velocity_m_s=float("nan"))
    with pytest.raises(UserInputError, match="pitch_rad"):
        source.set_operating_point(pitch_rad=3.0)
    with pytest.raises(UserInputError, match="n_samples"):
        source.next_block(0)
