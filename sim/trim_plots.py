"""Pictures of a linearised trim (PNG and PDF): the poles of A in the complex plane.

Eigenvalues are in 1/s: the real part is minus the decay rate (1/s), the imaginary part the damped
angular frequency (rad/s). Lines of constant damping ratio through the origin help read the
oscillatory pitch mode's zeta off the map.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

POLE_MAP_FILE = "trim_poles"
DAMPING_GRID = (0.1, 0.2, 0.4, 0.7)
"""Damping ratios drawn as faint rays on a pole map."""


def draw_pole_map(
    axis: plt.Axes, eigenvalues: Sequence[complex], label: str = "poles", marker: str = "x"
) -> None:
    """Plot ``eigenvalues`` (1/s) on ``axis`` with the imaginary axis, damping rays and units."""
    values = np.asarray(eigenvalues, dtype=complex)
    reach = max(float(np.max(np.abs(values))) if values.size else 1.0, 1e-3) * 1.15
    for zeta in DAMPING_GRID:
        angle = math.acos(zeta)
        for sign in (1.0, -1.0):
            axis.plot(
                [0.0, -reach * math.cos(angle)],
                [0.0, sign * reach * math.sin(angle)],
                color="0.8",
                linewidth=0.7,
                zorder=0,
            )
        axis.annotate(
            f"zeta {zeta:g}",
            (-reach * math.cos(angle), reach * math.sin(angle)),
            fontsize=6,
            color="0.5",
        )
    axis.axvline(0.0, color="black", linewidth=0.8)
    axis.axhline(0.0, color="black", linewidth=0.5)
    axis.plot(values.real, values.imag, marker, markersize=9, mew=2, linestyle="none", label=label)
    axis.set_xlabel("real part (1/s), negative: decaying")
    axis.set_ylabel("imaginary part, damped frequency (rad/s)")
    axis.grid(True, alpha=0.3)


def pole_map_figure(
    eigenvalues: Sequence[complex],
    damping_ratio: float,
    natural_frequency_rad_s: float,
    title: str,
) -> plt.Figure:
    """The poles of A (1/s) with the oscillatory mode's zeta and omega_n (rad/s) in the title."""
    figure, axis = plt.subplots(figsize=(6, 5))
    draw_pole_map(axis, eigenvalues)
    mode = (
        "no oscillatory mode"
        if not math.isfinite(damping_ratio)
        else f"pitch oscillation zeta {damping_ratio:.3f}, omega_n {natural_frequency_rad_s:.3f} rad/s"
    )
    axis.set_title(f"poles of the linearised model: {title}\n{mode}", fontsize=9)
    axis.legend(fontsize=8, loc="lower left")
    figure.tight_layout()
    return figure


def write_pole_map(
    eigenvalues: Sequence[complex],
    damping_ratio: float,
    natural_frequency_rad_s: float,
    title: str,
    directory: Path,
) -> list[Path]:
    """Write ``trim_poles.png`` and ``trim_poles.pdf`` into ``directory``; return their paths."""
    figure = pole_map_figure(eigenvalues, damping_ratio, natural_frequency_rad_s, title)
    paths = [directory / f"{POLE_MAP_FILE}.png", directory / f"{POLE_MAP_FILE}.pdf"]
    for path in paths:
        figure.savefig(path, dpi=120)
    plt.close(figure)
    return paths
