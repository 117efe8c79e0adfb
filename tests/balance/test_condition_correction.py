"""Repeats of one set point measured at slightly different conditions are moved to one before they are pooled."""

import math

import numpy as np
import pandas as pd
import pytest

from ornitail.balance.condition_correction import at_reference_conditions
from ornitail.balance.derivatives import body_velocities, fit_stability_derivatives
from ornitail.balance.sweep_table import tail_contribution
from ornitail.balance.tail_statement import repeatability_statement

THETA0_DEG, V0_M_S, F0_HZ = 25.0, 0.8, 13.5
SLOPES = {"x_n": (-0.11, -0.03), "z_n": (0.049, -0.009), "m_n_m": (0.0022, 0.00085)}
"""d load / du and d load / dw (N or N m per m/s), about the simulator's S3 at 98 mm."""
STEADY = {"x_n": 0.078, "z_n": -0.207, "m_n_m": -6e-5}
TAIL = {"x_n": 0.009, "z_n": -0.00066, "m_n_m": 0.0012}
SE = 1e-5


def loads_at(theta_deg: float, v_m_s: float, tailed: bool) -> dict[str, float]:
    """Loads linear in the body velocities about the steady state; tailless lacks the constant TAIL."""
    u, w = body_velocities(math.radians(theta_deg), v_m_s)
    u0, w0 = body_velocities(math.radians(THETA0_DEG), V0_M_S)
    return {
        name: STEADY[name]
        + SLOPES[name][0] * (u - u0)
        + SLOPES[name][1] * (w - w0)
        - (0.0 if tailed else TAIL[name])
        for name in STEADY
    }


def table_read_off_the_set_values() -> pd.DataFrame:
    """Pitch and velocity sweeps and steady-state repeats whose velocity was read a few mm/s off the set value
    (tailed repeats from below, one from above, tailless repeats further below), as on the rig."""
    points = [("theta", True, theta, V0_M_S, V0_M_S - 0.0015) for theta in (20.0, 22.5, 27.5, 30.0)]
    points += [("velocity", True, THETA0_DEG, v, v - 0.0012) for v in (0.55, 0.675, 0.925, 1.05)]
    points += [("steady_state", True, THETA0_DEG, V0_M_S, read) for read in (0.7984, 0.7983, 0.802)]
    points += [
        ("steady_state", False, THETA0_DEG, V0_M_S, read) for read in (0.7975, 0.7976, 0.7974)
    ]
    rows = []
    for index, (sweep, tailed, theta, v_set, v_read) in enumerate(points):
        row = {
            "sweep": sweep,
            "tailed": tailed,
            "repeat": index,
            "theta_deg": theta,
            "v_m_s": v_set,
            "f_set_hz": F0_HZ,
            "theta_measured_deg": theta,
            "v_measured_m_s": v_read,
            "tare_id": f"tare-{index}",
            "cycles": 26,
            "tail_id": "S3",
            "x_h_mm": 98.0,
        }
        loads = loads_at(theta, v_read, tailed)
        for name in ("x_n", "y_n", "z_n", "l_n_m", "m_n_m", "n_n_m"):
            row.update({name: loads.get(name, 0.0), f"{name}_se": SE, f"{name}_tare_se": 0.0})
            row[f"{name}_2sigma"] = 2e-3
        rows.append(row)
    return pd.DataFrame(rows)


def test_repeats_moved_to_the_tailless_condition_give_the_tail_exactly_and_agree():
    table = table_read_off_the_set_values()
    fit = fit_stability_derivatives(table)
    # The fit regresses on the conditions read, so its intercept is the load at the set steady state.
    assert abs(fit.X0 - STEADY["x_n"]) < 1e-9
    contribution = tail_contribution(at_reference_conditions(table, fit))
    assert contribution.loc[0, "v_reference_m_s"] == pytest.approx(0.7975)
    assert contribution.loc[0, "v_measured_m_s_tailed"] == pytest.approx(
        (0.7984 + 0.7983 + 0.802) / 3
    )
    for name in TAIL:
        assert contribution.loc[0, name] == pytest.approx(TAIL[name], abs=1e-9)
    assert repeatability_statement(contribution).endswith("(no sigma inflated).")
    # Pooled as read, the repeats disagree (X moves 0.1 N/(m/s) x 4 mm/s, 40 of their sigmas) and the tail
    # carries the two states' different offsets.
    as_read = tail_contribution(table)
    assert "beyond their errors" in repeatability_statement(as_read)
    assert abs(as_read.loc[0, "x_n"] - TAIL["x_n"]) > 5 * SE


def test_without_velocity_and_pitch_sweeps_the_repeats_stay_as_measured():
    table = table_read_off_the_set_values()
    steady_only = table[table["sweep"] == "steady_state"].reset_index(drop=True)
    moved = at_reference_conditions(steady_only, fit_stability_derivatives(steady_only))
    np.testing.assert_array_equal(moved["x_n"], steady_only["x_n"])
    assert moved["v_reference_m_s"].isna().all()
    # And without readings (a run recorded before the sweep read its conditions) nothing moves either.
    unread = table.drop(columns=["theta_measured_deg", "v_measured_m_s"])
    np.testing.assert_array_equal(
        at_reference_conditions(unread, fit_stability_derivatives(unread))["x_n"], unread["x_n"]
    )
