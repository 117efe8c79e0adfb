"""``ornitail design propose``: a tail geometry for steady-state and damping targets (design/proposal.py)."""

from __future__ import annotations

from pathlib import Path

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.app.trend_source_options import trend_source_options
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import prepare_output_directory
from ornitail.design.drawing import write_proposal_drawings
from ornitail.design.proposal import (
    INTERVAL_KINDS,
    OBJECTIVES,
    propose,
)
from ornitail.design.proposal_plots import write_proposal_pictures
from ornitail.design.proposal_report import (
    check_solver_settings,
    design_targets,
    proposal_result,
    render_proposal,
)
from ornitail.design.trend_sources import gather_observations
from ornitail.design.trends import fit_trends


@click.command("propose")
@click.option(
    "--theta-ss-deg", type=float, default=None, help="Target steady pitch attitude (deg)."
)
@click.option(
    "--theta-tol-deg",
    type=float,
    default=0.0,
    show_default=True,
    help="Half-width of the theta band (deg).",
)
@click.option("--v-ss-m-s", type=float, default=None, help="Target steady airspeed (m/s).")
@click.option(
    "--v-tol-m-s",
    type=float,
    default=0.0,
    show_default=True,
    help="Half-width of the V band (m/s).",
)
@click.option("--f-ss-hz", type=float, default=None, help="Target flapping frequency (Hz).")
@click.option(
    "--f-tol-hz", type=float, default=0.0, show_default=True, help="Half-width of the f band (Hz)."
)
@click.option(
    "--zeta", type=float, default=None, help="Minimum damping ratio of the oscillatory pitch mode."
)
@click.option(
    "--omega-rad-s", type=float, default=None, help="Target natural frequency of that mode (rad/s)."
)
@click.option(
    "--omega-tol-rad-s",
    type=float,
    default=0.0,
    show_default=True,
    help="Half-width of the omega band.",
)
@click.option("--objective", type=click.Choice(OBJECTIVES), default="min-area", show_default=True)
@click.option(
    "--robust-k",
    type=float,
    default=0.0,
    show_default=True,
    help="Constrain zeta - k sigma_zeta >= --zeta (delta method).",
)
@click.option(
    "--robust-interval",
    type=click.Choice(INTERVAL_KINDS),
    default="new",
    show_default=True,
    help="sigma_zeta of the mean trend or of a new flight.",
)
@click.option("--x-h-mm", type=float, default=None, help="Use this tail position only (mm).")
@click.option("--continuous-x-h", is_flag=True, help="Treat x_h as continuous (57-126 mm).")
@click.option(
    "--starts",
    "start_count",
    type=int,
    default=8,
    show_default=True,
    help="Sobol starts per position.",
)
@trend_source_options
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False),
    default="proposal",
    show_default=True,
    help="Directory for planform.svg/png, cut_1to1.svg and the proposal's pictures "
    "(proposal_poles, proposal_response, proposal_in_data; PNG and PDF).",
)
@json_option
def propose_command(
    theta_ss_deg,
    theta_tol_deg,
    v_ss_m_s,
    v_tol_m_s,
    f_ss_hz,
    f_tol_hz,
    zeta,
    omega_rad_s,
    omega_tol_rad_s,
    objective,
    robust_k,
    robust_interval,
    x_h_mm,
    continuous_x_h,
    start_count,
    study,
    campaigns,
    tunnels,
    user_csvs,
    basis,
    out_dir,
    as_json,
) -> None:
    """Propose a tail (b, b_LE, c_r, c_t, x_h) meeting steady-state and pitch-damping targets."""
    targets = design_targets(
        theta_ss_deg,
        theta_tol_deg,
        v_ss_m_s,
        v_tol_m_s,
        f_ss_hz,
        f_tol_hz,
        zeta,
        omega_rad_s,
        omega_tol_rad_s,
    )
    if all(band is None for band in targets.bands()) and objective != "max-damping":
        raise UserInputError(
            "targets",
            "give at least one target (--theta-ss-deg, --v-ss-m-s, --f-ss-hz, --zeta, --omega-rad-s)",
        )
    if x_h_mm is not None and continuous_x_h:
        raise UserInputError("--x-h-mm", "give either --x-h-mm or --continuous-x-h, not both")
    check_solver_settings(x_h_mm, start_count, robust_k)
    prepare_output_directory(out_dir)
    # The study's tables when no source is chosen (as design/trend_sources.trend_model_from_sources does); the
    # observations are kept for the picture of where the design sits among them.
    observations = gather_observations(
        study or not (campaigns or tunnels or user_csvs), campaigns, tunnels, user_csvs
    )
    trend_model = fit_trends(observations, basis=basis)
    proposal = propose(
        trend_model,
        targets,
        objective=objective,
        robust_k=robust_k,
        interval_kind=robust_interval,
        x_h_m=None if x_h_mm is None else x_h_mm / 1e3,
        continuous_x_h=continuous_x_h,
        start_count=start_count,
    )
    result = proposal_result(proposal, trend_model)
    title = (
        f"S {result['s_cm2']:.1f} cm^2, AR {result['ar']:.2f}, x_h {result['x_h_mm']:.0f} mm, "
        f"zeta {proposal.evaluation.damping_ratio.value:.2f}"
    )
    result["files"] = {
        **write_proposal_drawings(proposal.geometry, title, Path(out_dir)),
        **write_proposal_pictures(proposal.evaluation, observations, Path(out_dir)),
    }
    emit(result, as_json, render_proposal)
