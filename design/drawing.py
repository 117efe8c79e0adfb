"""Drawings of a proposed tail: the planform over the base tail (SVG and PNG) and a 1:1 cut file.

Coordinates: y spanwise (mm, from the plane of symmetry, y_b to the left wing), x aft of the root
leading edge (mm, along +z_b). The cut file is an SVG whose width and height are given in mm with a
viewBox in mm, so one user unit is one millimetre and printing or laser cutting at 100 % scale gives
the real size; it holds one closed polygon (the outline, id "tail-outline") with the
y coordinate shifted by b/2 + margin and x by margin so that every coordinate is positive.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ornitail.vehicle.geometry import TailGeometry, base_tail_outline_vertices_m  # noqa: E402

CUT_FILE_MARGIN_MM = 5.0


def planform_outline_mm(geometry: TailGeometry) -> np.ndarray:
    """Closed outline of a hexagonal planform, rows (y, x) in mm, first vertex repeated at the end."""
    if geometry.leading_edge_span_m is None:
        raise ValueError("only hexagonal planforms (b_LE given) have a polygon outline")
    half_span = geometry.span_m / 2 * 1e3
    half_leading = geometry.leading_edge_span_m / 2 * 1e3
    root = geometry.root_chord_m * 1e3
    tip_start = (geometry.root_chord_m - geometry.tip_chord_m) * 1e3
    outline = [
        (-half_leading, 0.0),
        (half_leading, 0.0),
        (half_span, tip_start),
        (half_span, root),
        (-half_span, root),
        (-half_span, tip_start),
        (-half_leading, 0.0),
    ]
    return np.array(outline)


def base_tail_outline_mm() -> np.ndarray:
    """Closed base-tail outline (y, x) in mm, in the same frame as :func:`planform_outline_mm`."""
    v = base_tail_outline_vertices_m() * 1e3
    order = [0, 2, 4, 3, 1, 0]  # centre, right corner, right trailing, left trailing, left corner
    return v[order]


def planform_figure(geometry: TailGeometry, title: str) -> plt.Figure:
    """The planform (solid) over the base tail (dashed), mm axes; the legend sits below the axes,
    clear of both outlines."""
    outline = planform_outline_mm(geometry)
    base = base_tail_outline_mm()
    figure, axes = plt.subplots(figsize=(7, 4))
    axes.fill(outline[:, 0], outline[:, 1], color="tab:blue", alpha=0.25, label="proposed tail")
    axes.plot(outline[:, 0], outline[:, 1], color="tab:blue")
    axes.plot(base[:, 0], base[:, 1], "k--", label="base tail (80 x 48 mm)")
    axes.set_xlabel("spanwise y (mm)")
    axes.set_ylabel("aft of root leading edge (mm)")
    axes.invert_yaxis()
    axes.set_aspect("equal")
    axes.grid(True, alpha=0.3)
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, frameon=False)
    axes.set_title(title)
    figure.tight_layout()
    return figure


def draw_planform(geometry: TailGeometry, title: str, svg_path: Path, png_path: Path) -> None:
    """Draw the planform (solid) over the base tail (dashed), mm axes, as SVG and PNG."""
    figure = planform_figure(geometry, title)
    figure.savefig(svg_path, bbox_inches="tight")
    figure.savefig(png_path, dpi=120, bbox_inches="tight")
    plt.close(figure)


def cut_file_svg(geometry: TailGeometry) -> str:
    """A 1:1 SVG cut file (mm units) with the planform outline as one closed polygon."""
    outline = planform_outline_mm(geometry)[:-1]
    margin = CUT_FILE_MARGIN_MM
    width = geometry.span_m * 1e3 + 2 * margin
    height = geometry.root_chord_m * 1e3 + 2 * margin
    points = " ".join(
        f"{y + geometry.span_m * 1e3 / 2 + margin:.3f},{x + margin:.3f}" for y, x in outline
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.3f}mm" height="{height:.3f}mm" '
        f'viewBox="0 0 {width:.3f} {height:.3f}">\n'
        f"  <title>ornitail tail: b {geometry.span_m * 1e3:.1f} mm, b_LE "
        f"{geometry.leading_edge_span_m * 1e3:.1f} mm, c_r {geometry.root_chord_m * 1e3:.1f} mm, "
        f"c_t {geometry.tip_chord_m * 1e3:.1f} mm (1:1, units mm)</title>\n"
        f'  <polygon id="tail-outline" points="{points}" fill="none" stroke="red" '
        'stroke-width="0.1"/>\n'
        "</svg>\n"
    )


def write_proposal_drawings(geometry: TailGeometry, title: str, directory: Path) -> dict[str, str]:
    """Write planform.svg, planform.png and cut_1to1.svg into ``directory``; return their paths."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = {
        "planform_svg": directory / "planform.svg",
        "planform_png": directory / "planform.png",
        "cut_file_svg": directory / "cut_1to1.svg",
    }
    draw_planform(geometry, title, paths["planform_svg"], paths["planform_png"])
    paths["cut_file_svg"].write_text(cut_file_svg(geometry))
    return {name: str(path) for name, path in paths.items()}
