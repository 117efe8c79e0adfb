"""``ornitail design``: tail geometry and, in the modules registered at the end, trends and proposals."""

from __future__ import annotations

from typing import Any

import click

from ornitail.app.cli import LazyCommand, LazyGroup
from ornitail.app.cli_output import emit, json_option

design_group = LazyGroup(
    "design",
    help="Tail design: geometry, trend fits, proposals.",
    lazy_commands={
        "trends": LazyCommand(
            "ornitail.app.commands.design_trends:trends_command",
            "Fit steady state and derivatives against tail geometry and x_h; print coefficients, LOO RMSE, "
            "sources and, with --predict-*, a prediction with both intervals and its extrapolation measure.",
        ),
        "propose": LazyCommand(
            "ornitail.app.commands.design_propose:propose_command",
            "Propose a tail (b, b_LE, c_r, c_t, x_h) meeting steady-state and pitch-damping targets.",
        ),
        "pareto": LazyCommand(
            "ornitail.app.commands.design_pareto:pareto_command",
            "Trade-off front by epsilon-constraint re-solves of the proposal problem.",
        ),
    },
)
"""Geometry is defined here; trends, propose and pareto (casadi, scipy, matplotlib) are imported on first use."""


def geometry_result(
    b_mm: float, b_le_mm: float | None, c_r_mm: float, c_t_mm: float
) -> dict[str, Any]:
    """S (cm^2), AR and the dimensions of a valid planform; an invalid one raises UserInputError."""
    from ornitail.vehicle.geometry import TailGeometry

    geometry = TailGeometry.from_mm(b_mm, b_le_mm, c_r_mm, c_t_mm)
    geometry.validate("--b/--b-le/--c-r/--c-t")
    return {
        "s_cm2": geometry.area_m2 * 1e4,
        "ar": geometry.aspect_ratio,
        "valid": True,
        "b_mm": b_mm,
        "b_le_mm": b_le_mm,
        "c_r_mm": c_r_mm,
        "c_t_mm": c_t_mm,
        "leading_edge": "elliptical" if b_le_mm is None else "straight",
    }


def _render_geometry(result: dict[str, Any]) -> str:
    return (
        f"S = {result['s_cm2']:.2f} cm^2, AR = {result['ar']:.3f} "
        f"({result['leading_edge']} leading edge; encloses the base tail: valid)"
    )


@design_group.command("geometry")
@click.option("--b", "b_mm", type=float, required=True, help="Maximum span b (mm).")
@click.option(
    "--b-le",
    "b_le_mm",
    type=float,
    default=None,
    help="Leading-edge span b_LE (mm); omit for an elliptical leading edge (tail T2).",
)
@click.option("--c-r", "c_r_mm", type=float, required=True, help="Root chord c_r (mm).")
@click.option("--c-t", "c_t_mm", type=float, required=True, help="Tip chord c_t (mm).")
@json_option
def geometry_command(
    b_mm: float, b_le_mm: float | None, c_r_mm: float, c_t_mm: float, as_json: bool
) -> None:
    """Planform area S and aspect ratio AR of a tail from its dimensions in mm (docs/background.md section 2)."""
    emit(geometry_result(b_mm, b_le_mm, c_r_mm, c_t_mm), as_json, _render_geometry)
