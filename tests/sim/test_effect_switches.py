"""Each effect switch changes what it should and leaves alone what it should not."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ornitail.sim.configuration import VehicleConfiguration, study_configuration
from ornitail.sim.dynamics import linearise, trim
from ornitail.sim.effects import EFFECT_NAMES, EffectSet
from ornitail.sim.instruments import balance_calibration_matrix_si
from ornitail.sim.model import PreparedVehicle
from ornitail.sim.tunnel import TunnelSignalSource, true_cycle_average
from ornitail.sim.vehicle import mass_properties
from ornitail.vehicle.geometry import TailGeometry

S3_98 = study_configuration("S3", 98)
ALL = EffectSet.all_on()
TUNNEL_ONLY = [
    name
    for name in EFFECT_NAMES
    if name
    in {
        "strut_interference",
        "clamping",
        "balance_resolution",
        "balance_thermal_drift",
        "hotwire_temperature",
        "structural_resonance",
    }
]


@pytest.mark.parametrize("name", TUNNEL_ONLY)
def test_tunnel_only_effects_leave_free_flight_alone(name) -> None:
    assert trim(S3_98, ALL.without(name)) == trim(S3_98, ALL)
    np.testing.assert_array_equal(
        linearise(S3_98, ALL.without(name)).a_matrix, linearise(S3_98, ALL).a_matrix
    )


@pytest.mark.parametrize("x_h_mm", [57, 98, 126])
def test_strut_interference_changes_the_tunnel_tail_force_depending_on_x_h(x_h_mm) -> None:
    configuration = study_configuration("S3", x_h_mm)
    on = true_cycle_average(configuration, ALL, 0.4, 0.8, 13.5)
    off = true_cycle_average(configuration, ALL.without("strut_interference"), 0.4, 0.8, 13.5)
    assert on.tail_x_n != pytest.approx(off.tail_x_n, rel=0.02)
    assert on.aero_x_n - on.tail_x_n == pytest.approx(off.aero_x_n - off.tail_x_n, rel=1e-12)


def test_strut_interference_flips_the_sign_of_its_tail_bias_between_positions() -> None:
    def bias(x_h_mm: float) -> float:
        configuration = study_configuration("S3", x_h_mm)
        on = true_cycle_average(configuration, ALL, 0.4, 0.8, 13.5).tail_x_n
        return (
            on
            - true_cycle_average(
                configuration, ALL.without("strut_interference"), 0.4, 0.8, 13.5
            ).tail_x_n
        )

    assert bias(57) * bias(126) < 0


def test_clamping_removes_the_free_flight_x_damping_from_the_balance() -> None:
    clamped = true_cycle_average(S3_98, ALL, 0.4, 0.8, 13.5)
    free = true_cycle_average(S3_98, ALL.without("clamping"), 0.4, 0.8, 13.5)
    wing_x_clamped = clamped.aero_x_n - clamped.tail_x_n
    wing_x_free = free.aero_x_n - free.tail_x_n
    fraction = ALL.clamping.free_flight_damping_fraction
    assert wing_x_free == pytest.approx(wing_x_clamped * (1 + fraction), rel=1e-12)
    assert free.tail_x_n == clamped.tail_x_n
    # the free-flight model always has it: the tunnel's Xu is smaller than the flight Xu
    flight = PreparedVehicle(S3_98, ALL, "flight").loads(-0.7, -0.3, 0.0, 13.5, 0.0)
    tunnel_free = PreparedVehicle(S3_98, ALL.without("clamping"), "tunnel").loads(
        -0.7, -0.3, 0.0, 13.5, 0.0
    )
    assert flight.x_n == pytest.approx(
        tunnel_free.x_n * 1.0, rel=0.05
    )  # differ only by strut effect


def _equal_area_equal_span_pair() -> tuple[VehicleConfiguration, VehicleConfiguration]:
    # b = 200 mm and S = 120 cm^2 for both (same AR 3.33), different chord distribution across the
    # span
    broad_tips = TailGeometry.from_mm(200, 160, 62.666666666666664, 36)
    narrow_tips = TailGeometry.from_mm(200, 100, 70, 30)
    assert broad_tips.area_m2 == pytest.approx(narrow_tips.area_m2, rel=1e-12)
    return VehicleConfiguration(broad_tips, 0.098), VehicleConfiguration(narrow_tips, 0.098)


@pytest.mark.parametrize("x_h_mm", [57, 126])
def test_wake_profile_off_leaves_only_area_and_aspect_ratio(x_h_mm) -> None:
    broad, narrow = (
        dataclasses.replace(c, x_h_m=x_h_mm / 1000) for c in _equal_area_equal_span_pair()
    )

    def tail_x(configuration, effects):
        return (
            PreparedVehicle(configuration, effects, "flight")
            .loads(-0.7, -0.3, 0.0, 13.5, 0.0)
            .tail_x_n
        )

    uniform = ALL.without("wake_profile")
    # equal up to the 48-strip midpoint rule's area error on the kinked chord (~1e-4 relative)
    assert tail_x(broad, uniform) == pytest.approx(tail_x(narrow, uniform), rel=5e-4)
    assert abs(tail_x(broad, ALL) / tail_x(narrow, ALL) - 1) > 0.02


def test_added_mass_raises_pitch_inertia_only() -> None:
    on, off = linearise(S3_98, ALL), linearise(S3_98, ALL.without("added_mass"))
    assert on.trim == off.trim
    assert on.derivatives == pytest.approx(off.derivatives, rel=1e-9)
    added = on.iyy_kg_m2 - off.iyy_kg_m2
    assert 0.01 * off.iyy_kg_m2 < added < 0.2 * off.iyy_kg_m2  # flat-plate estimate: a few per cent
    assert on.rigid_body_iyy_kg_m2 == off.iyy_kg_m2
    assert on.oscillatory_natural_frequency_rad_s() < off.oscillatory_natural_frequency_rad_s()


def test_cg_shift_off_freezes_cg_and_inertia_at_98mm() -> None:
    off = ALL.without("cg_shift_with_x_h")
    aft = study_configuration("S3", 126)
    reference = mass_properties(S3_98, ALL)
    frozen = mass_properties(aft, off)
    assert (frozen.cg_station_m, frozen.iyy_kg_m2) == (reference.cg_station_m, reference.iyy_kg_m2)
    assert mass_properties(aft, ALL).cg_station_m > reference.cg_station_m + 0.005
    assert trim(S3_98, off) == trim(S3_98, ALL)  # at the reference position nothing changes
    assert trim(aft, off).airspeed_m_s > trim(aft, ALL).airspeed_m_s  # no growing wing arm


def test_frequency_coupling_changes_the_linear_model_not_the_trim() -> None:
    on, off = linearise(S3_98, ALL), linearise(S3_98, ALL.without("flapping_frequency_coupling"))
    assert on.trim == off.trim
    assert abs(on.derivatives["Zw"] - off.derivatives["Zw"]) > 1e-4


def test_day_to_day_drift_changes_trim_per_day_only_when_on() -> None:
    day = [trim(S3_98, ALL.replace_effect("day_to_day_drift", day=d)) for d in range(3)]
    assert len({round(state.airspeed_m_s, 6) for state in day}) == 3
    off = ALL.without("day_to_day_drift")
    assert trim(S3_98, off) == trim(S3_98, off.replace_effect("day_to_day_drift", day=5))


def _gauges(effects: EffectSet, samples: int = 2000, **point) -> np.ndarray:
    source = TunnelSignalSource(S3_98, effects, seed=11)
    source.set_operating_point(**point)
    return source.next_block(samples)


def test_balance_resolution_adds_noise_at_the_sensor_resolution() -> None:
    quiet = EffectSet.none()
    assert np.ptp(_gauges(quiet)[:, :6], axis=0).max() == 0.0
    noisy = _gauges(quiet.with_enabled("balance_resolution"))[:, :6]
    force_std = (noisy @ balance_calibration_matrix_si().T)[:, :3].std(axis=0)
    # 1.46e-3 N noise plus 16-bit quantisation (~0.3 mV * 7 N/V / sqrt(12) ~ 6e-4 N): 1.4-2.0e-3 N
    assert np.all((force_std > 1.3e-3) & (force_std < 2.2e-3))


def test_thermal_drift_moves_the_gauge_offsets_while_the_motor_runs() -> None:
    def drift(effects: EffectSet) -> np.ndarray:
        source = TunnelSignalSource(S3_98, effects, seed=4, sample_rate_hz=200.0)
        source.set_operating_point(pitch_rad=0.4, flapping_frequency_hz=13.5)
        block = source.next_block(200 * 400)  # 400 s of running
        return block[-2000:, :6].mean(axis=0) - block[:2000, :6].mean(axis=0)

    base = EffectSet.none()
    assert np.abs(drift(base.with_enabled("balance_thermal_drift"))).max() > 1e-3
    assert np.abs(drift(base)).max() < 1e-4


def test_hotwire_temperature_changes_only_the_bridge_voltage() -> None:
    point = {"pitch_rad": 0.4, "tunnel_velocity_m_s": 0.8, "flapping_frequency_hz": 13.5}
    on = _gauges(ALL, **point)
    off = _gauges(ALL.without("hotwire_temperature"), **point)
    np.testing.assert_array_equal(np.delete(on, 6, axis=1), np.delete(off, 6, axis=1))
    # flow 1.5 K warmer than calibration: E falls by ~ 1.5 / (2 * 230) = 0.33 %
    assert on[:, 6].mean() / off[:, 6].mean() == pytest.approx(1 - 1.5 / 2 / 230, abs=3e-4)


def test_structural_resonance_amplifies_harmonics_not_the_mean() -> None:
    point = {"pitch_rad": 0.4, "tunnel_velocity_m_s": 0.8, "flapping_frequency_hz": 13.5}
    base = EffectSet.none()
    plain = _gauges(base, 20_000, **point)
    ringing = _gauges(base.with_enabled("structural_resonance"), 20_000, **point)
    assert ringing[:, :6].std(axis=0).max() > 1.2 * plain[:, :6].std(axis=0).max()
    cycles = slice(0, int(round(27 * 10_000 / 13.5)))  # 27 whole cycles at constant frequency
    np.testing.assert_allclose(
        ringing[cycles, :6].mean(axis=0), plain[cycles, :6].mean(axis=0), atol=2e-4
    )


def test_every_registered_effect_is_exercised_here() -> None:
    with open(__file__) as handle:
        source = handle.read()
    missing = [name for name in EFFECT_NAMES if f'"{name}"' not in source]
    assert missing == []
