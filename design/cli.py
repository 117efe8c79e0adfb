"""``ornitail design``: tail geometry and, in the modules registered at the end, trends and proposals."""

from __future__ import annotations

from typing import Any

import click

from ornitail.core.output import emit, json_option
from ornitail.design.geometry import TailGeometry

design_group = click.Group("design", help="Tail design: geometry, trend fits, proposals.")


def geometry_result(
    b_mm: float, b_le_mm: float | None, c_r_mm: float, c_t_mm: float
) -> dict[str, Any]:
    """S (cm^2), AR and the dimensions of a valid planform; an invalid one raises UserInputError."""
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
    """Planform area S and aspect ratio AR of a tail from its dimensions in mm (domain.md section 2)."""
    emit(geometry_result(b_mm, b_le_mm, c_r_mm, c_t_mm), as_json, _render_geometry)


def _register_design_commands() -> None:
    from ornitail.design.trends_cli import trends_command

    design_group.add_command(trends_command)


_register_design_commands()


def _register_proposal_commands() -> None:
    from ornitail.design.pareto_cli import pareto_command
    from ornitail.design.propose_cli import propose_command

    design_group.add_command(propose_command)
    design_group.add_command(pareto_command)


_register_proposal_commands()
