"""Tunnel fan table, thermocouple amplifier conversion, flapping-frequency cross-check."""

from __future__ import annotations

import numpy as np
import pytest

from ornitail.calibration.data_files import EXAMPLE_TUNNEL_TABLE_PATH
from ornitail.calibration.flapping_frequency_check import (
    check_flapping_frequency,
    flapping_frequency_hz_from_motor_rpm,
)
from ornitail.calibration.thermocouple_amplifier import temperature_k_from_amplifier_voltage
from ornitail.calibration.tunnel_table import TunnelVelocityTable
from ornitail.core.errors import UserInputError
from ornitail.vehicle.constants import DELFLY_GEAR_RATIO


def write_table(tmp_path, rows: str):
    path = tmp_path / "table.csv"
    path.write_text("fan_rpm,velocity_m_s\n" + rows)
    return path


def test_table_values_are_interpolated_linearly(tmp_path):
    table = TunnelVelocityTable.from_csv(write_table(tmp_path, "0,0\n500,1.0\n1000,3.0\n"))
    assert table.velocity_m_s_at_rpm(500) == 1.0
    assert table.velocity_m_s_at_rpm(750) == pytest.approx(2.0, rel=1e-15)
    np.testing.assert_allclose(table.velocity_m_s_at_rpm(np.array([250, 1000])), [0.5, 3.0])
    assert table.rpm_for_velocity(2.0) == pytest.approx(750.0, rel=1e-15)


def test_example_table_inverse_round_trip():
    table = TunnelVelocityTable.from_csv(EXAMPLE_TUNNEL_TABLE_PATH)
    assert table.velocity_m_s[0] == 0.0 and 3.0 <= table.velocity_m_s[-1] < 3.1
    velocities = np.linspace(0.0, 3.0, 31)
    np.testing.assert_allclose(
        table.velocity_m_s_at_rpm(table.rpm_for_velocity(velocities)), velocities, atol=1e-12
    )


@pytest.mark.parametrize(
    ("method", "value"),
    [("velocity_m_s_at_rpm", 1500.0), ("velocity_m_s_at_rpm", -1.0), ("rpm_for_velocity", 3.5)],
)
def test_table_refuses_to_extrapolate(method, value):
    table = TunnelVelocityTable.from_csv(EXAMPLE_TUNNEL_TABLE_PATH)
    with pytest.raises(UserInputError, match=f"{value:g} is outside the tunnel table's range"):
        getattr(table, method)(value)


@pytest.mark.parametrize(
    ("rows", "words"),
    [
        ("0,0\n500,1.0\n400,1.5\n", "line 4, column fan_rpm"),
        ("0,0\n500,1.0\n600,1.0\n", "line 4, column velocity_m_s"),
        ("0,0\n500,nan\n", "line 3, column velocity_m_s"),
        ("0,0\n", "at least 2 data rows"),
    ],
)
def test_bad_tables_name_the_row(tmp_path, rows, words):
    with pytest.raises(UserInputError, match=words):
        TunnelVelocityTable.from_csv(write_table(tmp_path, rows))


@pytest.mark.parametrize(
    ("voltage_v", "temperature_k"), [(1.25, 273.15), (1.375, 298.15), (1.75, 373.15), (0.25, 73.15)]
)
def test_ad8495_conversion(voltage_v, temperature_k):
    # T = (V - 1.25 V) / 5 mV/degC, e.g. 1.375 V -> 25 degC.
    assert temperature_k_from_amplifier_voltage(voltage_v) == pytest.approx(
        temperature_k, abs=1e-10
    )


def test_ad8495_conversion_is_vectorised_and_refuses_nan():
    np.testing.assert_allclose(
        temperature_k_from_amplifier_voltage(np.array([1.25, 1.30])), [273.15, 283.15]
    )
    with pytest.raises(UserInputError, match="not a finite number"):
        temperature_k_from_amplifier_voltage(np.array([1.3, np.nan]))


def test_flapping_frequency_from_motor_uses_the_gear_ratio():
    assert DELFLY_GEAR_RATIO == 21.33
    # 12 798 rpm / 60 / 21.33 = 10.0 Hz
    assert flapping_frequency_hz_from_motor_rpm(12798.0) == pytest.approx(10.0, rel=1e-15)


@pytest.mark.parametrize(
    ("hall_hz", "disagreement", "flagged"),
    [(10.0, 0.0, False), (10.19, 0.019, False), (10.21, 0.021, True), (9.7, -0.03, True)],
)
def test_flapping_cross_check_flags_beyond_two_percent(hall_hz, disagreement, flagged):
    check = check_flapping_frequency(hall_hz, 12798.0)
    assert check.relative_disagreement == pytest.approx(disagreement, abs=1e-12)
    assert check.disagrees is flagged
    assert check.tolerance == 0.02


def test_flapping_cross_check_on_arrays_and_a_stopped_motor():
    check = check_flapping_frequency(np.array([10.0, 0.0, 3.0]), np.array([12798.0, 0.0, 0.0]))
    # 12798 / 60 / 21.33 is 10 up to one rounding step (~2e-16 relative).
    np.testing.assert_allclose(check.relative_disagreement, [0.0, 0.0, np.inf], atol=1e-15)
    np.testing.assert_array_equal(check.disagrees, [False, False, True])
