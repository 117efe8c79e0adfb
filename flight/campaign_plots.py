"""Campaign pictures, each written as PNG and PDF (docs/flight-campaign.md, "Pictures").

- ``poles``: poles of every configuration's representative model, of its accepted manoeuvre
  models, and of the simulator's linearisation when the flights were simulated; full view and a
  zoom on the oscillatory mode;
- ``oscillatory_mode``: damping ratio and natural frequency per configuration (+-2 sigma);
- ``responses_<configuration>``: the representative model simulated on the validation
  manoeuvres over the measured (filtered) response;
- ``parameters_<configuration>``: each parameter across manoeuvres (accepted and rejected, with
  +-2 sigma) and the three averaged models.

Angles and rates are drawn in degrees for reading; the axis labels say so.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ornitail.flight.campaign import ConfigurationResult  # noqa: E402

PICTURE_SUFFIXES = (".png", ".pdf")
AVERAGED_STYLES = {
    "mean": ("tab:green", "--", "mean"),
    "weighted": ("tab:purple", "-.", "covariance-weighted"),
    "time_averaged": ("tab:orange", "-", "time-averaged response"),
}
STATE_AXES = (  # column, label, factor from SI to the drawn unit
    ("q_rad_s", r"$\Delta q$ [deg/s]", 180 / math.pi),
    ("u_m_s", r"$\Delta u$ [m/s]", 1.0),
    ("w_m_s", r"$\Delta w$ [m/s]", 1.0),
    ("theta_rad", r"$\Delta\theta$ [deg]", 180 / math.pi),
)

plt.rcParams.update(
    {
        "font.size": 9,
        "axes.titlesize": 10,
        "axes.labelsize": 9,
        "legend.fontsize": 8,
        "axes.grid": True,
        "grid.alpha": 0.3,
        "savefig.dpi": 150,
    }
)


def file_stem(label: str) -> str:
    """A file-name-safe form of a configuration label (``S3@98`` -> ``S3_98``)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", label).strip("_")


def _save(figure: plt.Figure, directory: Path, stem: str) -> list[Path]:
    paths = []
    for suffix in PICTURE_SUFFIXES:
        path = directory / f"{stem}{suffix}"
        figure.savefig(path, bbox_inches="tight")
        paths.append(path)
    plt.close(figure)
    return paths


def _colours(count: int) -> list:
    cmap = plt.get_cmap("tab10")
    return [cmap(index % 10) for index in range(count)]


def pole_plot(results: list[ConfigurationResult], directory: Path) -> list[Path]:
    """Pole map of all configurations: full view and oscillatory-mode zoom."""
    figure, (full, zoom) = plt.subplots(1, 2, figsize=(10, 4.2), width_ratios=(1.3, 1))
    any_reference = False
    for result, colour in zip(results, _colours(len(results)), strict=True):
        label = result.configuration.label
        accepted = [result.models[index] for index in result.accepted]
        individual = np.concatenate([np.linalg.eigvals(m.state_space().a_matrix) for m in accepted])
        for axes in (full, zoom):
            axes.scatter(
                individual.real, individual.imag, s=9, color=colour, alpha=0.25, linewidths=0
            )
            poles = result.representative_eigenvalues
            axes.scatter(
                poles.real,
                poles.imag,
                s=46,
                marker="X",
                color=colour,
                edgecolors="black",
                linewidths=0.5,
                label=f"{label} ({result.representative.name.replace('_', '-')})",
                zorder=3,
            )
            reference = result.simulator_reference
            if reference is not None:
                any_reference = True
                exact = reference.eigenvalues()
                axes.scatter(
                    exact.real,
                    exact.imag,
                    s=70,
                    facecolors="none",
                    edgecolors=colour,
                    linewidths=1.4,
                    zorder=4,
                )
    for axes in (full, zoom):
        axes.axvline(0.0, color="black", linewidth=0.8)
        axes.axhline(0.0, color="black", linewidth=0.5)
        axes.set_xlabel("real part [1/s]")
        axes.set_ylabel("imaginary part [rad/s]")
    oscillatory = [
        estimate.mode.eigenvalue
        for result in results
        for estimate in result.representative_modes
        if estimate.mode.oscillatory
    ]
    if oscillatory:
        centre_imag = float(np.mean([value.imag for value in oscillatory]))
        spread = max(2.0, 0.6 * centre_imag)
        lowest_real = min(value.real for value in oscillatory)
        zoom.set_xlim(min(-3.0, 1.5 * lowest_real), 1.0)
        zoom.set_ylim(max(0.0, centre_imag - spread), centre_imag + spread)
    full.set_title("Poles: representative (X), manoeuvre models (dots)")
    zoom.set_title("Oscillatory mode (zoom)")
    handles, labels = full.get_legend_handles_labels()
    if any_reference:
        handles.append(
            plt.Line2D(
                [],
                [],
                marker="o",
                linestyle="none",
                markerfacecolor="none",
                markeredgecolor="grey",
                markersize=8,
            )
        )
        labels.append("simulator linearisation")
    full.legend(handles, labels, loc="upper left", framealpha=0.9)
    figure.tight_layout()
    return _save(figure, directory, "poles")


def oscillatory_mode_plot(results: list[ConfigurationResult], directory: Path) -> list[Path]:
    """Damping ratio and natural frequency of the oscillatory mode per configuration."""
    figure, (damping_axes, frequency_axes) = plt.subplots(1, 2, figsize=(9, 3.6))
    labels = [result.configuration.label for result in results]
    positions = np.arange(len(results))
    for axes, key, sigma_key, reference_key, title in (
        (damping_axes, "damping_ratio", "sigma_damping_ratio", "damping", "damping ratio [-]"),
        (
            frequency_axes,
            "natural_frequency_rad_s",
            "sigma_natural_frequency_rad_s",
            "frequency",
            "natural frequency [rad/s]",
        ),
    ):
        values, sigmas, references = [], [], []
        for result in results:
            mode = next((m for m in result.representative_modes if m.mode.oscillatory), None)
            values.append(getattr(mode.mode, key) if mode else math.nan)
            sigmas.append(getattr(mode, sigma_key) if mode else math.nan)
            reference = result.simulator_reference
            if reference is None:
                references.append(math.nan)
            elif reference_key == "damping":
                references.append(reference.oscillatory_damping_ratio())
            else:
                references.append(reference.oscillatory_natural_frequency_rad_s())
        axes.errorbar(
            positions,
            values,
            yerr=2 * np.asarray(sigmas),
            fmt="o",
            color="tab:blue",
            capsize=3,
            label="identified (representative, $\\pm 2\\sigma$)",
        )
        if np.any(np.isfinite(references)):
            axes.scatter(
                positions,
                references,
                marker="_",
                s=300,
                color="black",
                linewidths=1.6,
                label="simulator linearisation",
                zorder=3,
            )
        axes.set_xticks(positions, labels, rotation=30 if len(labels) > 4 else 0)
        axes.set_ylabel(title)
        axes.set_xlim(-0.6, len(results) - 0.4)
    damping_axes.legend(loc="best")
    damping_axes.set_title("Oscillatory mode: damping")
    frequency_axes.set_title("Oscillatory mode: natural frequency")
    figure.tight_layout()
    return _save(figure, directory, "oscillatory_mode")


def response_plot(result: ConfigurationResult, directory: Path, most: int = 4) -> list[Path]:
    """Representative model over the measured response of up to ``most`` validation manoeuvres."""
    responses = result.validation_responses[:most]
    columns = len(responses)
    figure, axes = plt.subplots(
        4, columns, figsize=(2.7 * columns + 1.0, 7.0), sharex="col", sharey="row", squeeze=False
    )
    output_columns = [result.spec.columns[name].column for name in result.spec.outputs]
    for column, response in enumerate(responses):
        time = response.manoeuvre.deviations["time_s"].to_numpy()[: len(response.measured)]
        for row, (state_column, label, factor) in enumerate(STATE_AXES):
            if state_column not in output_columns:
                continue
            position = output_columns.index(state_column)
            ax = axes[row, column]
            ax.plot(
                time,
                factor * response.measured[:, position],
                color="0.35",
                linewidth=1.2,
                label="measured (5 Hz low-pass)",
            )
            ax.plot(
                time,
                factor * response.simulated[:, position],
                color="tab:red",
                linewidth=1.2,
                linestyle="--",
                label="representative model",
            )
            ax.axvline(response.manoeuvre.input_start_s, color="tab:blue", linewidth=0.6, alpha=0.6)
            if column == 0:
                ax.set_ylabel(label)
        axes[0, column].set_title(response.manoeuvre.label.split("/")[-1], fontsize=8)
        axes[-1, column].set_xlabel("time from manoeuvre start [s]")
    axes[0, 0].legend(loc="lower right", fontsize=7)
    figure.suptitle(
        f"{result.configuration.label}: {result.representative.name.replace('_', '-')} model "
        f"on validation manoeuvres (input at the blue line)",
        fontsize=10,
    )
    figure.tight_layout()
    return _save(figure, directory, f"responses_{file_stem(result.configuration.label)}")


def parameter_spread_plot(result: ConfigurationResult, directory: Path) -> list[Path]:
    """Each estimated parameter across manoeuvres with the three averaged models."""
    names = result.models[0].parameter_names
    columns = 4
    rows = math.ceil(len(names) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(11, 2.3 * rows + 0.6), squeeze=False)
    rejected = result.flags.rejected
    numbers = np.arange(1, len(result.models) + 1)
    reference = result.simulator_reference
    for index, name in enumerate(names):
        ax = axes.flat[index]
        values = np.array([model.values[index] for model in result.models])
        sigmas = np.array([model.sigmas[index] for model in result.models])
        kept = ~rejected
        ax.errorbar(
            numbers[kept],
            values[kept],
            yerr=2 * sigmas[kept],
            fmt="o",
            markersize=3,
            color="tab:blue",
            capsize=2,
            linewidth=0.8,
            label="accepted ($\\pm 2\\sigma$)",
        )
        if np.any(rejected):
            ax.errorbar(
                numbers[rejected],
                values[rejected],
                yerr=2 * sigmas[rejected],
                fmt="x",
                markersize=5,
                color="tab:red",
                capsize=2,
                linewidth=0.8,
                label="rejected",
            )
        for model in result.averaged:
            colour, style, label = AVERAGED_STYLES[model.name]
            width = 2.2 if model is result.representative else 1.1
            ax.axhline(
                model.estimate.values[index],
                color=colour,
                linestyle=style,
                linewidth=width,
                label=label,
            )
        if reference is not None and name in reference.derivatives:
            ax.axhline(
                reference.derivatives[name],
                color="black",
                linestyle=":",
                linewidth=1.4,
                label="simulator",
            )
        ax.set_title(f"{name} [{result.spec.parameter(name).unit or '-'}]")  # the model file's unit
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
        ax.set_xlim(0.3, len(result.models) + 0.7)
    for ax in axes.flat[len(names) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("converged manoeuvre model")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="lower center", ncol=len(labels), frameon=False)
    figure.suptitle(
        f"{result.configuration.label}: parameters per manoeuvre; thick line = representative "
        f"({result.representative.name.replace('_', '-')})",
        fontsize=10,
    )
    figure.tight_layout(rect=(0, 0.05, 1, 1))
    return _save(figure, directory, f"parameters_{file_stem(result.configuration.label)}")


def write_campaign_pictures(results: list[ConfigurationResult], directory: Path) -> list[Path]:
    """All pictures of a campaign into ``directory`` (PNG and PDF each)."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = pole_plot(results, directory) + oscillatory_mode_plot(results, directory)
    for result in results:
        paths += response_plot(result, directory)
        paths += parameter_spread_plot(result, directory)
    return paths
