"""Pictures of trend fits: each quantity against S and against AR, with the fit and its bands (PNG and PDF)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ornitail.design.trend_basis import PlanformFeatures  # noqa: E402
from ornitail.design.trend_data import TrendObservation  # noqa: E402
from ornitail.design.trends import QuantityTrend  # noqa: E402


def _trend_line(trend: QuantityTrend, area_m2: np.ndarray, aspect_ratio: np.ndarray, x_h_m: float):
    values, sigma_mean, sigma_new = [], [], []
    for area, ratio in zip(area_m2, aspect_ratio, strict=True):
        planform = PlanformFeatures(area, ratio, math.sqrt(area * ratio), x_h_m)
        prediction = trend.predict_features(np.asarray(trend.basis.make_features(planform), float))
        values.append(prediction.value)
        sigma_mean.append(prediction.sigma_mean)
        sigma_new.append(prediction.sigma_new)
    return np.array(values), np.array(sigma_mean), np.array(sigma_new)


def write_trend_picture(
    trend: QuantityTrend, observations: Sequence[TrendObservation], directory: Path
) -> list[Path]:
    """Write ``trend_<quantity>.png/.pdf``: the quantity against S (AR at the data mean) and against AR
    (S at the data mean), x_h at each observed position; +-1 sigma bands of the mean trend (dark) and of a
    new flight (light). Returns the written paths."""
    chosen = [item for item in observations if item.quantity == trend.quantity]
    areas = np.array([item.geometry.area_m2 for item in chosen])
    ratios = np.array([item.geometry.aspect_ratio for item in chosen])
    values = np.array([item.value for item in chosen])
    errors = np.array([np.nan if item.sigma is None else item.sigma for item in chosen])
    positions = sorted({round(item.x_h_m, 6) for item in chosen})
    figure, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for axis, along_area in zip(axes, (True, False), strict=True):
        data_x = areas * 1e4 if along_area else ratios
        for colour, x_h in zip(colours, positions, strict=False):
            here = np.isclose([item.x_h_m for item in chosen], x_h)
            axis.errorbar(
                data_x[here],
                values[here],
                yerr=np.nan_to_num(errors[here]),
                fmt="o",
                color=colour,
                label=f"data x_h = {x_h * 1e3:g} mm",
            )
            grid = np.linspace(data_x.min(), data_x.max(), 50)
            area_grid = grid / 1e4 if along_area else np.full_like(grid, areas.mean())
            ratio_grid = np.full_like(grid, ratios.mean()) if along_area else grid
            line, sigma_mean, sigma_new = _trend_line(trend, area_grid, ratio_grid, x_h)
            axis.plot(grid, line, color=colour)
            axis.fill_between(grid, line - sigma_new, line + sigma_new, color=colour, alpha=0.12)
            axis.fill_between(grid, line - sigma_mean, line + sigma_mean, color=colour, alpha=0.3)
        axis.set_xlabel("S (cm^2), AR at data mean" if along_area else "AR, S at data mean")
        axis.grid(alpha=0.3)
    axes[0].set_ylabel(f"{trend.quantity} (SI)")
    axes[0].legend(fontsize=7)
    figure.suptitle(
        f"{trend.quantity}: basis {trend.basis.name}, {trend.weighting.upper()}, LOO RMSE "
        f"{trend.loo_rmse:.3g}; bands: +-1 sigma mean trend (dark), new flight (light)",
        fontsize=9,
    )
    figure.tight_layout()
    written = []
    for suffix in ("png", "pdf"):
        path = directory / f"trend_{trend.quantity}.{suffix}"
        figure.savefig(path, dpi=120)
        written.append(path)
    plt.close(figure)
    return written
