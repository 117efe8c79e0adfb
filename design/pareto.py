"""Trade-off fronts by epsilon-constraint re-solves of one built proposal problem.

Two fronts (SI units inside):

- ``area-damping``: for damping floors eps between the damping of the smallest admissible tail and the
  largest damping reachable, the minimum-area tail with zeta >= eps.
- ``damping-speed``: for airspeed ceilings eps between the V_ss of the smallest admissible tail and
  the V_ss of the best-damped one, the best-damped tail with V_ss <= eps (larger tails damp more but
  fly faster, docs/background.md section 6).

Every point is re-solved from the previous point's optimum and from Sobol starts; the best verified
solution is kept. The user's other targets (e.g. theta_ss) stay constraints at every point.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.design.design_evaluation import DesignEvaluation
from ornitail.design.pareto_plots import write_pareto_picture
from ornitail.design.proposal import (
    DesignTargets,
    ProposalProblem,
    SolveSettings,
    StartOutcome,
    TargetBand,
    best_of_starts,
    sobol_start_points,
)

FRONT_KINDS = ("area-damping", "damping-speed")


@dataclass(frozen=True)
class ParetoPoint:
    """One point of a front: the bound applied (epsilon) and the optimum found there (SI)."""

    epsilon: float
    geometry_vector_m: tuple[float, ...]
    area_m2: float
    damping_ratio: float
    v_ss_m_s: float
    theta_ss_rad: float


def _solve(
    problem: ProposalProblem, settings: SolveSettings, starts: np.ndarray
) -> StartOutcome | None:
    outcome, _, _ = best_of_starts(problem, settings, starts)
    return outcome


def _point(problem: ProposalProblem, epsilon: float, outcome: StartOutcome) -> ParetoPoint:
    vector = tuple(float(v) for v in outcome.geometry_vector_m)
    predictions = problem.trend_model.predict(vector)
    span, leading, root, tip, _ = vector
    area = (leading + span) / 2 * (root - tip) + span * tip
    return ParetoPoint(
        epsilon=float(epsilon),
        geometry_vector_m=vector,
        area_m2=area,
        damping_ratio=outcome.damping_ratio,
        v_ss_m_s=float(predictions["v_ss_m_s"].value),
        theta_ss_rad=float(predictions["theta_ss_rad"].value),
    )


def pareto_front(
    problem: ProposalProblem,
    kind: str,
    targets: DesignTargets,
    x_h_m: float,
    point_count: int = 8,
    start_count: int = 4,
    on_point: Callable[[int, int], None] | None = None,
) -> list[ParetoPoint]:
    """The ``kind`` front at tail position ``x_h_m`` (m) with ``point_count`` epsilon values; ``on_point(done,
    total)`` follows the re-solves (the two ends, then each epsilon) for a progress display."""
    if kind not in FRONT_KINDS:
        raise UserInputError("kind", f"unknown front {kind!r}; choose {', '.join(FRONT_KINDS)}")
    if not 2 <= point_count <= 50:
        raise UserInputError("point_count", f"value {point_count!r} must be between 2 and 50")
    x_h_range = (x_h_m, x_h_m)
    starts = sobol_start_points(problem.bounds, start_count, x_h_range)
    base = SolveSettings(targets, "min-area", x_h_range_m=x_h_range)
    smallest = _solve(problem, base, starts)
    best_damped = _solve(problem, dataclasses.replace(base, objective="max-damping"), starts)
    if smallest is None or best_damped is None:
        raise UserInputError(
            "targets", "no admissible tail meets the other targets; no front to draw"
        )
    total = point_count + 2
    if on_point is not None:
        on_point(2, total)
    low, high = _point(problem, 0, smallest), _point(problem, 0, best_damped)
    points: list[ParetoPoint] = []
    previous = smallest.geometry_vector_m
    if kind == "area-damping":
        epsilons = np.linspace(low.damping_ratio, high.damping_ratio, point_count)
    else:
        epsilons = np.linspace(low.v_ss_m_s, high.v_ss_m_s, point_count)
    for index, epsilon in enumerate(epsilons, start=3):
        if on_point is not None and index > 3:
            on_point(index - 1, total)
        if kind == "area-damping":
            settings = dataclasses.replace(
                base, targets=dataclasses.replace(targets, damping_ratio_min=float(epsilon))
            )
        else:
            band = TargetBand(0.0, float(epsilon))
            settings = dataclasses.replace(
                base, objective="max-damping", targets=dataclasses.replace(targets, v_ss_m_s=band)
            )
        outcome = _solve(problem, settings, np.vstack([previous, starts]))
        if outcome is None:
            continue
        previous = outcome.geometry_vector_m
        points.append(_point(problem, epsilon, outcome))
    if on_point is not None:
        on_point(total, total)
    return points


def write_front(
    points: list[ParetoPoint],
    kind: str,
    directory: Path,
    evaluations: Sequence[DesignEvaluation] | None = None,
) -> dict[str, str]:
    """Write the front as pareto.csv (mm, cm^2, deg columns; the damping ratio's sigmas of the mean trend
    and of a new flight when ``evaluations`` are given) and pareto.png/pdf/svg with its 95 % damping band
    (design/pareto_plots.py); return the paths."""
    directory.mkdir(parents=True, exist_ok=True)
    table = directory / "pareto.csv"
    sigmas = (
        [(e.damping_ratio.sigma_mean, e.damping_ratio.sigma_new) for e in evaluations]
        if evaluations
        else [(math.nan, math.nan)] * len(points)
    )
    with table.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(
            [
                "epsilon",
                "b_mm",
                "b_le_mm",
                "c_r_mm",
                "c_t_mm",
                "x_h_mm",
                "s_cm2",
                "damping_ratio",
                "damping_ratio_sigma_mean",
                "damping_ratio_sigma_new",
                "v_ss_m_s",
                "theta_ss_deg",
            ]
        )
        for p, (sigma_mean, sigma_new) in zip(points, sigmas, strict=True):
            writer.writerow(
                [
                    f"{p.epsilon:.6g}",
                    *(f"{v * 1e3:.2f}" for v in p.geometry_vector_m),
                    f"{p.area_m2 * 1e4:.3f}",
                    f"{p.damping_ratio:.5f}",
                    f"{sigma_mean:.5f}",
                    f"{sigma_new:.5f}",
                    f"{p.v_ss_m_s:.4f}",
                    f"{np.degrees(p.theta_ss_rad):.3f}",
                ]
            )
    paths = {"table_csv": table, **write_pareto_picture(points, kind, directory, evaluations)}
    return {name: str(path) for name, path in paths.items()}
