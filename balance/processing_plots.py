"""Report figures of a processed tunnel sweep (matplotlib, Agg backend; saved as PNG and PDF).

- the phase-averaged loads over the flap cycle at the steady state, tailed and tailless, with +-2 sigma bands;
- the cycle-averaged loads against each sweep variable with the fitted model and the local derivative;
- tailed against tailless at the steady state, with the tail contribution and the balance resolution.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from ornitail.balance.derivatives import StabilityDerivatives  # noqa: E402
from ornitail.balance.phase_loads import PhaseAveragedLoads  # noqa: E402
from ornitail.balance.sweep_table import BALANCE_RESOLUTION_N  # noqa: E402

PLOTTED_LOADS = (
    ("x_n", "X", "N", "force along $x_b$"),
    ("z_n", "Z", "N", "force along $z_b$"),
    ("m_n_m", "M", "N m", "pitching moment (+ nose-down)"),
)
_SWEEPS = (
    ("theta", "theta_deg", r"pitch $\theta$ [deg]"),
    ("velocity", "v_m_s", "tunnel velocity $V$ [m/s]"),
    ("frequency", "f_set_hz", "flapping frequency $f$ [Hz]"),
)
_TAILED_COLOUR, _TAILLESS_COLOUR = "tab:blue", "tab:orange"


def save_figure(figure: Figure, path_without_suffix: Path) -> list[Path]:
    """Write ``<path>.png`` (150 dpi) and ``<path>.pdf``; close the figure; return both paths.

    Every figure here lays itself out (``tight_layout``, with room kept for its legend), so it is saved at its own
    size: a tight bounding box would draw each file twice (processing a short sweep took 1.16x as long with it,
    ``benchmarks/processing_figures.py``)."""
    paths = [path_without_suffix.with_suffix(".png"), path_without_suffix.with_suffix(".pdf")]
    for path in paths:
        figure.savefig(path, dpi=150)
    plt.close(figure)
    return paths


def phase_average_figure(
    tailed: PhaseAveragedLoads, tailless: PhaseAveragedLoads | None, configuration: str, where: str
) -> Figure:
    """X, Z and M over the flap cycle: mean and +-2 sigma over cycles, tailed and tailless overlaid."""
    figure, axes = plt.subplots(3, 1, figsize=(7.5, 8.5), sharex=True)
    states = [("tailed", tailed, _TAILED_COLOUR), ("tailless", tailless, _TAILLESS_COLOUR)]
    for axis, (name, symbol, unit, meaning) in zip(axes, PLOTTED_LOADS, strict=True):
        for label, loads, colour in states:
            if loads is None:
                continue
            mean, spread = loads.load(name)
            axis.plot(
                loads.phase,
                mean,
                color=colour,
                label=f"{label} (mean of {loads.cycle_count} cycles, {loads.flapping_frequency_hz:.2f} Hz)",
            )
            axis.axhline(
                mean.mean(), color=colour, linestyle=":", linewidth=1.0, label=f"{label} cycle mean"
            )
            axis.fill_between(
                loads.phase,
                mean - 2 * spread,
                mean + 2 * spread,
                color=colour,
                alpha=0.25,
                label=f"{label} $\\pm 2\\sigma$ over cycles",
            )
        axis.set_ylabel(f"{symbol} [{unit}]")
        axis.set_title(f"{symbol}: {meaning}", fontsize=10, loc="left")
        axis.grid(True, alpha=0.3)
    figure.legend(
        *axes[0].get_legend_handles_labels(), loc="lower center", ncol=2, fontsize=8, frameon=False
    )
    axes[-1].set_xlabel("flap phase [cycle fraction, 0 = Hall edge]")
    axes[-1].set_xlim(0.0, 1.0)
    figure.suptitle(
        f"{configuration}: phase-averaged loads over the flap cycle\n{where}\n"
        "body frame, about the rig's reference point; bands +-2 sigma over cycles",
        fontsize=11,
    )
    figure.tight_layout(rect=(0.0, 0.07, 1.0, 1.0))
    return figure


def sweep_fit_figure(table: pd.DataFrame, fit: StabilityDerivatives) -> Figure:
    """Cycle-averaged X, Z, M against pitch, velocity and frequency: points (2 sigma bars) and the fit."""
    steady = fit.steady_state
    steady_values = {
        "theta_deg": np.degrees(steady.theta_rad),
        "v_m_s": steady.v_m_s,
        "f_set_hz": steady.f_hz,
    }
    sweeps = [sweep for sweep in _SWEEPS if (table["sweep"] == sweep[0]).any()]
    figure, axes = plt.subplots(
        3, max(len(sweeps), 1), figsize=(4.2 * max(len(sweeps), 1), 9.0), squeeze=False
    )
    for column, (sweep, variable, label) in enumerate(sweeps):
        for row, (name, symbol, unit, _) in enumerate(PLOTTED_LOADS):
            axis = axes[row, column]
            for tailed, colour, marker, legend in (
                (True, _TAILED_COLOUR, "o", "tailed"),
                (False, _TAILLESS_COLOUR, "s", "tailless"),
            ):
                points = table[
                    (table["tailed"] == tailed) & table["sweep"].isin([sweep, "steady_state"])
                ]
                if points.empty:
                    continue
                axis.errorbar(
                    points[variable],
                    points[name],
                    yerr=points[f"{name}_2sigma"],
                    fmt=marker,
                    color=colour,
                    markersize=4,
                    capsize=3,
                    label=f"{legend} ($\\pm 2\\sigma$ over cycles)",
                )
            span = table.loc[table["sweep"] == sweep, variable]
            grid = np.linspace(span.min(), span.max(), 60)
            arguments = dict(steady_values)
            arguments[variable] = grid
            fitted = fit.predict(arguments["theta_deg"], arguments["v_m_s"], arguments["f_set_hz"])
            tangent = fit.predict(
                arguments["theta_deg"],
                arguments["v_m_s"],
                arguments["f_set_hz"],
                linear_only=True,
            )
            axis.plot(grid, fitted[symbol], color="k", linewidth=1.2, label="fitted model")
            axis.plot(
                grid,
                tangent[symbol],
                color="k",
                linestyle="--",
                linewidth=0.9,
                label="local derivative at steady state",
            )
            axis.set_xlabel(label)
            axis.set_ylabel(f"{symbol} [{unit}]")
            axis.grid(True, alpha=0.3)
    figure.suptitle(
        f"{fit.configuration}: cycle-averaged loads against set point, with the fit\n"
        "body frame, about the rig's reference point; other variables at the steady state",
        fontsize=11,
    )
    figure.tight_layout(rect=(0.0, 0.05, 1.0, 1.0))
    if sweeps:
        handles, labels = axes[0, 0].get_legend_handles_labels()
        figure.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    return figure


def tail_comparison_figure(
    table: pd.DataFrame, contribution: pd.DataFrame, configuration: str
) -> Figure:
    """Tailed against tailless at the first point measured both ways (top), the tail's share (bottom)."""
    row = contribution.iloc[0]
    at_point = table[
        np.isclose(table["theta_deg"], row["theta_deg"])
        & np.isclose(table["v_m_s"], row["v_m_s"])
        & np.isclose(table["f_set_hz"], row["f_set_hz"])
    ]
    figure, axes = plt.subplots(2, 3, figsize=(11.0, 7.0))
    for column, (name, symbol, unit, meaning) in enumerate(PLOTTED_LOADS):
        totals = axes[0, column]
        for position, (tailed, colour) in enumerate(
            ((True, _TAILED_COLOUR), (False, _TAILLESS_COLOUR))
        ):
            group = at_point[at_point["tailed"] == tailed]
            totals.errorbar(
                position + 0.08 * (np.arange(len(group)) - (len(group) - 1) / 2),
                group[name],
                yerr=group[f"{name}_2sigma"],
                fmt="o",
                color=colour,
                capsize=3,
                markersize=5,
            )
        totals.set_xticks([0, 1], ["tailed", "tailless"])
        totals.set_xlim(-0.6, 1.6)
        totals.set_ylabel(f"{symbol} [{unit}]")
        totals.set_title(f"{symbol}: {meaning}", fontsize=9)
        totals.grid(True, axis="y", alpha=0.3)
        share = axes[1, column]
        share.errorbar(
            [0], [row[name]], yerr=[2 * row[f"{name}_sigma"]], fmt="D", color="tab:green", capsize=5
        )
        if name.endswith("_n"):
            share.axhspan(
                -BALANCE_RESOLUTION_N,
                BALANCE_RESOLUTION_N,
                color="grey",
                alpha=0.25,
                label="+- balance resolution (0.149 gf)",
            )
            share.legend(fontsize=7, loc="lower right")
        share.axhline(0.0, color="k", linewidth=0.6)
        share.set_xticks([0], ["tailed - tailless"])
        share.set_xlim(-1, 1)
        limit = 1.3 * max(
            abs(row[name]) + 2 * row[f"{name}_sigma"],
            BALANCE_RESOLUTION_N if name.endswith("_n") else 0.0,
        )
        share.set_ylim(-limit, limit)
        verdict = "resolvable" if bool(row[f"{name}_resolvable"]) else "NOT resolvable"
        share.set_title(f"tail: {row[name]:+.5f} {unit} ({verdict})", fontsize=9)
        share.set_ylabel(f"tail contribution {symbol} [{unit}]")
        share.grid(True, axis="y", alpha=0.3)
    figure.suptitle(
        f"{configuration}: tailed against tailless at theta {row['theta_deg']:.1f} deg, "
        f"V {row['v_m_s']:.2f} m/s, f {row['f_set_hz']:.2f} Hz\n"
        "top: each repeat, +-2 sigma over cycles; bottom: difference of the repeat means, +-2 sigma of the mean",
        fontsize=10,
    )
    figure.tight_layout()
    return figure
