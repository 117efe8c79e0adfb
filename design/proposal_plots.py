"""Pictures of a proposed tail (PNG and PDF), beside its planform drawings.

- ``proposal_poles``: the poles of the predicted A matrix (1/s) in the complex plane, the oscillatory
  pitch mode's damping ratio with its 95 % intervals in the title;
- ``proposal_response``: the free response of the predicted linear model to an initial pitch
  disturbance (no control input): pitch attitude (deg), pitch rate (deg/s), u and w (m/s) over time (s);
- ``proposal_in_data``: where the design sits among the fitted data: its S (cm^2) against AR and
  against x_h (mm), over the configurations the trends were fitted on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.linalg import expm  # noqa: E402

from ornitail.design.design_evaluation import DesignEvaluation  # noqa: E402
from ornitail.design.linear_model import A_MATRIX_DERIVATIVES, STATE_NAMES  # noqa: E402
from ornitail.design.trend_data import TrendObservation  # noqa: E402
from ornitail.sim.trim_plots import draw_pole_map  # noqa: E402

INITIAL_PITCH_DEG = 5.0
"""Initial pitch-attitude disturbance of the response picture, deg."""
RESPONSE_SAMPLES = 400
RESPONSE_SPAN_S = (2.0, 20.0)
"""Shortest and longest time span of the response picture, s."""


def _save(figure: plt.Figure, directory: Path, name: str) -> list[Path]:
    paths = [directory / f"{name}.png", directory / f"{name}.pdf"]
    for path in paths:
        figure.savefig(path, dpi=120)
    plt.close(figure)
    return paths


def poles_figure(evaluation: DesignEvaluation) -> plt.Figure:
    """Poles of the design's A (1/s), the pitch oscillation's zeta and 95 % intervals in the title."""
    figure, axis = plt.subplots(figsize=(6, 5))
    draw_pole_map(axis, evaluation.modes.eigenvalues, label="poles of the proposed tail")
    oscillatory = evaluation.modes.oscillatory_eigenvalue
    if oscillatory is not None:
        axis.plot(
            [oscillatory.real, oscillatory.real],
            [oscillatory.imag, -oscillatory.imag],
            "o",
            markersize=14,
            markerfacecolor="none",
            color="tab:red",
            label="oscillatory pitch mode",
        )
        zeta = evaluation.damping_ratio
        low, high = zeta.interval_95("new")
        mode = (
            f"pitch mode zeta {zeta.value:.3f} (95 % new flight {low:.3f}..{high:.3f}), "
            f"omega_n {evaluation.natural_frequency_rad_s.value:.3f} rad/s"
        )
    else:
        mode = "no oscillatory pitch mode"
    axis.legend(fontsize=8, loc="lower left")
    axis.set_title(
        f"poles of the proposed tail (S {evaluation.area_m2 * 1e4:.1f} cm^2, AR "
        f"{evaluation.aspect_ratio:.2f}, x_h {evaluation.x_h_m * 1e3:.0f} mm)\n{mode}",
        fontsize=9,
    )
    figure.tight_layout()
    return figure


def _response_span_s(evaluation: DesignEvaluation) -> float:
    oscillatory = evaluation.modes.oscillatory_eigenvalue
    if oscillatory is None or oscillatory.real >= 0:
        return 10.0
    return float(np.clip(6.0 / -oscillatory.real, *RESPONSE_SPAN_S))


def pitch_response(
    evaluation: DesignEvaluation, initial_pitch_rad: float, span_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Free response x(t) = expm(A t) x0 of states [q, u, w, theta] (rad/s, m/s, m/s, rad) to an
    initial pitch attitude ``initial_pitch_rad``; returns time (s) and states (samples, 4)."""
    time_s = np.linspace(0.0, span_s, RESPONSE_SAMPLES)
    initial = np.zeros(len(STATE_NAMES))
    initial[STATE_NAMES.index("theta")] = initial_pitch_rad
    step = expm(evaluation.a_matrix * (time_s[1] - time_s[0]))
    states = np.empty((len(time_s), len(initial)))
    states[0] = initial
    for index in range(1, len(time_s)):
        states[index] = step @ states[index - 1]
    return time_s, states


def response_figure(evaluation: DesignEvaluation) -> plt.Figure:
    """Free response of the design's linear model to a pitch disturbance of
    :data:`INITIAL_PITCH_DEG` (deg), no control input."""
    time_s, states = pitch_response(
        evaluation, math.radians(INITIAL_PITCH_DEG), _response_span_s(evaluation)
    )
    panels = (
        ("theta", "pitch attitude theta (deg)", math.degrees(1.0)),
        ("q", "pitch rate q (deg/s)", math.degrees(1.0)),
        ("u", "body velocity u (m/s)", 1.0),
        ("w", "body velocity w (m/s)", 1.0),
    )
    figure, axes = plt.subplots(len(panels), 1, figsize=(7, 7.5), sharex=True)
    for axis, (state, label, factor) in zip(axes, panels, strict=True):
        axis.plot(time_s, states[:, STATE_NAMES.index(state)] * factor, color="tab:blue")
        axis.axhline(0.0, color="black", linewidth=0.6)
        axis.set_ylabel(label, fontsize=8)
        axis.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time after the disturbance (s)")
    figure.suptitle(
        f"proposed tail: free response to an initial pitch disturbance of {INITIAL_PITCH_DEG:g} deg\n"
        "(deviations from the steady state, no control input)",
        fontsize=9,
    )
    figure.tight_layout()
    return figure


def _fitted_configurations(
    observations: Sequence[TrendObservation],
) -> list[tuple[str, float, float, float, bool]]:
    """Each fitted configuration once: (name, S cm^2, AR, x_h mm, whether it has observations of
    an A-matrix derivative)."""
    seen: dict[tuple[str, float], list] = {}
    for item in observations:
        key = (item.configuration, round(item.x_h_m, 6))
        entry = seen.setdefault(
            key,
            [
                item.configuration,
                item.geometry.area_m2 * 1e4,
                item.geometry.aspect_ratio,
                item.x_h_m * 1e3,
                False,
            ],
        )
        entry[4] = entry[4] or item.quantity in A_MATRIX_DERIVATIVES
    return [tuple(entry) for entry in seen.values()]


def in_data_figure(
    evaluation: DesignEvaluation, observations: Sequence[TrendObservation]
) -> plt.Figure:
    """The design's S (cm^2), AR and x_h (mm) over the configurations the trends were fitted on;
    filled markers: configurations with derivative observations (Mq..Zw), open: steady state only."""
    fitted = _fitted_configurations(observations)
    names = [item[0] for item in fitted]
    area = np.array([item[1] for item in fitted])
    ratio = np.array([item[2] for item in fitted])
    position = np.array([item[3] for item in fitted])
    derivative = np.array([item[4] for item in fitted], dtype=bool)
    design = (evaluation.area_m2 * 1e4, evaluation.aspect_ratio, evaluation.x_h_m * 1e3)
    figure, (ratio_axis, position_axis) = plt.subplots(1, 2, figsize=(10, 4.4))
    for axis, data_y, design_y, label in (
        (ratio_axis, ratio, design[1], "aspect ratio AR (-)"),
        (position_axis, position, design[2], "tail position x_h (mm)"),
    ):
        for chosen, face, text in (
            (derivative, "0.35", "fitted: steady state and derivatives"),
            (~derivative, "none", "fitted: steady state only"),
        ):
            if chosen.any():
                axis.plot(
                    area[chosen],
                    data_y[chosen],
                    "o",
                    color="0.35",
                    markerfacecolor=face,
                    label=f"{text} ({int(chosen.sum())})",
                )
        for name, x, y in zip(names, area, data_y, strict=True):
            axis.annotate(
                name, (x, y), fontsize=6, color="0.4", xytext=(3, 3), textcoords="offset points"
            )
        axis.plot(design[0], design_y, "*", markersize=16, color="tab:red", label="proposed tail")
        axis.set_xlabel("tail area S (cm^2)")
        axis.set_ylabel(label)
        axis.grid(True, alpha=0.3)
    figure.legend(
        *ratio_axis.get_legend_handles_labels(),
        loc="lower center",
        ncol=3,
        fontsize=8,
        frameon=False,
    )
    figure.suptitle(
        "where the proposed tail sits among the configurations the trends were fitted on\n"
        f"(largest extrapolation, Mahalanobis: {evaluation.max_extrapolation:.3g})",
        fontsize=9,
    )
    figure.tight_layout(rect=(0.0, 0.07, 1.0, 1.0))
    return figure


def write_proposal_pictures(
    evaluation: DesignEvaluation, observations: Sequence[TrendObservation], directory: Path
) -> dict[str, str]:
    """Write proposal_poles, proposal_response and proposal_in_data (PNG and PDF) into
    ``directory``; return their paths by name (``poles_png``, ``poles_pdf``, ...)."""
    written: dict[str, str] = {}
    for name, figure in (
        ("poles", poles_figure(evaluation)),
        ("response", response_figure(evaluation)),
        ("in_data", in_data_figure(evaluation, observations)),
    ):
        png, pdf = _save(figure, directory, f"proposal_{name}")
        written[f"{name}_png"] = str(png)
        written[f"{name}_pdf"] = str(pdf)
    return written
