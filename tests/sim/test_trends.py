"""The simulator reproduces the study's trends (docs/background.md section 6) from physics."""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path

import pandas as pd
import pytest

from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import LinearisedModel, linearise
from ornitail.sim.effects import EffectSet

AREA_SERIES = ("S1", "S2", "S3", "S4", "S5", "S6")  # AR ~3.45, growing S
ASPECT_SERIES = ("AR1", "AR2", "S3", "AR4", "AR6")  # S ~118 cm^2, growing AR (S3 = AR3)
POSITIONS = (57.0, 98.0, 126.0)
VALIDATION = Path(__file__).parents[1] / "data" / "reference" / "steady_state_validation.csv"


@cache
def model(tail: str, x_h_mm: float) -> LinearisedModel:
    return linearise(study_configuration(tail, x_h_mm), EffectSet())


def _values(series: tuple[str, ...], x_h_mm: float, quantity) -> list[float]:
    return [quantity(model(tail, x_h_mm)) for tail in series]


def _theta(m: LinearisedModel) -> float:
    return m.trim.theta_rad


def _speed(m: LinearisedModel) -> float:
    return m.trim.airspeed_m_s


def _frequency(m: LinearisedModel) -> float:
    return m.trim.flapping_frequency_hz


def _increasing(values: list[float]) -> bool:
    return all(later > earlier for earlier, later in zip(values, values[1:], strict=False))


@pytest.mark.parametrize("x_h_mm", POSITIONS)
@pytest.mark.parametrize("series", [AREA_SERIES, ASPECT_SERIES], ids=["S", "AR"])
def test_bigger_tail_flies_steeper_faster_and_flaps_slower(series, x_h_mm) -> None:
    assert _increasing(_values(series, x_h_mm, _theta))
    assert _increasing(_values(series, x_h_mm, _speed))
    frequencies = _values(series, x_h_mm, _frequency)
    assert abs(frequencies[0] - frequencies[-1]) < 1.0  # frequency changes only slightly


@pytest.mark.parametrize("x_h_mm", [57.0, 98.0])
@pytest.mark.parametrize("series", [AREA_SERIES, ASPECT_SERIES], ids=["S", "AR"])
def test_bigger_tail_flaps_slightly_slower(series, x_h_mm) -> None:
    # At 126 mm the heavier large-S tails need more thrust than their steeper pitch saves, and the
    # S series' frequency rises by ~0.1 Hz (docs/simulator.md); the study measured at 57 mm.
    frequencies = _values(series, x_h_mm, _frequency)
    assert 0.0 < frequencies[0] - frequencies[-1] < 1.0


@pytest.mark.parametrize("tail", ["S1", "S3", "S6", "AR1", "AR6", "T2", "T3"])
def test_moving_the_tail_aft_lowers_speed_and_pitch(tail) -> None:
    positions = (57.0, 98.0, 114.0, 126.0)
    speeds = [model(tail, x).trim.airspeed_m_s for x in positions]
    thetas = [model(tail, x).trim.theta_rad for x in positions]
    assert _increasing(speeds[::-1]) and _increasing(thetas[::-1])


@pytest.mark.parametrize("x_h_mm", POSITIONS)
def test_damping_rises_and_natural_frequency_falls_with_area(x_h_mm) -> None:
    assert _increasing(_values(AREA_SERIES, x_h_mm, LinearisedModel.oscillatory_damping_ratio))
    assert _increasing(
        _values(AREA_SERIES, x_h_mm, LinearisedModel.oscillatory_natural_frequency_rad_s)[::-1]
    )


@pytest.mark.parametrize("x_h_mm", POSITIONS)
def test_damping_rises_with_aspect_ratio(x_h_mm) -> None:
    damping = _values(("AR1", "AR2", "AR4"), x_h_mm, LinearisedModel.oscillatory_damping_ratio)
    assert _increasing(damping)
    assert (
        model("AR6", x_h_mm).oscillatory_damping_ratio()
        > model("AR1", x_h_mm).oscillatory_damping_ratio()
    )


@pytest.mark.parametrize(
    ("narrow", "wide"), [("S1", "S3"), ("AR1", "S3"), ("S1", "S5"), ("AR1", "AR6")]
)
def test_narrow_tails_lose_damping_aft_of_98mm_while_wide_ones_keep_it(narrow, wide) -> None:
    def relative_loss(tail: str) -> float:
        at_98 = model(tail, 98.0).oscillatory_damping_ratio()
        return (at_98 - model(tail, 126.0).oscillatory_damping_ratio()) / at_98

    assert relative_loss(narrow) > 0.3  # narrow: loses a third or more of its damping
    assert relative_loss(wide) < 0.15  # wide: keeps most of it
    assert relative_loss(narrow) > 2 * relative_loss(wide)


@pytest.mark.parametrize("x_h_mm", POSITIONS)
def test_t3_is_the_least_damped_and_unstable_or_nearly_so(x_h_mm) -> None:
    damping_t3 = model("T3", x_h_mm).oscillatory_damping_ratio()
    assert damping_t3 < 0.05
    others = [
        model(tail, x_h_mm).oscillatory_damping_ratio() for tail in AREA_SERIES + ASPECT_SERIES
    ]
    assert damping_t3 < min(others)


@pytest.mark.parametrize("x_h_mm", POSITIONS)
def test_mq_grows_with_area_more_than_with_aspect_ratio(x_h_mm) -> None:
    area = [abs(d) for d in _values(AREA_SERIES, x_h_mm, lambda m: m.derivatives["Mq"])]
    assert _increasing(area)
    aspect = [abs(m) for m in _values(("AR1", "AR6"), x_h_mm, lambda m: m.derivatives["Mq"])]
    assert area[-1] / area[0] > aspect[-1] / aspect[0]


@pytest.mark.parametrize("x_h_mm", POSITIONS)
def test_xu_grows_weakly_with_area(x_h_mm) -> None:
    xu = [abs(d) for d in _values(AREA_SERIES, x_h_mm, lambda m: m.derivatives["Xu"])]
    assert _increasing(xu)
    assert xu[-1] / xu[0] < 1.3  # weak: < 30 % over a doubling of area (study: S1 -> S5 +10 %)


def test_mu_is_set_by_tail_position_not_tail_geometry() -> None:
    tails = AREA_SERIES + ASPECT_SERIES
    at_98 = [model(tail, 98.0).derivatives["Mu"] for tail in tails]
    spread_over_tails = (max(at_98) - min(at_98)) / min(at_98)
    change_with_position = (
        model("S3", 126.0).derivatives["Mu"] / model("S3", 57.0).derivatives["Mu"] - 1
    )
    assert all(value > 0 for value in at_98)
    assert change_with_position > 2 * spread_over_tails


def _study_tails() -> list[str]:
    return list(AREA_SERIES + ASPECT_SERIES + ("AR5", "T1", "T2"))


@pytest.mark.parametrize("tail", _study_tails())
@pytest.mark.parametrize("x_h_mm", [57.0, 98.0])
def test_steady_states_are_of_the_study_order(tail, x_h_mm) -> None:
    trim = model(tail, x_h_mm).trim
    # study: theta 20-29 deg, V 0.7-0.9 m/s, f 13-14 Hz at 57 mm; the bounds widen these by its
    # 2-sigma day-to-day scatter (~2 deg, 0.1 m/s, 0.2 Hz). 98 mm flies slower and flatter: the
    # CG moves ~10 mm aft and the wings' moment arm (38 mm at 57 mm, +40 % at 126 mm, docs/background.md section 1)
    # grows ~25 %, so tan(theta) falls ~20 % and the slower flight needs up to 0.5 Hz more.
    lowest_theta_deg, lowest_speed, highest_frequency = (
        (18.0, 0.6, 14.2) if x_h_mm == 57.0 else (14.0, 0.45, 14.4)
    )
    assert lowest_theta_deg < math.degrees(trim.theta_rad) < 31.0
    assert lowest_speed < trim.airspeed_m_s < 0.95
    assert 12.8 < trim.flapping_frequency_hz < highest_frequency


@pytest.mark.parametrize(
    "row", pd.read_csv(VALIDATION, comment="#").to_dict("records"), ids=lambda row: row["tail"]
)
def test_steady_states_near_the_measured_ones_at_57mm(row) -> None:
    # tolerances: the model is calibrated to orders and trends, not fitted to these six points; the
    # study's own linear fits miss them by up to 1.9 deg, 0.05 m/s, 0.34 Hz (Table 3), and the
    # vehicle drifts between days; the model's worst cases are 1.1 deg (AR6), 0.074 m/s (AR4),
    # 0.28 Hz (S4) (docs/simulator.md); tests/sim/test_study_findings.py holds the tighter bounds
    trim = model(row["tail"][:-1], 57.0).trim
    assert abs(math.degrees(trim.theta_rad) - row["theta_meas_deg"]) < 3.5
    assert abs(trim.airspeed_m_s - row["v_meas_m_s"]) < 0.08
    assert abs(trim.flapping_frequency_hz - row["f_meas_hz"]) < 0.4
