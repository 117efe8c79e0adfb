"""Proposal NLP: characteristic polynomial, a constructed problem with a known optimum, numpy check of
the damping, infeasible targets, the 1:1 cut file and the command line."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.optimize import brentq

from ornitail.app.cli import main
from ornitail.app.commands.design import design_group
from ornitail.core.normal_quantiles import NORMAL_QUANTILE_95
from ornitail.design.design_evaluation import MassInertiaModel, evaluate_design
from ornitail.design.drawing import CUT_FILE_MARGIN_MM, cut_file_svg
from ornitail.design.linear_model import a_matrix, characteristic_polynomial, modal_summary
from ornitail.design.proposal import (
    DesignTargets,
    ProposalProblem,
    SolveSettings,
    TargetBand,
    best_of_starts,
    propose,
    sobol_start_points,
)
from ornitail.design.proposal_report import honest_status, targets_within_their_noise
from ornitail.design.trend_data import TrendObservation
from ornitail.design.trends import fit_trends
from ornitail.vehicle.geometry import TailGeometry, study_tails

MASS_KG = 0.0235
IYY_KG_M2 = 1.5e-4
CONSTANT_MASS = MassInertiaModel(lambda v: MASS_KG, lambda v: IYY_KG_M2, "test constants")
# Known trends (value = intercept + slope * S, S in m^2): sim-like derivatives with Mq and Mu growing
# with area, so the pitch damping rises monotonically from ~0.18 at 50 cm^2 to ~0.53 at 200 cm^2.
KNOWN_TRENDS = {
    "Mq": (-0.0012, -0.2),
    "Mu": (0.0073, -0.2),
    "Mw": (0.0018, 0.0),
    "Xq": (0.0066, 0.0),
    "Xu": (-0.119, 0.0),
    "Xw": (-0.026, 0.0),
    "Zq": (-0.0026, 0.0),
    "Zu": (0.034, 0.0),
    "Zw": (-0.0083, 0.0),
    "theta_ss_rad": (math.radians(15.0), math.radians(1000.0)),
    "v_ss_m_s": (0.5, 20.0),
}


def known_values(area_m2: float) -> dict[str, float]:
    return {name: a + b * area_m2 for name, (a, b) in KNOWN_TRENDS.items()}


def known_damping(area_m2: float) -> float:
    """zeta of the constructed model at area S, straight from numpy eigenvalues."""
    values = known_values(area_m2)
    matrix = a_matrix(values, MASS_KG, IYY_KG_M2, values["theta_ss_rad"], values["v_ss_m_s"])
    return modal_summary(matrix).damping_ratio


def constructed_trend_model(noise_fraction: float = 0.0, seed: int = 3):
    """Fit (real fit_trends, basis [1, S, x_h]) to observations lying on the known trends."""
    rng = np.random.default_rng(seed)
    observations = []
    for name, tail in study_tails().items():
        if tail.geometry.leading_edge_span_m is None:
            continue
        for x_h in (0.057, 0.098, 0.126):
            for quantity, value in known_values(tail.geometry.area_m2).items():
                noisy = value * (1 + noise_fraction * rng.standard_normal())
                observations.append(
                    TrendObservation(
                        f"{name}@{x_h}", name, tail.geometry, x_h, quantity, noisy, None, "test"
                    )
                )
    return fit_trends(observations, basis="linear-area")


@pytest.fixture(scope="module")
def exact_problem() -> ProposalProblem:
    return ProposalProblem(constructed_trend_model(), mass_inertia=CONSTANT_MASS)


@pytest.mark.parametrize("seed", range(5))
def test_characteristic_polynomial_equals_numpy_poly(seed: int) -> None:
    matrix = np.random.default_rng(seed).normal(size=(4, 4))
    # Faddeev-LeVerrier in float64 on an O(1) matrix: round-off ~1e-14
    assert np.allclose(characteristic_polynomial(matrix), np.poly(matrix)[1:], atol=1e-12)


def test_a_matrix_reproduces_the_simulator_linearisation() -> None:
    from ornitail.sim.configuration import study_configuration
    from ornitail.sim.dynamics import linearise

    model = linearise(study_configuration("S3", 98.0))
    trim = model.trim
    matrix = a_matrix(
        model.derivatives, model.mass_kg, model.iyy_kg_m2, trim.theta_rad, trim.airspeed_m_s
    )
    # same formula, same gravity (vehicle/constants.py), same numbers (round-off only; the trim angle is carried
    # through sin and cos differently, a few parts in 1e9)
    assert np.allclose(matrix, model.a_matrix, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("zeta_target", [0.30, 0.45])
def test_min_area_finds_the_hand_computed_optimum(exact_problem, zeta_target: float) -> None:
    # zeta rises monotonically with S, so the smallest tail with zeta >= target has zeta(S*) = target
    optimum_area = brentq(lambda s: known_damping(s) - zeta_target, 0.005, 0.02, xtol=1e-12)
    proposal = propose(
        exact_problem.trend_model,
        DesignTargets(damping_ratio_min=zeta_target),
        x_h_m=0.098,
        start_count=4,
        problem=exact_problem,
    )
    assert proposal.targets_met
    # IPOPT tol 1e-9 on the order-one damping constraint; dzeta/dS ~ 30 per m^2 -> dS ~ 1e-10 m^2
    assert proposal.area_m2 == pytest.approx(optimum_area, abs=1e-8)
    assert proposal.evaluation.damping_ratio.value == pytest.approx(zeta_target, abs=1e-6)
    assert proposal.geometry.validation_problems() == []
    assert "target damping_ratio (lower bound)" in proposal.binding_constraints


def proposal_at_a_damping_floor(trend_model, robust_k: float):
    """The smallest tail at 98 mm with zeta - k sigma_new >= 0.35."""
    return propose(
        trend_model,
        DesignTargets(damping_ratio_min=0.35),
        robust_k=robust_k,
        interval_kind="new",
        x_h_m=0.098,
        start_count=4,
        mass_inertia=CONSTANT_MASS,
    )


@pytest.mark.parametrize("robust_k", [0.0, 1.0])
def test_damping_inside_the_problem_equals_numpy_eigenvalues(robust_k: float) -> None:
    trend_model = constructed_trend_model(noise_fraction=0.02)
    proposal = proposal_at_a_damping_floor(trend_model, robust_k)
    evaluation = evaluate_design(trend_model, proposal.geometry, proposal.x_h_m, CONSTANT_MASS)
    # factor equalities hold to IPOPT's 1e-9; zeta is well conditioned (simple complex pair)
    assert proposal.damping_ratio_in_problem == pytest.approx(
        evaluation.damping_ratio.value, abs=1e-6
    )
    assert proposal.natural_frequency_in_problem_rad_s == pytest.approx(
        evaluation.natural_frequency_rad_s.value, abs=1e-5
    )
    # implicit differentiation (exact) against central differences of numpy eig (error ~1e-8 rel)
    assert proposal.sigma_damping_ratio_in_problem == pytest.approx(
        evaluation.damping_ratio.sigma_new, rel=1e-4
    )
    robust = evaluation.damping_ratio.value - robust_k * evaluation.damping_ratio.sigma_new
    assert robust == pytest.approx(0.35, abs=1e-5)


def test_a_floor_met_by_the_predicted_value_alone_is_said_so_and_a_robust_one_is_not() -> None:
    trend_model = constructed_trend_model(noise_fraction=0.02)

    # Without the robust term the damping sits on its floor: half the new flights fall below it.
    nominal = proposal_at_a_damping_floor(trend_model, 0.0)
    assert nominal.targets_met
    low, high = nominal.evaluation.damping_ratio.interval_95("new")
    assert low < 0.35 < high
    (phrase,) = targets_within_their_noise(nominal)
    assert phrase == f"damping ratio {low:.3g} to {high:.3g} reaches below 0.35"
    status = honest_status(nominal, extrapolated=0, trends=len(trend_model.trends))
    assert status.startswith(
        "targets met by the predicted values only (95 % intervals for a new flight: damping ratio"
    )
    # With k = 1.96 the interval's lower end is the floor (to the solver's tolerance): a plain "targets met".
    robust = proposal_at_a_damping_floor(trend_model, NORMAL_QUANTILE_95)
    assert robust.evaluation.damping_ratio.interval_95("new")[0] == pytest.approx(0.35, abs=1e-5)
    assert targets_within_their_noise(robust) == []
    assert honest_status(robust, 0, len(trend_model.trends)).startswith("targets met; IPOPT")


def test_early_stop_of_multi_start_keeps_the_optimum(exact_problem) -> None:
    settings = SolveSettings(DesignTargets(damping_ratio_min=0.40), x_h_range_m=(0.098, 0.098))
    starts = sobol_start_points(exact_problem.bounds, 8, (0.098, 0.098))
    every, every_converged, every_tried = best_of_starts(
        exact_problem, settings, starts, agreeing_starts=0
    )
    early, early_converged, early_tried = best_of_starts(
        exact_problem, settings, starts, agreeing_starts=3
    )
    assert every_tried == 8
    assert 3 <= early_converged <= early_tried < every_tried
    assert every_converged >= early_converged
    # both stop at IPOPT tol 1e-9 on an order-one objective (S in units of 100 cm^2)
    assert early.objective_value == pytest.approx(every.objective_value, abs=1e-7)


def test_robust_build_with_k_zero_equals_the_build_without_the_robust_term(exact_problem) -> None:
    # k = 0 in the robust NLP multiplies sigma_zeta by zero: the same problem, the same optimum
    settings = SolveSettings(DesignTargets(damping_ratio_min=0.40), x_h_range_m=(0.098, 0.098))
    start = sobol_start_points(exact_problem.bounds, 1, (0.098, 0.098))[0]
    plain = exact_problem.solve_from(settings, start)
    exact_problem._nlp_for(robust=True)  # noqa: SLF001 - the robust NLP, solved with k = 0
    robust_nlp = exact_problem._builds.pop(True)  # noqa: SLF001
    exact_problem._builds[False], saved = robust_nlp, exact_problem._builds[False]  # noqa: SLF001
    try:
        with_term = exact_problem.solve_from(settings, start)
    finally:
        exact_problem._builds[False] = saved  # noqa: SLF001
    # IPOPT tol 1e-9 on both; the geometry's degenerate directions are fixed by S and AR only
    assert with_term.objective_value == pytest.approx(plain.objective_value, abs=1e-7)
    assert with_term.damping_ratio == pytest.approx(plain.damping_ratio, abs=1e-6)
    assert with_term.sigma_damping_ratio == pytest.approx(plain.sigma_damping_ratio, rel=1e-6)


def test_unreachable_target_gives_nearest_design_and_names_the_binding_constraint(
    exact_problem,
) -> None:
    # theta = 15 deg + 1000 deg/m^2 * S; the trends were fitted on the study tails, so S may not
    # exceed the largest fitted area (S6, ~170 cm^2): theta reaches at most ~32 deg there
    largest_fitted_area = max(
        t.geometry.area_m2
        for t in study_tails().values()
        if t.geometry.leading_edge_span_m is not None
    )
    proposal = propose(
        exact_problem.trend_model,
        DesignTargets(theta_ss_rad=TargetBand.around(math.radians(50))),
        x_h_m=0.098,
        start_count=4,
        problem=exact_problem,
    )
    assert not proposal.targets_met
    assert "nearest achievable" in proposal.solver_status
    # the area constraint holds to IPOPT's tolerance on an order-one scaled inequality
    assert proposal.area_m2 == pytest.approx(largest_fitted_area, rel=1e-6)
    assert any(
        name.startswith("S_m2 <=") and "fitted data range" in name
        for name in proposal.binding_constraints
    )
    expected_miss_deg = 50.0 - (15.0 + 1000.0 * largest_fitted_area)
    assert math.degrees(proposal.unmet_targets["theta_ss"]) == pytest.approx(
        expected_miss_deg, abs=1e-3
    )


@pytest.mark.parametrize("dims_mm", [(203, 105, 66, 35), (120, 90, 60, 30)])
def test_cut_file_is_one_to_one_in_millimetres(dims_mm) -> None:
    geometry = TailGeometry.from_mm(*dims_mm)
    text = cut_file_svg(geometry)
    width = float(re.search(r'width="([\d.]+)mm"', text).group(1))
    view_box = [float(v) for v in re.search(r'viewBox="([^"]+)"', text).group(1).split()]
    assert view_box[2] == pytest.approx(width)  # one user unit = 1 mm
    points = np.array(
        [
            [float(c) for c in p.split(",")]
            for p in re.search(r'points="([^"]+)"', text).group(1).split()
        ]
    )
    b, b_le, c_r, c_t = dims_mm
    # coordinates written with 3 decimals: 0.001 mm
    assert np.ptp(points[:, 0]) == pytest.approx(b, abs=2e-3)
    assert np.ptp(points[:, 1]) == pytest.approx(c_r, abs=2e-3)
    leading = points[np.isclose(points[:, 1], CUT_FILE_MARGIN_MM)]
    assert np.ptp(leading[:, 0]) == pytest.approx(b_le, abs=2e-3)
    tips = points[np.isclose(points[:, 0], CUT_FILE_MARGIN_MM)]
    assert np.ptp(tips[:, 1]) == pytest.approx(c_t, abs=2e-3)
    assert width == pytest.approx(b + 2 * CUT_FILE_MARGIN_MM)


def test_propose_command_on_study_data(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        design_group,
        [
            "propose",
            "--theta-ss-deg",
            "25",
            "--zeta",
            "0.5",
            "--x-h-mm",
            "57",
            "--starts",
            "8",
            "--out",
            str(tmp_path),
            "--json",
        ],
    )
    assert result.exit_code == 0, result.output
    answer = json.loads(result.output)
    assert answer["geometry"]["valid"]
    assert answer["x_h_mm"] == pytest.approx(57.0)
    if answer["targets_met"]:
        assert answer["steady_state"]["theta_ss_deg"]["value"] == pytest.approx(25.0, abs=1e-4)
        assert answer["oscillatory_mode"]["damping_ratio"]["value"] >= 0.5 - 1e-6
    # Table 4 has derivatives at 98 mm only: at 57 mm every derivative trend is named as extrapolated, and why;
    # the steady-state trends (fitted at 57-126 mm) are not.
    notes = answer["extrapolation_notes"]
    assert {"Mq", "Xu", "Mu"} <= set(notes) and "theta_ss_rad" not in notes
    assert "every fitted observation has 0.098" in notes["Mq"]
    # The headline says so: never a plain "targets met" outside the fitted data.
    assert answer["targets_met_inside_fitted_data"] is False
    if answer["targets_met"]:
        assert answer["solver_status"].startswith("targets met by extrapolation (")
    for path in answer["files"].values():
        assert Path(path).stat().st_size > 0


def test_propose_command_refuses_a_bad_target() -> None:
    result = CliRunner().invoke(main, ["design", "propose", "--zeta", "1.5", "--json"])
    assert result.exit_code == 2
    assert "--zeta" in result.output
    assert "Traceback" not in result.output


def test_propose_runs_in_a_subprocess(tmp_path: Path) -> None:
    completed = subprocess.run(
        [
            str(Path(sys.executable).parent / "ornitail"),
            "design",
            "propose",
            "--theta-ss-deg",
            "25",
            "--x-h-mm",
            "57",
            "--starts",
            "8",
            "--out",
            str(tmp_path),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert completed.returncode == 0, completed.stderr
    answer = json.loads(completed.stdout)
    assert answer["steady_state"]["theta_ss_deg"]["value"] == pytest.approx(25.0, abs=1e-4)
    assert (tmp_path / "cut_1to1.svg").exists()
