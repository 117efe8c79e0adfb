"""The demo's last stage: simulated flights -> trends (with the tunnel derivatives) -> a tail proposal.

Flies a small simulated campaign over tails and fuselages that span S, AR and x_h, identifies a representative model
per configuration with the study's procedure, fits the trends of steady state and derivatives against geometry
(the tunnel derivatives of the demo's sweep join them), and asks the design tool for the smallest tail that trims at
``DEMO_THETA_SS_DEG`` with the oscillatory pitch mode damped at least at ``DEMO_DAMPING_RATIO``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from ornitail.design.drawing import write_proposal_drawings
from ornitail.design.proposal import propose
from ornitail.design.proposal_report import design_targets, proposal_result
from ornitail.design.trend_sources import gather_observations
from ornitail.design.trends import fit_trends
from ornitail.flight.campaign import run_campaign
from ornitail.flight.campaign_file import DEFAULT_SEED, CampaignSpec, configuration_from_label
from ornitail.flight.campaign_table import write_campaign_table

DEMO_CAMPAIGN = ("S1@98", "S5@98", "AR1@98", "AR6@98", "S3@57", "S3@126")
"""Configurations flown: the S and AR series' ends at 98 mm and the middle tail at the outer fuselages."""
DEMO_MANOEUVRES_PER_CONFIGURATION = 5
DEMO_THETA_SS_DEG = 22.0
DEMO_THETA_TOLERANCE_DEG = 0.5
DEMO_DAMPING_RATIO = 0.25


def design_from_simulated_campaign(
    out_folder: Path, tunnel_derivatives: list[Path]
) -> dict[str, Any]:
    """Run the simulated campaign, fit trends and propose a tail; write tables and drawings under ``out_folder``."""
    campaign = CampaignSpec(
        tuple(
            configuration_from_label(
                label, "demo", simulated_manoeuvres=DEMO_MANOEUVRES_PER_CONFIGURATION
            )
            for label in DEMO_CAMPAIGN
        ),
        DEFAULT_SEED,
        "delfly_longitudinal",
    )
    with click.progressbar(
        length=len(DEMO_CAMPAIGN), label="simulated flights", file=sys.stderr
    ) as bar:
        results = run_campaign(
            campaign,
            lambda index, fraction, note: bar.update(max(0, index + int(fraction) - bar.pos)),
        )
    campaign_csv, _, _ = write_campaign_table(
        results, out_folder / "campaign", {"seed": campaign.seed, "model": campaign.model}
    )
    observations = gather_observations(
        False, (str(campaign_csv),), tuple(map(str, tunnel_derivatives)), ()
    )
    trend_model = fit_trends(observations, basis="linear")
    targets = design_targets(
        DEMO_THETA_SS_DEG,
        DEMO_THETA_TOLERANCE_DEG,
        None,
        0.0,
        None,
        0.0,
        DEMO_DAMPING_RATIO,
        None,
        0.0,
    )
    proposal = propose(trend_model, targets, objective="min-area")
    result = proposal_result(proposal, trend_model)
    title = (
        f"S {result['s_cm2']:.1f} cm^2, AR {result['ar']:.2f}, x_h {result['x_h_mm']:.0f} mm, "
        f"zeta {proposal.evaluation.damping_ratio.value:.2f}"
    )
    result["files"] = write_proposal_drawings(proposal.geometry, title, out_folder / "proposal")
    result["campaign_table"] = str(campaign_csv)
    result["targets"] = {
        "theta_ss_deg": DEMO_THETA_SS_DEG,
        "theta_tolerance_deg": DEMO_THETA_TOLERANCE_DEG,
        "damping_ratio_min": DEMO_DAMPING_RATIO,
    }
    return result
