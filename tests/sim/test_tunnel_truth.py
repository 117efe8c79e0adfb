"""`ornitail sim tunnel`: the simulator's truth for the quantities `ornitail process` estimates.

Checked against paths that do not go through ``tunnel_truth``: the simulator's own ``true_cycle_average`` (loads
about the CG, the weight included, the sensor-frame mean the balance sees) moved to the reference point by hand,
and derivatives from finite differences of that function over the tunnel's own variables V and theta.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, read_rig_file
from ornitail.app.cli import main
from ornitail.calibration.tool_transform import ToolTransform
from ornitail.sim.configuration import study_configuration
from ornitail.sim.effects import EffectSet
from ornitail.sim.tunnel import true_cycle_average
from ornitail.sim.tunnel_truth import tunnel_truth

THETA_RAD, V_M_S, F_HZ = math.radians(25.0), 0.8, 13.5
REFERENCE_STATION_M = 0.0657
"""The simulated rig's reference point: sensor origin (station 60 mm, 12 mm along +x_b) moved by the tool
transform's [-12, 0, -5.7] mm in sensor axes (sensor z = -z_b), i.e. on the fuselage axis at station 65.7 mm."""


@pytest.fixture(scope="module")
def rig_transform() -> ToolTransform:
    return read_rig_file(DEFAULT_RIG_FILE).tool_transform


def _by_hand(configuration, tail_attached: bool, theta_rad: float, v_m_s: float) -> np.ndarray:
    """X, Z, M about the reference point from true_cycle_average: aerodynamic loads about the CG moved by their
    lever arm (CG station minus reference station along z_b; both on the fuselage axis)."""
    truth = true_cycle_average(configuration, EffectSet(), theta_rad, v_m_s, F_HZ, tail_attached)
    arm_m = truth.cg_station_m - REFERENCE_STATION_M
    return np.array([truth.aero_x_n, truth.aero_z_n, truth.aero_m_n_m + arm_m * truth.aero_x_n])


@pytest.mark.parametrize("tail_attached", [True, False])
def test_loads_are_the_aerodynamic_loads_about_the_rigs_reference_point(
    rig_transform, tail_attached
):
    configuration = study_configuration("S3", 98.0)
    truth = tunnel_truth(
        configuration,
        THETA_RAD,
        V_M_S,
        F_HZ,
        tail_attached=tail_attached,
        reference_transform=rig_transform,
    )
    expected = _by_hand(configuration, tail_attached, THETA_RAD, V_M_S)
    got = np.array([truth.loads["x_n"], truth.loads["z_n"], truth.loads["m_n_m"]])
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)


def test_weight_is_not_in_the_truth_because_the_wind_off_tare_removes_it(rig_transform):
    """The balance's mean minus the same pitch's weight-only load is what the truth reports (forces in the
    sensor frame: sensor x = x_b, sensor z = -z_b)."""
    configuration = study_configuration("S3", 98.0)
    point = true_cycle_average(configuration, EffectSet(), THETA_RAD, V_M_S, F_HZ)
    truth = tunnel_truth(configuration, THETA_RAD, V_M_S, F_HZ, reference_transform=rig_transform)
    sensor_fx, sensor_fz = point.sensor_loads[0], point.sensor_loads[2]
    assert sensor_fx - point.weight_x_n == pytest.approx(truth.loads["x_n"], rel=1e-9)
    assert -sensor_fz - point.weight_z_n == pytest.approx(truth.loads["z_n"], rel=1e-9)


def test_derivatives_agree_with_finite_differences_over_speed_and_pitch(rig_transform):
    """Chain rule: dL/dV = Lu du/dV + Lw dw/dV and dL/dtheta = Lu du/dtheta + Lw dw/dtheta, with u = -V cos theta,
    w = -V sin theta; differences over V and theta of the independent path, step 1e-4 (truncation ~1e-8 of the
    slope, far below the 1e-5 relative tolerance)."""
    configuration = study_configuration("S5", 98.0)
    truth = tunnel_truth(configuration, THETA_RAD, V_M_S, F_HZ, reference_transform=rig_transform)
    step = 1e-4
    d_dv = (
        _by_hand(configuration, True, THETA_RAD, V_M_S + step)
        - _by_hand(configuration, True, THETA_RAD, V_M_S - step)
    ) / (2 * step)
    d_dtheta = (
        _by_hand(configuration, True, THETA_RAD + step, V_M_S)
        - _by_hand(configuration, True, THETA_RAD - step, V_M_S)
    ) / (2 * step)
    du_dv, dw_dv = -math.cos(THETA_RAD), -math.sin(THETA_RAD)
    du_dtheta, dw_dtheta = V_M_S * math.sin(THETA_RAD), -V_M_S * math.cos(THETA_RAD)
    for index, load in enumerate("XZM"):
        lu, lw = truth.derivatives[f"{load}u"], truth.derivatives[f"{load}w"]
        scale = abs(lu) + abs(lw)
        assert lu * du_dv + lw * dw_dv == pytest.approx(d_dv[index], abs=1e-5 * scale)
        assert lu * du_dtheta + lw * dw_dtheta == pytest.approx(d_dtheta[index], abs=1e-5 * scale)


def test_frequency_derivative_agrees_with_a_finite_difference(rig_transform):
    configuration = study_configuration("S3", 98.0)
    truth = tunnel_truth(configuration, THETA_RAD, V_M_S, F_HZ, reference_transform=rig_transform)
    above = tunnel_truth(
        configuration, THETA_RAD, V_M_S, F_HZ + 0.05, reference_transform=rig_transform
    )
    below = tunnel_truth(
        configuration, THETA_RAD, V_M_S, F_HZ - 0.05, reference_transform=rig_transform
    )
    for load, key in (("X", "x_n"), ("Z", "z_n"), ("M", "m_n_m")):
        slope = (above.loads[key] - below.loads[key]) / 0.1
        assert truth.derivatives[f"{load}f"] == pytest.approx(slope, rel=1e-4)


def test_moving_the_reference_point_changes_only_the_moment_by_the_lever_arm():
    configuration = study_configuration("S3", 98.0)
    at_sensor = tunnel_truth(configuration, THETA_RAD, V_M_S, F_HZ)
    shifted = tunnel_truth(
        configuration,
        THETA_RAD,
        V_M_S,
        F_HZ,
        reference_transform=ToolTransform.from_mm_deg(0.0, 0.0, -20.0, 0.0, 0.0, 0.0),
    )
    # No rotation: the frame stays the sensor's. The new point sits 20 mm along -z_sensor (towards the tail);
    # the moment about y_sensor changes by the lever arm times the force along x_sensor.
    assert shifted.loads["x_n"] == pytest.approx(at_sensor.loads["x_n"], rel=1e-12)
    assert shifted.loads["z_n"] == pytest.approx(at_sensor.loads["z_n"], rel=1e-12)
    assert shifted.loads["m_n_m"] - at_sensor.loads["m_n_m"] == pytest.approx(
        0.020 * at_sensor.loads["x_n"], rel=1e-9
    )


def test_command_prints_the_truth_and_the_tail_contribution_follows_from_two_calls():
    runner = CliRunner()
    point = ["--tail", "S3", "--theta-deg", "25", "--v-m-s", "0.8", "--f-hz", "13.5", "--json"]
    tailed = runner.invoke(main, ["sim", "tunnel", *point])
    tailless = runner.invoke(main, ["sim", "tunnel", *point, "--tailless"])
    assert tailed.exit_code == 0 and tailless.exit_code == 0, tailed.output + tailless.output
    with_tail, without = json.loads(tailed.output), json.loads(tailless.output)
    assert with_tail["operating_point"] == {"theta_deg": 25.0, "v_m_s": 0.8, "f_hz": 13.5}
    assert set(with_tail["loads"]) == {"x_n", "z_n", "m_n_m"}
    assert list(with_tail["derivatives"]) == ["Xu", "Xw", "Xf", "Zu", "Zw", "Zf", "Mu", "Mw", "Mf"]
    assert with_tail["derivatives"]["Mu"]["unit"] == "N m/(m/s)"
    assert with_tail["derivatives"]["Xf"]["unit"] == "N/Hz"
    # The tail pushes towards +x_b at this point: a positive tail contribution to X, at the balance's scale.
    contribution = with_tail["loads"]["x_n"] - without["loads"]["x_n"]
    assert 1e-3 < contribution < 5e-2
    text = runner.invoke(main, ["sim", "tunnel", *point[:-1]]).output
    assert "X " in text and " N " in text and "deg" in text


def test_another_day_changes_the_vehicle():
    runner = CliRunner()
    point = ["--tail", "S3", "--theta-deg", "25", "--v-m-s", "0.8", "--f-hz", "13.5", "--json"]
    day_0 = json.loads(runner.invoke(main, ["sim", "tunnel", *point]).output)
    day_3 = json.loads(runner.invoke(main, ["sim", "tunnel", *point, "--day", "3"]).output)
    assert day_0["loads"]["z_n"] != pytest.approx(day_3["loads"]["z_n"], rel=1e-3)
