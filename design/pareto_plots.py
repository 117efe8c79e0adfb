"""Picture of a trade-off front (PNG, PDF and SVG) with the uncertainty band of its damping ratio.

Each point of the front is re-evaluated with numpy (design/design_evaluation.py) for the delta-method
standard deviations of its damping ratio: the dark band is the 95 % interval of the mean trend, the
light band the 95 % interval of one new flight of the built tail. Area in cm^2, speed in m/s,
damping ratio dimensionless.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ornitail.core.normal_quantiles import NORMAL_QUANTILE_95  # noqa: E402
from ornitail.design.design_evaluation import DesignEvaluation, evaluate_design  # noqa: E402
from ornitail.design.proposal import ProposalProblem, geometry_of_vector  # noqa: E402

if TYPE_CHECKING:
    from ornitail.design.pareto import ParetoPoint

PARETO_PICTURE = "pareto"


def front_evaluations(
    problem: ProposalProblem, points: Sequence[ParetoPoint]
) -> list[DesignEvaluation]:
    """Each front point evaluated with numpy: damping ratio and V_ss with their sigmas (SI)."""
    return [
        evaluate_design(
            problem.trend_model,
            geometry_of_vector(np.asarray(point.geometry_vector_m)),
            point.geometry_vector_m[4],
            problem.mass_inertia,
        )
        for point in points
    ]


def _damping_band(evaluations: Sequence[DesignEvaluation], kind: str) -> np.ndarray:
    sigma = [getattr(item.damping_ratio, f"sigma_{kind}") for item in evaluations]
    return NORMAL_QUANTILE_95 * np.nan_to_num(np.asarray(sigma, dtype=float))


def pareto_figure(
    points: Sequence[ParetoPoint],
    kind: str,
    evaluations: Sequence[DesignEvaluation] | None = None,
    x_h_mm: float | None = None,
) -> plt.Figure:
    """The ``kind`` front (``area-damping``: S (cm^2) against zeta; ``damping-speed``: zeta
    against V_ss (m/s)) with the 95 % damping bands of ``evaluations`` when given."""
    figure, axes = plt.subplots(figsize=(6.5, 4.5))
    area_cm2 = np.array([p.area_m2 * 1e4 for p in points])
    damping = np.array([p.damping_ratio for p in points])
    speed = np.array([p.v_ss_m_s for p in points])
    bands = (
        []
        if not evaluations
        else [
            ("new", 0.15, "95 % interval, a new flight"),
            ("mean", 0.3, "95 % interval, mean trend"),
        ]
    )
    if kind == "area-damping":
        for which, alpha, label in bands:
            half = _damping_band(evaluations, which)
            axes.fill_betweenx(
                area_cm2, damping - half, damping + half, color="tab:blue", alpha=alpha, label=label
            )
        axes.plot(damping, area_cm2, "o-", color="tab:blue", label="front")
        axes.set_xlabel("damping ratio of the pitch oscillation, zeta (-)")
        axes.set_ylabel("minimum tail area S (cm^2)")
    else:
        for which, alpha, label in bands:
            half = _damping_band(evaluations, which)
            axes.fill_between(
                speed, damping - half, damping + half, color="tab:blue", alpha=alpha, label=label
            )
        axes.plot(speed, damping, "o-", color="tab:blue", label="front")
        axes.set_xlabel("steady airspeed V_ss (m/s)")
        axes.set_ylabel("maximum damping ratio, zeta (-)")
    axes.grid(True, alpha=0.3)
    axes.legend(fontsize=8, loc="best")
    where = "" if x_h_mm is None else f" at x_h {x_h_mm:g} mm"
    axes.set_title(f"trade-off front ({kind}){where}", fontsize=10)
    figure.tight_layout()
    return figure


def write_pareto_picture(
    points: Sequence[ParetoPoint],
    kind: str,
    directory: Path,
    evaluations: Sequence[DesignEvaluation] | None = None,
) -> dict[str, Path]:
    """Write ``pareto.png``, ``pareto.pdf`` and ``pareto.svg``; return them by name."""
    x_h_mm = points[0].geometry_vector_m[4] * 1e3 if points else None
    figure = pareto_figure(points, kind, evaluations, x_h_mm)
    paths = {
        "plot_png": directory / f"{PARETO_PICTURE}.png",
        "plot_pdf": directory / f"{PARETO_PICTURE}.pdf",
        "plot_svg": directory / f"{PARETO_PICTURE}.svg",
    }
    for path in paths.values():
        figure.savefig(path, dpi=120)
    plt.close(figure)
    return paths
