"""One picture of the three realities' scores (benchmarks/gap_realities.py) against issue 15's targets.

A panel per rate the issue's "Done when" names, a point per part (simulator, flapper B, semi-real) with its 95 %
Wilson interval and its count, and the target as a dashed line: whether a target is met, missed, or not told apart
by these cases (the interval holds it) is seen at once. A part without cases of a kind (the semi-real part has
no effect outside the library and no fresh flight) says so in the panel. A last panel gives the named effects'
magnitude errors (median and largest, %) against the semi-real target of 20 %.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend is chosen first: the benchmarks run headless)

PARTS = {"sim": "simulator", "independent": "flapper B", "semi_real": "semi-real"}
"""The result files' part keys and the names the picture gives them."""
TARGETS = {
    # rate key: (panel title, the target, "at most" / "at least" / "nominal")
    "false_alarms_on_no_effect": ("no-effect cases naming an effect", 0.05, "at most"),
    "named_in_library": ("in-library effects named (or their set)", 0.95, "at least"),
    "out_of_library_unexplained_or_nearest_derivative": (
        "out-of-library: unexplained or nearest derivative",
        0.90,
        "at least",
    ),
    "fresh_flight_closure_within_prediction_interval": (
        "fresh flight inside the 90 % prediction interval",
        0.90,
        "nominal",
    ),
}
"""Issue 15's "Done when" rates and targets."""
MAGNITUDE_TARGET_PERCENT = 20.0
"""Issue 15: the semi-real cases' injected magnitudes within 20 %."""


def realities_figure(scores: dict[str, dict], title: str) -> plt.Figure:
    """The figure of the module docstring from ``scores`` (part -> ``summarise``'s scores: its
    ``rate_counts`` and ``rate_intervals_95``, and the magnitude errors)."""
    figure, axes = plt.subplots(1, len(TARGETS) + 1, figsize=(3.0 * (len(TARGETS) + 1), 3.8))
    parts = [part for part in PARTS if part in scores]
    for axis, (rate, (label, target, side)) in zip(axes[:-1], TARGETS.items(), strict=True):
        for position, part in enumerate(parts):
            successes, trials = scores[part]["rate_counts"][rate]
            if trials == 0:
                axis.text(
                    position, 0.5, "no cases", ha="center", va="center", fontsize=8, rotation=90
                )
                continue
            low, high = scores[part]["rate_intervals_95"][rate]
            share = successes / trials
            axis.errorbar(
                position,
                share,
                yerr=[[share - low], [high - share]],
                fmt="o",
                color="black",
                capsize=4,
            )
            axis.annotate(
                f"{successes}/{trials}",
                (position, share),
                textcoords="offset points",
                xytext=(7, 0),
                va="center",
                fontsize=8,
            )
        axis.set_ylim(-0.03, 1.03)
        _target_line(axis, target, f"{side} {target:.2f}")
        _part_axis(axis, parts, label)
    axes[0].set_ylabel("share of cases\n(95 % Wilson interval)")
    _magnitude_panel(axes[-1], scores, parts)
    figure.suptitle(title, fontsize=9)
    figure.tight_layout()
    return figure


def _magnitude_panel(axis: plt.Axes, scores: dict[str, dict], parts: list[str]) -> None:
    """Median (dot) and largest (bar's top) magnitude error of the named effects per part, %."""
    for position, part in enumerate(parts):
        median, largest = (
            scores[part]["magnitude_error_median"],
            scores[part]["magnitude_error_max"],
        )
        if median is None:
            axis.text(position, 10.0, "no cases", ha="center", va="center", fontsize=8, rotation=90)
            continue
        axis.vlines(position, 0.0, 100.0 * largest, color="grey", linewidth=3)
        axis.plot(position, 100.0 * median, "o", color="black")
        axis.annotate(
            f"{100.0 * largest:.0f}",
            (position, 100.0 * largest),
            textcoords="offset points",
            xytext=(0, 3),
            ha="center",
            fontsize=8,
        )
    largest_percent = [
        100.0 * scores[part]["magnitude_error_max"]
        for part in parts
        if scores[part]["magnitude_error_max"] is not None
    ]
    # room above the tallest bar's label for the target's name
    axis.set_ylim(0.0, 1.3 * max([MAGNITUDE_TARGET_PERCENT, *largest_percent]))
    _target_line(axis, MAGNITUDE_TARGET_PERCENT, "semi-real: at most 20 %")
    _part_axis(axis, parts, "magnitude error of named effects")
    axis.set_ylabel("error (%): median (dot), largest (bar)")


def _target_line(axis: plt.Axes, target: float, text: str) -> None:
    """The target as a dashed line, named in the corner of the panel on the far side of the line from it (the
    points sit near a target they meet or miss narrowly, and a name beside the line covered them)."""
    axis.axhline(target, color="tab:red", linestyle="--", linewidth=1)
    bottom, top = axis.get_ylim()
    high = (target - bottom) / (top - bottom) > 0.5
    axis.text(
        0.03,
        0.03 if high else 0.97,
        f"dashed: {text}",
        transform=axis.transAxes,
        va="bottom" if high else "top",
        color="tab:red",
        fontsize=7,
    )


def _part_axis(axis: plt.Axes, parts: list[str], title: str) -> None:
    axis.set_xticks(range(len(parts)), [PARTS[part] for part in parts], fontsize=8)
    axis.set_xlim(-0.5, len(parts) - 0.25)  # room for the last point's count beside it
    axis.set_title(title, fontsize=8)
    axis.grid(axis="y", alpha=0.3)


def save_realities_figure(scores: dict[str, dict], title: str, path: Path) -> Path:
    """:func:`realities_figure` written to ``path`` (its suffix chooses the format)."""
    figure = realities_figure(scores, title)
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return path
