"""Pictures of a diagnosis (PNG and PDF): residual spectra before/after, where, the ranking.

Made from the report and the residual arrays the diagnosis returns, never from model internals.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ornitail.gap.spectra import fft_length, residual_power  # noqa: E402


def _save(figure: plt.Figure, folder: Path, name: str) -> list[str]:
    paths = []
    for suffix in ("png", "pdf"):
        path = folder / f"{name}.{suffix}"
        figure.savefig(path, dpi=120)
        paths.append(str(path))
    plt.close(figure)
    return paths


def residual_spectra_picture(
    before: Sequence[np.ndarray],
    after: Sequence[np.ndarray],
    time_step_s: float,
    channels: Sequence[str],
    effect: str,
    folder: Path,
) -> list[str]:
    """Residual power per channel on the test runs, baseline and with ``effect``."""
    length = fft_length(before)
    frequencies, power_before = residual_power(before, time_step_s, length)
    _, power_after = residual_power(after, time_step_s, length)
    figure, axes = plt.subplots(1, len(channels), figsize=(3.2 * len(channels), 3.2))
    for index, (axis, channel) in enumerate(zip(np.atleast_1d(axes), channels, strict=True)):
        keep = frequencies > 0
        axis.semilogy(frequencies[keep], power_before[keep, index], label="baseline")
        axis.semilogy(frequencies[keep], power_after[keep, index], label=f"+ {effect}")
        axis.set_xlim(0, min(8.0, frequencies[-1]))
        axis.set_xlabel("frequency (Hz)")
        axis.set_title(channel)
    np.atleast_1d(axes)[0].set_ylabel("residual power (normalised)")
    np.atleast_1d(axes)[0].legend(fontsize=7)
    figure.tight_layout()
    return _save(figure, folder, "residual_spectra")


def localisation_figure(where: dict[str, Any]) -> plt.Figure:
    """Bars: residual energy share by channel; by frequency band (flight) or the strongest
    |correlation| with each configuration variable (tunnel); share by time segment or sweep.
    Shares and correlations are fractions (-)."""
    figure, axes = plt.subplots(1, 3, figsize=(11, 3.8))
    channels = where["by_channel"]
    axes[0].bar(list(channels), [item["energy_share"] for item in channels.values()])
    axes[0].set_title("share by channel")
    axes[0].set_xlabel("channel")
    axes[0].set_ylabel("share of residual energy (-)")
    if where["by_band"]:
        bands = where["by_band"]
        labels = [f"{b['band_hz'][0]:g}-{b['band_hz'][1]:.3g}" for b in bands]
        axes[1].bar(labels, [b["pooled_share"] for b in bands])
        axes[1].set_title("share by band (Hz)")
        axes[1].set_xlabel("frequency band (Hz)")
        axes[1].set_ylabel("pooled share of residual energy (-)")
    else:
        variables = {
            name: max(abs(v["correlation"]) for v in item["per_load"].values())
            for name, item in where["by_configuration"].items()
            if item["varies"]
        }
        axes[1].bar(list(variables), list(variables.values()))
        axes[1].set_title("|correlation| with configuration")
        axes[1].set_xlabel("configuration variable")
        axes[1].set_ylabel("largest |correlation| with a load (-)")
    axes[1].tick_params(axis="x", labelsize=7)
    segments = where["by_segment"]
    axes[2].bar(
        [name.replace("_", "\n") for name in segments],
        [item["energy_share"] for item in segments.values()],
    )
    axes[2].set_title("share by segment")
    axes[2].set_xlabel("time segment or sweep")
    axes[2].set_ylabel("share of residual energy (-)")
    figure.suptitle("where the baseline's residual lies", fontsize=10)
    figure.tight_layout()
    return figure


def localisation_picture(where: dict[str, Any], folder: Path) -> list[str]:
    """Write ``localisation.png/.pdf`` (:func:`localisation_figure`); return the paths."""
    return _save(localisation_figure(where), folder, "localisation")


def ranking_figure(report: dict[str, Any]) -> plt.Figure:
    """Validation closure (-) of each candidate with its 90 % interval and its simultaneous lower
    bound (black tick); the top set highlighted; the detection rule's two lines: the closure must
    pass the dashed one, the simultaneous lower bound the dotted one."""
    ranking = report["ranking"]
    figure, axis = plt.subplots(figsize=(7, 0.45 * len(ranking) + 1.2))
    positions = np.arange(len(ranking))[::-1]
    values = [entry["validation_closure"] for entry in ranking]
    errors = np.array(
        [
            [v - e["closure_interval"][0], e["closure_interval"][1] - v]
            for v, e in zip(values, ranking, strict=True)
        ]
    ).T
    colours = ["tab:red" if entry["in_top_set"] else "tab:gray" for entry in ranking]
    axis.barh(positions, values, xerr=errors, color=colours)
    axis.scatter(
        [entry["simultaneous_lower_bound"] for entry in ranking],
        positions,
        marker="|",
        s=160,
        color="black",
        zorder=3,
        label="lower bound, simultaneous over the contenders",
    )
    axis.set_yticks(positions, [entry["name"] for entry in ranking])
    axis.axvline(0.0, color="black", linewidth=0.8)
    rule = report["detection_rule"]
    for key, style, label in (
        ("threshold", "--", "closure must exceed (null's 95th percentile)"),
        (
            "lower_bound_threshold",
            ":",
            "lower bound must exceed (null median or materiality floor)",
        ),
    ):
        axis.axvline(rule[key], color="tab:blue", linestyle=style, linewidth=0.9, label=label)
    axis.legend(fontsize=7)
    axis.set_xlabel("closure of the gap on validation runs, 1 - gap after / gap before (-)")
    axis.set_ylabel("candidate effect")
    axis.set_title("candidate effects ranked (red: top set; bars: 90 % interval)", fontsize=10)
    figure.tight_layout()
    return figure


def ranking_picture(report: dict[str, Any], folder: Path) -> list[str]:
    """Write ``ranking.png/.pdf`` (:func:`ranking_figure`); return the paths."""
    return _save(ranking_figure(report), folder, "ranking")


def tunnel_residual_picture(
    points: Any, before: np.ndarray, after: np.ndarray, effect: str, folder: Path
) -> list[str]:
    """Tunnel residual of each load against pitch, before (dots) and after ``effect`` (crosses),
    coloured by tail position x_h."""
    figure, axes = plt.subplots(1, 3, figsize=(11, 3.4))
    theta_deg = np.degrees(points["theta_rad"].to_numpy())
    colour = points["x_h_mm"].to_numpy()
    for index, (axis, label) in enumerate(zip(axes, ("X (N)", "Z (N)", "M (N m)"), strict=True)):
        dots = axis.scatter(theta_deg, before[:, index], c=colour, s=12, label="baseline")
        axis.scatter(theta_deg, after[:, index], c=colour, s=18, marker="x", label=f"+ {effect}")
        axis.axhline(0.0, color="black", linewidth=0.6)
        axis.set_xlabel("pitch theta (deg)")
        axis.set_ylabel(f"residual {label}")
        axis.set_title(f"residual {label}")
    axes[0].legend(fontsize=7)
    figure.colorbar(dots, ax=axes[-1], label="x_h (mm)")
    figure.tight_layout()
    return _save(figure, folder, "residuals_by_point")


def steady_residual_picture(
    labels: Sequence[str],
    channels: Sequence[str],
    before: np.ndarray,
    after: np.ndarray,
    effect: str,
    folder: Path,
) -> list[str]:
    """Steady-state residual per configuration in units of its standard error, baseline (dots)
    and with ``effect`` (crosses; withheld predictions), one panel per channel."""
    figure, axes = plt.subplots(
        len(channels), 1, figsize=(max(6.0, 0.35 * len(labels) + 2), 2.2 * len(channels))
    )
    positions = np.arange(len(labels))
    for index, (axis, channel) in enumerate(zip(np.atleast_1d(axes), channels, strict=True)):
        axis.plot(positions, before[:, index], "o", markersize=4, label="baseline")
        axis.plot(positions, after[:, index], "x", markersize=6, label=f"+ {effect}")
        axis.axhline(0.0, color="black", linewidth=0.6)
        axis.set_ylabel(f"{channel} / sigma")
        axis.set_xticks(positions, labels if index == len(channels) - 1 else [], rotation=60)
    np.atleast_1d(axes)[0].legend(fontsize=7)
    np.atleast_1d(axes)[-1].tick_params(axis="x", labelsize=7)
    np.atleast_1d(axes)[-1].set_xlabel("configuration")
    figure.tight_layout()
    return _save(figure, folder, "residuals_by_configuration")


FLIGHT_OVERLAY_CHANNELS = {
    "q": ("pitch rate q (deg/s)", 180.0 / np.pi),
    "u": ("body velocity u (m/s)", 1.0),
    "w": ("body velocity w (m/s)", 1.0),
    "theta": ("pitch attitude theta (deg)", 180.0 / np.pi),
}
"""The simulator's channels: axis label and the factor from SI (rad/s, m/s, rad) to its unit."""


def _overlay_axis(channel: str, simulator_units: bool) -> tuple[str, float]:
    if simulator_units and channel in FLIGHT_OVERLAY_CHANNELS:
        return FLIGHT_OVERLAY_CHANNELS[channel]
    return f"{channel} (model unit)", 1.0


def flight_overlay_figure(
    time_s: np.ndarray,
    measured: np.ndarray,
    baseline: np.ndarray,
    corrected: np.ndarray,
    label: str,
    effect: str,
    channels: Sequence[str] = tuple(FLIGHT_OVERLAY_CHANNELS),
) -> plt.Figure:
    """One run over time (s): measured outputs, the baseline's prediction and the prediction with
    ``effect`` (corrected), one panel per output in ``channels``; the arrays are (N, outputs) in
    the model's units (the simulator's four states in SI, shown in deg/s, m/s and deg), deviations
    from the run-in for a manoeuvre."""
    simulator_units = tuple(channels) == tuple(FLIGHT_OVERLAY_CHANNELS)
    figure, axes = plt.subplots(
        len(channels), 1, figsize=(8, 2 * len(channels)), sharex=True, squeeze=False
    )
    for index, (axis, channel) in enumerate(zip(axes[:, 0], channels, strict=True)):
        name, factor = _overlay_axis(channel, simulator_units)
        axis.plot(time_s, measured[:, index] * factor, color="0.3", linewidth=1.2, label="data")
        axis.plot(time_s, baseline[:, index] * factor, color="tab:blue", label="baseline")
        axis.plot(
            time_s,
            corrected[:, index] * factor,
            color="tab:red",
            linestyle="--",
            label=f"corrected (+ {effect})",
        )
        axis.set_ylabel(name, fontsize=8)
        axis.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel("time from the run's start (s)")
    figure.suptitle(f"run {label}: data, baseline and corrected model", fontsize=10)
    figure.tight_layout()
    return figure


def flight_overlay_picture(
    time_s: np.ndarray,
    measured: np.ndarray,
    baseline: np.ndarray,
    corrected: np.ndarray,
    label: str,
    effect: str,
    folder: Path,
    channels: Sequence[str] = tuple(FLIGHT_OVERLAY_CHANNELS),
) -> list[str]:
    """Write ``flight_overlay.png/.pdf`` (:func:`flight_overlay_figure`); return the paths."""
    figure = flight_overlay_figure(time_s, measured, baseline, corrected, label, effect, channels)
    return _save(figure, folder, "flight_overlay")


def derivative_refit_figure(refit: dict[str, Any]) -> plt.Figure:
    """Each re-fitted derivative's change relative to its baseline value (-) with its 90 % interval;
    moved ones (interval excluding zero) in red; a derivative whose baseline is 0 has no relative
    scale and is listed with its change in its own unit instead of drawn."""
    items = list(refit["derivatives"].items())
    figure, axis = plt.subplots(figsize=(8, 0.4 * len(items) + 1.6))
    positions = np.arange(len(items))[::-1]
    labels = []
    for position, (name, item) in zip(positions, items, strict=True):
        scale = abs(item["baseline"])
        if scale == 0:
            labels.append(f"{name} (baseline 0: {item['change']:+.3g} {item['unit']})")
            continue
        labels.append(name)
        low, high = (bound / scale for bound in item["change_interval"])
        centre = item["change"] / scale
        axis.errorbar(
            centre,
            position,
            xerr=[[centre - low], [high - centre]],
            fmt="o",
            color="tab:red" if item["moved"] else "tab:gray",
            capsize=3,
        )
    axis.set_yticks(positions, labels, fontsize=8)
    axis.axvline(0.0, color="black", linewidth=0.8)
    # linear within +-100 % of the baseline value, logarithmic beyond: a poorly determined derivative
    # (intervals of +-1000 %) must not flatten the ones the runs pin down
    axis.set_xscale("symlog", linthresh=1.0)
    axis.set_xlabel("change / |baseline value| (-), 90 % interval; linear within +-1, log beyond")
    axis.set_ylabel("derivative of the baseline model")
    low, high = refit["closure_interval"]
    support = "supported by" if refit["supported_by_test_runs"] else "NOT supported by"
    axis.set_title(
        f"derivative re-fit (red: moved)\ntest closure {refit['closure_test']:.2f} "
        f"[{low:.2f}, {high:.2f}], {support} the test runs",
        fontsize=9,
    )
    figure.tight_layout()
    return figure


def derivative_refit_picture(refit: dict[str, Any], folder: Path) -> list[str]:
    """Write ``derivative_refit.png/.pdf`` (:func:`derivative_refit_figure`); return the paths."""
    return _save(derivative_refit_figure(refit), folder, "derivative_refit")
