"""Effects registry, mass model, trim and linearisation of the simulator."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ornitail.core.errors import UserInputError
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import a_matrix_from_derivatives, linearise, trim
from ornitail.sim.effects import EFFECT_NAMES, EFFECT_SCOPES, EffectSet
from ornitail.sim.parameters import VehicleParameters
from ornitail.sim.vehicle import rigid_body_mass_properties
from ornitail.sim.wings import periodic_wing_loads

REFERENCE = Path(__file__).parents[1] / "data" / "reference" / "derivatives_xh98.csv"
FLIPPED = (
    "Mu",
    "Mw",
    "Xq",
    "Zq",
)  # docs/frames.md: the published table's pitch-axis sign convention


def test_effect_registry_and_switches() -> None:
    assert len(EFFECT_NAMES) == 11
    assert set(EFFECT_SCOPES.values()) == {"tunnel", "flight", "both"}
    assert EffectSet.all_on().enabled_names() == EFFECT_NAMES
    assert EffectSet.none().enabled_names() == ()
    assert EffectSet.only("wake_profile", "added_mass").enabled_names() == (
        "wake_profile",
        "added_mass",
    )
    without = EffectSet().without("strut_interference")
    assert not without.is_on("strut_interference") and without.is_on("clamping")
    assert EffectSet().replace_effect("day_to_day_drift", day=3).day_to_day_drift.day == 3
    with pytest.raises(UserInputError, match="unknown effect 'warp_drive'"):
        EffectSet().without("warp_drive")
    with pytest.raises(UserInputError, match="unknown parameter"):
        EffectSet().replace_effect("clamping", colour="red")


def test_mass_properties_follow_the_study() -> None:
    masses = [
        rigid_body_mass_properties(study_configuration(tail, x_h)).mass_kg
        for tail in ("T3", "S1", "S3", "S6", "AR6")
        for x_h in (57, 98, 126)
    ]
    # study: 22.8-24.3 g; the point-mass model is allowed 0.4 g either side
    assert min(masses) >= 0.0224 and max(masses) <= 0.0247
    for tail in ("S1", "S3", "AR1"):
        forward = rigid_body_mass_properties(study_configuration(tail, 57))
        aft = rigid_body_mass_properties(study_configuration(tail, 126))
        # study: CG 15.1 mm aft on average; I_yy +150 % (model gives ~+120 %, see docs/simulator.md)
        assert 0.013 < aft.cg_station_m - forward.cg_station_m < 0.018
        assert 1.9 < aft.iyy_kg_m2 / forward.iyy_kg_m2 < 2.6


def test_periodic_wing_loads_have_zero_mean_over_a_cycle() -> None:
    phase = np.linspace(0, 2 * np.pi, 1000, endpoint=False)
    x, z, m = periodic_wing_loads(phase, 13.5, 0.21, -0.05, VehicleParameters())
    for series in (x, z, m):
        assert abs(series.mean()) < 1e-12 * (1 + np.abs(series).max())
    assert np.ptp(z) > 0.2  # thrust ripple of the order of the mean thrust (DelFly force traces)


@pytest.mark.parametrize("tail", ["S1", "S3", "AR6", "T3"])
@pytest.mark.parametrize("effects_name", ["all_on", "none"])
def test_numerical_a_matrix_has_the_structure_of_domain_section_5(
    tail: str, effects_name: str
) -> None:
    model = linearise(study_configuration(tail, 98), getattr(EffectSet, effects_name)())
    built = a_matrix_from_derivatives(model.derivatives, model.mass_kg, model.iyy_kg_m2, model.trim)
    # both come from the same central differences; the kinematic and gravity entries differ only by
    # truncation error O(h^2) ~1e-6 relative
    np.testing.assert_allclose(model.a_matrix, built, rtol=1e-5, atol=1e-6)
    b_built = np.array(
        [
            model.derivatives["Mde"] / model.iyy_kg_m2,
            model.derivatives["Xde"] / model.mass_kg,
            model.derivatives["Zde"] / model.mass_kg,
            0.0,
        ]
    )
    np.testing.assert_allclose(model.b_matrix[:, 0], b_built, rtol=1e-6, atol=1e-9)


def test_trim_satisfies_the_equations_of_motion() -> None:
    from ornitail.sim.dynamics import FlightDynamics

    dynamics = FlightDynamics(study_configuration("S3", 98), EffectSet())
    state = dynamics.trim()
    rates = dynamics.state_derivative(dynamics.trim_state_vector(state), 0.0, state)
    np.testing.assert_allclose(rates, 0.0, atol=1e-9)
    assert state.elevator_rad == 0.0 and 0.0 < state.throttle < 1.0
    assert state.u0_m_s == pytest.approx(-state.airspeed_m_s * math.cos(state.theta_rad))
    assert state.w0_m_s == pytest.approx(-state.airspeed_m_s * math.sin(state.theta_rad))


@pytest.mark.parametrize("tail", ["S1", "S2", "S3", "S5", "AR1", "AR6", "T2"])
def test_eigenstructure_oscillatory_pair_and_two_real_poles(tail: str) -> None:
    model = linearise(study_configuration(tail, 98), EffectSet())
    assert model.oscillatory_eigenvalue() is not None
    assert model.oscillatory_damping_ratio() > 0.0
    slow, fast = model.real_poles()[-1], model.real_poles()[0]
    assert len(model.real_poles()) == 2
    assert -3.0 < slow < -0.1  # "of order -1"
    assert -30.0 < fast < -5.0  # "of order -10"


def _flipped_table() -> pd.DataFrame:
    table = pd.read_csv(REFERENCE, comment="#")
    table.loc[table.parameter.isin(FLIPPED), "value"] *= -1
    return table


# Left out: S1's Mw (-3.8e-5, 23 % sigma, two orders below the other tails), S3's Zw (positive,
# 24 % sigma) and S3's Zu (123 % sigma): docs/background.md calls Z derivatives and Mw poorly determined.
# Zu > 0 comes from the wings' translational lift (thrust grows with cross-flow). Xq, Zq: see the
# Xq test below.
DERIVATIVE_CASES = [
    (tail, parameter)
    for tail in ("S1", "S2", "S3", "S5")
    for parameter in ("Mq", "Mu", "Xu", "Xw", "Zw", "Mw", "Zu")
    if (tail, parameter) not in {("S1", "Mw"), ("S3", "Zw"), ("S3", "Zu")}
]


@pytest.mark.parametrize(("tail", "parameter"), DERIVATIVE_CASES)
def test_derivative_orders_match_the_sign_flipped_study_table(tail: str, parameter: str) -> None:
    table = _flipped_table()
    published = float(
        table[(table.config == f"{tail}b") & (table.parameter == parameter)].value.iloc[0]
    )
    simulated = linearise(study_configuration(tail, 98), EffectSet()).derivatives[parameter]
    assert np.sign(simulated) == np.sign(published)
    # "orders": within a factor of three. With the study's wing arm (38 mm at 57 mm, docs/background.md section 1)
    # the model's Mu is 1.5-1.8x and Mq 1.9-2.3x the published values (docs/simulator.md).
    factor = 3.0
    assert 1 / factor <= simulated / published <= factor


def test_xq_is_small_compared_with_the_published_value() -> None:
    # Documented limitation (docs/simulator.md): a physically consistent quasi-steady model gives
    # |Xq| = |z_w Xu_w + (z_t + l) Xu_t| of a few 1e-3, not the published 2-3e-2.
    model = linearise(study_configuration("S3", 98), EffectSet())
    assert abs(model.derivatives["Xq"]) < 0.01


def test_trim_is_deterministic_and_day_drift_is_seeded() -> None:
    configuration = study_configuration("S3", 98)
    first, second = trim(configuration), trim(configuration)
    assert first == second
    other_day = trim(configuration, EffectSet().replace_effect("day_to_day_drift", day=4))
    assert other_day.airspeed_m_s != pytest.approx(first.airspeed_m_s, rel=1e-4)
