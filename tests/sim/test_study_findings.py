"""One test per finding of the study (Rijks et al., AIAA 2018-0524, Section IV.B; issue 13).

Every study tail is trimmed and linearised once per position (module-level cache) with all effects on,
at the study's four tail positions (reference/fuselages.csv). The findings are signs and orderings; the
numbers checked against the study are the Table 3 steady states at 57 mm and the damping ratios at 98 mm
that the Table 4 derivatives imply.
"""

from __future__ import annotations

import numpy as np
import pytest
import study_findings as study

# The simulator's trims and the study's numbers come from the benchmark that prints the same findings (one home).

POSITIONS_MM, AREA_SERIES, ASPECT_SERIES = (
    study.POSITIONS_MM,
    study.AREA_SERIES,
    study.ASPECT_SERIES,
)
model, theta_deg, speed, frequency = study.model, study.theta_deg, study.speed, study.frequency
damping, natural_frequency, increasing = (
    study.damping,
    study.natural_frequency,
    study.strictly_increasing,
)


@pytest.mark.parametrize("x_h_mm", POSITIONS_MM)
@pytest.mark.parametrize("series", [AREA_SERIES, ASPECT_SERIES], ids=["S", "AR"])
def test_larger_tail_flies_steeper_and_faster_with_more_damping_and_lower_natural_frequency(
    series, x_h_mm
) -> None:
    assert increasing([theta_deg(tail, x_h_mm) for tail in series])
    assert increasing([speed(tail, x_h_mm) for tail in series])
    # AR6 is checked on its own below (it damps like AR5, not more)
    damped = series if series == AREA_SERIES else series[:-1]
    assert increasing([damping(tail, x_h_mm) for tail in damped])
    first, last = natural_frequency(series[0], x_h_mm), natural_frequency(series[-1], x_h_mm)
    # "slightly lower": the study's natural frequencies differ by tens of percent at most
    assert 0.7 * first < last < first


@pytest.mark.xfail(
    strict=True,
    reason="AR6 damps like AR5 (0.345 vs 0.351 at 98 mm): at the trim angle of attack the tail's "
    "attached flow has separated, so the higher lift slope no longer adds damping and AR6's 2 % "
    "smaller area and lighter build offset it (docs/simulator.md, Findings of the study)",
)
@pytest.mark.parametrize("x_h_mm", POSITIONS_MM)
def test_ar6_is_more_damped_than_ar5(x_h_mm) -> None:
    assert damping("AR6", x_h_mm) > damping("AR5", x_h_mm)


def test_near_the_wings_aspect_ratio_acts_more_strongly_than_area() -> None:
    # Table 3 at 57 mm: AR2 -> AR6 +7.6 deg, S2 -> S6 +6.1 deg
    aspect_gain = theta_deg("AR6", 57.0) - theta_deg("AR2", 57.0)
    area_gain = theta_deg("S6", 57.0) - theta_deg("S2", 57.0)
    assert aspect_gain > area_gain > 0.0


@pytest.mark.parametrize(("tail", "measured"), sorted(study.table_3().items()))
def test_table_3_steady_states_at_57mm_within_the_study_scatter(tail, measured) -> None:
    # The study's own scatter (issue 13): its linear fits miss these points by up to 1.9 deg,
    # 0.05 m/s and 0.34 Hz and its sigma(meas) reach ~1.9 deg, 0.1 m/s, 0.5 Hz (Table 3 ratios);
    # 1.4 deg, 0.08 m/s and 0.6 Hz are the bounds for a model not fitted point by point.
    theta_meas_deg, v_meas_m_s, f_meas_hz = measured
    assert abs(theta_deg(tail, 57.0) - theta_meas_deg) < 1.4
    assert abs(speed(tail, 57.0) - v_meas_m_s) < 0.08
    assert abs(frequency(tail, 57.0) - f_meas_hz) < 0.6


def _frequency_drop(series: tuple[str, ...], x_h_mm: float) -> float:
    return frequency(series[0], x_h_mm) - frequency(series[-1], x_h_mm)


@pytest.mark.parametrize(
    ("series", "x_h_mm"),
    [(ASPECT_SERIES, x_h_mm) for x_h_mm in POSITIONS_MM]
    + [(AREA_SERIES, x_h_mm) for x_h_mm in (57.0, 98.0)],
)
def test_flapping_frequency_falls_slightly_with_area_and_aspect_ratio(series, x_h_mm) -> None:
    assert 0.0 < _frequency_drop(series, x_h_mm) < 1.0  # Table 3: AR2 -> AR6 -0.72 Hz at 57 mm


@pytest.mark.xfail(
    strict=True,
    reason="aft of 98 mm the S series' theta spread shrinks (S1 -> S6 +3.2 deg at 126 mm) and the "
    "0.7 g heavier S6 planform needs more thrust than its steeper trim saves: f rises 0.02-0.1 Hz "
    "(docs/simulator.md, Findings of the study)",
)
@pytest.mark.parametrize("x_h_mm", [114.0, 126.0])
def test_flapping_frequency_falls_with_area_aft_of_98mm(x_h_mm) -> None:
    assert _frequency_drop(AREA_SERIES, x_h_mm) > 0.0


@pytest.mark.parametrize("tail", ["S1", "AR1"])
def test_narrow_tails_gain_damping_up_to_98mm_then_lose_it_sharply(tail) -> None:
    zetas = [damping(tail, x_h_mm) for x_h_mm in POSITIONS_MM]
    assert zetas[1] > zetas[0]
    assert zetas[3] < 0.7 * zetas[1]  # "sharply": a third or more of the 98 mm damping is lost


def test_s3_keeps_its_damping_to_126mm() -> None:
    zetas = [damping("S3", x_h_mm) for x_h_mm in POSITIONS_MM]
    assert zetas[1] > zetas[0]
    assert min(zetas[1:]) > 0.9 * zetas[1]


def test_the_aspect_ratio_advantage_fades_aft() -> None:
    spread = [theta_deg("AR5", x_h_mm) - theta_deg("AR1", x_h_mm) for x_h_mm in POSITIONS_MM]
    assert all(value > 0.0 for value in spread)
    assert increasing(spread[::-1])


def test_mu_is_set_by_x_h_and_xq_peaks_near_98mm() -> None:
    mu = [model("S3", x_h_mm).derivatives["Mu"] for x_h_mm in POSITIONS_MM]
    mu_tails = [model(tail, 98.0).derivatives["Mu"] for tail in AREA_SERIES + ASPECT_SERIES]
    assert max(mu) - min(mu) > max(mu_tails) - min(mu_tails)
    xq = [abs(model("S3", x_h_mm).derivatives["Xq"]) for x_h_mm in POSITIONS_MM]
    assert int(np.argmax(xq)) in (1, 2)  # 98 or 114 mm


@pytest.mark.xfail(
    strict=True,
    reason="|Mq| of S3 grows x1.9 from 57 to 126 mm: the quasi-steady tail damping scales with "
    "the tail arm times (arm + wake lag length), which the wake's decay and narrowing offset only "
    "in part; even a 0.1 m wake decay leaves x1.5 (docs/simulator.md, Findings of the study)",
)
def test_mq_hardly_depends_on_x_h() -> None:
    mq = [abs(model("S3", x_h_mm).derivatives["Mq"]) for x_h_mm in POSITIONS_MM]
    assert max(mq) / min(mq) < 1.25  # "hardly": within 25 % over 57-126 mm


def test_t3_is_lightly_damped_at_57mm_and_unstable_aft() -> None:
    # The study identified T3 at 57 mm (30 % doublets, heavy oscillation) and lost it at 98, 126 mm
    assert 0.0 < damping("T3", 57.0) < 0.1
    assert damping("T3", 98.0) < 0.0
    assert damping("T3", 126.0) < 0.0


@pytest.mark.parametrize("x_h_mm", POSITIONS_MM)
@pytest.mark.parametrize("tail", AREA_SERIES + ASPECT_SERIES[:2] + ASPECT_SERIES[3:] + ("T2",))
def test_an_oscillatory_pair_and_real_poles_near_minus_1_and_minus_10(tail, x_h_mm) -> None:
    linear = model(tail, x_h_mm)
    assert linear.oscillatory_eigenvalue() is not None
    slow, fast = linear.real_poles()[::-1]
    # "near -1 and -10": within a factor ~2.5 of each (the study's real poles scatter, docs/background.md section 5)
    assert -2.5 < slow < -0.4
    assert -15.0 < fast < -5.0


@pytest.mark.parametrize("tail", sorted(study.TABLE_4_DAMPING))
def test_damping_ratio_at_98mm_matches_table_4(tail) -> None:
    # 0.05: the spread of the zeta Table 4 implies over I_yy = 1.3-1.7e-4 kg m^2 and the trims
    assert damping(tail, 98.0) == pytest.approx(study.TABLE_4_DAMPING[tail], abs=0.05)
