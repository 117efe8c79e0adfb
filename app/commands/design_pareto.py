"""``ornitail design pareto``: a trade-off front (area against damping, or damping against V_ss)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.app.progress import Progress
from ornitail.app.trend_source_options import trend_source_options
from ornitail.core.input_files import prepare_output_directory
from ornitail.design.pareto import FRONT_KINDS, pareto_front, write_front
from ornitail.design.pareto_plots import front_evaluations
from ornitail.design.proposal import ProposalProblem
from ornitail.design.proposal_report import check_solver_settings, design_targets
from ornitail.design.trend_sources import trend_model_from_sources


def _render(result: dict[str, Any]) -> str:
    lines = [
        f"front {result['kind']} at x_h {result['x_h_mm']:.0f} mm ({len(result['points'])} points)",
        "   epsilon    S (cm^2)   zeta   sigma_new    V_ss (m/s)  theta_ss (deg)",
    ]
    for p in result["points"]:
        lines.append(
            f"  {p['epsilon']:8.4g}  {p['s_cm2']:9.2f}  {p['damping_ratio']:7.4f}  "
            f"{p['damping_ratio_sigma_new']:8.4f}  {p['v_ss_m_s']:9.4f}  {p['theta_ss_deg']:9.2f}"
        )
    lines += [f"{name}: {path}" for name, path in result["files"].items()]
    return "\n".join(lines)


@click.command("pareto")
@click.option("--kind", type=click.Choice(FRONT_KINDS), default="area-damping", show_default=True)
@click.option("--points", "point_count", type=int, default=8, show_default=True)
@click.option("--x-h-mm", type=float, default=98.0, show_default=True, help="Tail position (mm).")
@click.option(
    "--theta-ss-deg", type=float, default=None, help="Keep this steady pitch attitude (deg)."
)
@click.option("--theta-tol-deg", type=float, default=0.0, show_default=True)
@click.option("--starts", "start_count", type=int, default=4, show_default=True)
@trend_source_options
@click.option(
    "--out", "out_dir", type=click.Path(file_okay=False), default="pareto", show_default=True
)
@json_option
def pareto_command(
    kind,
    point_count,
    x_h_mm,
    theta_ss_deg,
    theta_tol_deg,
    start_count,
    study,
    campaigns,
    tunnels,
    user_csvs,
    basis,
    out_dir,
    as_json,
) -> None:
    """Trade-off front by epsilon-constraint re-solves of the proposal problem."""
    check_solver_settings(x_h_mm, start_count, point_count=point_count)
    targets = design_targets(theta_ss_deg, theta_tol_deg, None, 0.0, None, 0.0, None, None, 0.0)
    prepare_output_directory(out_dir)
    trend_model = trend_model_from_sources(study, campaigns, tunnels, user_csvs, basis)
    problem = ProposalProblem(trend_model)
    with Progress("design pareto", point_count + 2, "solves", bar_delay_s=1.0) as bar:
        points = pareto_front(
            problem,
            kind,
            targets,
            x_h_mm / 1e3,
            point_count,
            start_count,
            on_point=lambda done, total: bar.update(done, total=total),
        )
    evaluations = front_evaluations(problem, points)
    result = {
        "kind": kind,
        "x_h_mm": x_h_mm,
        "points": [
            {
                "epsilon": p.epsilon,
                "b_mm": p.geometry_vector_m[0] * 1e3,
                "b_le_mm": p.geometry_vector_m[1] * 1e3,
                "c_r_mm": p.geometry_vector_m[2] * 1e3,
                "c_t_mm": p.geometry_vector_m[3] * 1e3,
                "s_cm2": p.area_m2 * 1e4,
                "damping_ratio": p.damping_ratio,
                "damping_ratio_sigma_mean": e.damping_ratio.sigma_mean,
                "damping_ratio_sigma_new": e.damping_ratio.sigma_new,
                "v_ss_m_s": p.v_ss_m_s,
                "theta_ss_deg": math.degrees(p.theta_ss_rad),
            }
            for p, e in zip(points, evaluations, strict=True)
        ],
        "files": write_front(points, kind, Path(out_dir), evaluations),
    }
    emit(result, as_json, _render)
