"""``ornitail flight identify --out DIR``: the fit report as files (docs/model-files.md, "Judging
a fit").

Pictures, each PNG and PDF: ``compare`` (measured and simulated outputs, fit in each panel's
title), ``residuals`` (measured - simulated over time), ``residual_autocorrelation`` (lags
0..25) and ``residual_input_correlation`` (lags -25..25, per output and non-constant input),
both with the 99 % bound. Outputs are drawn in the units of their log column (the unit is in the
column's name). Tables: ``parameters.csv`` and the two correlation sequences as CSV; the summary
as ``identification.json``.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from ornitail.core.errors import UserInputError  # noqa: E402
from ornitail.core.output import to_jsonable  # noqa: E402
from ornitail.flight.campaign_plots import _save as save_picture  # noqa: E402
from ornitail.flight.fit_report import (  # noqa: E402
    AUTOCORRELATION_FIGURE,
    COMPARE_FIGURE,
    INPUT_CORRELATION_FIGURE,
    RESIDUALS_FIGURE,
    ResidualCorrelations,
    correlation_sequences,
)
from ornitail.flight.identification_result import IdentificationResult  # noqa: E402
from ornitail.flight.model_data import ModelData, model_data  # noqa: E402

PARAMETER_TABLE = "parameters.csv"
AUTOCORRELATION_TABLE = "residual_autocorrelation.csv"
INPUT_CORRELATION_TABLE = "residual_input_correlation.csv"
SUMMARY_FILE = "identification.json"


def prepare_directory(directory: Path) -> None:
    """Create ``directory`` (and parents) or raise a one-line :class:`UserInputError` when it
    cannot be created or written to.
    """
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UserInputError(
            f"{directory}", f"cannot create the folder ({error.strerror or error})"
        ) from None
    if not os.access(directory, os.W_OK):
        raise UserInputError(f"{directory}", "the folder is not writable")


def _outputs_in_column_units(
    result: IdentificationResult, signals: ModelData, log: pd.DataFrame
) -> tuple[np.ndarray, np.ndarray, dict[str, str]]:
    """Measured and simulated outputs (samples, outputs) in each output's log-column units
    (undoing the column's scale, offset and removed start mean), and each output's y label.
    """
    spec = result.model
    measured, simulated, labels = [], [], {}
    for index, output in enumerate(spec.outputs):
        column = spec.columns[output]
        raw = log[column.column].to_numpy(dtype=float)
        shift = float(np.mean(signals.outputs[:, index] - column.scale * raw))
        measured.append(raw)
        simulated.append((result.simulated_outputs[:, index] - shift) / column.scale)
        labels[output] = f"{output} ({column.column})"
    return np.column_stack(measured), np.column_stack(simulated), labels


def _time_panels(count: int) -> tuple[plt.Figure, np.ndarray]:
    figure, axes = plt.subplots(
        count, 1, figsize=(8, 2.1 * count + 0.6), sharex=True, squeeze=False
    )
    axes[-1, 0].set_xlabel("time from the log's start [s]")
    return figure, axes[:, 0]


def compare_figure(
    time_s: np.ndarray,
    measured: np.ndarray,
    simulated: np.ndarray,
    labels: dict[str, str],
    fit: dict[str, float],
) -> plt.Figure:
    """Measured and simulated output over time (s), one panel per output with its fit."""
    figure, axes = _time_panels(len(labels))
    for index, (axis, output) in enumerate(zip(axes, labels, strict=True)):
        axis.plot(time_s, measured[:, index], color="0.35", linewidth=1.2, label="measured")
        axis.plot(time_s, simulated[:, index], color="tab:red", linestyle="--", label="model")
        axis.set_title(f"{output}: fit (1 - NRMSE) {fit[output]:.3f}")
        axis.set_ylabel(labels[output])
    axes[0].legend(loc="best")
    figure.suptitle("measured and model outputs", fontsize=10)
    figure.tight_layout()
    return figure


def compare_picture(
    time_s: np.ndarray,
    measured: np.ndarray,
    simulated: np.ndarray,
    labels: dict[str, str],
    fit: dict[str, float],
    directory: Path,
) -> list[Path]:
    """Write :func:`compare_figure` as ``compare.png`` and ``.pdf``; return the paths."""
    figure = compare_figure(time_s, measured, simulated, labels, fit)
    return save_picture(figure, directory, COMPARE_FIGURE)


def residuals_figure(
    time_s: np.ndarray, residuals: np.ndarray, labels: dict[str, str]
) -> plt.Figure:
    """Residual (measured - model) of each output over time (s), in its column's units."""
    figure, axes = _time_panels(len(labels))
    for index, (axis, output) in enumerate(zip(axes, labels, strict=True)):
        axis.plot(time_s, residuals[:, index], color="tab:blue", linewidth=1.0)
        axis.axhline(0.0, color="black", linewidth=0.6)
        axis.set_title(f"{output}: measured - model")
        axis.set_ylabel(labels[output])
    figure.suptitle("residuals, measured - model", fontsize=10)
    figure.tight_layout()
    return figure


def residuals_picture(
    time_s: np.ndarray, residuals: np.ndarray, labels: dict[str, str], directory: Path
) -> list[Path]:
    """Write :func:`residuals_figure` as ``residuals.png`` and ``.pdf``; return the paths."""
    return save_picture(residuals_figure(time_s, residuals, labels), directory, RESIDUALS_FIGURE)


def _correlation_panel(
    axis: plt.Axes, lags: np.ndarray, values: np.ndarray, bound: float, title: str
) -> None:
    axis.vlines(lags, 0.0, values, color="tab:blue", linewidth=1.2)
    axis.plot(lags, values, "o", color="tab:blue", markersize=2.5)
    axis.axhspan(-bound, bound, color="tab:orange", alpha=0.15, label=f"99 % bound, {bound:.3f}")
    for level in (-bound, bound):
        axis.axhline(level, color="tab:orange", linestyle="--", linewidth=1.0)
    axis.axhline(0.0, color="black", linewidth=0.6)
    axis.set_title(title)


def autocorrelation_picture(
    correlations: ResidualCorrelations, time_step_s: float, directory: Path
) -> list[Path]:
    """Residual autocorrelation of each output at lags 0..L with the 99 % bound."""
    outputs = list(correlations.autocorrelation)
    figure, axes = plt.subplots(len(outputs), 1, figsize=(6, 2.0 * len(outputs) + 0.6))
    for axis, output in zip(np.atleast_1d(axes), outputs, strict=True):
        _correlation_panel(
            axis,
            correlations.auto_lags,
            correlations.autocorrelation[output],
            correlations.bound,
            f"residual autocorrelation of {output}",
        )
        axis.set_ylabel("correlation [-]")
    np.atleast_1d(axes)[0].legend(loc="best")
    np.atleast_1d(axes)[-1].set_xlabel(f"lag [samples of {time_step_s:g} s]")
    figure.tight_layout()
    return save_picture(figure, directory, AUTOCORRELATION_FIGURE)


def input_correlation_picture(
    correlations: ResidualCorrelations, time_step_s: float, directory: Path
) -> list[Path]:
    """Residual-input correlation per output (rows) and non-constant input (columns) at lags
    -L..L with the 99 % bound; nothing when every input is constant.
    """
    outputs = list(correlations.autocorrelation)
    inputs = list(dict.fromkeys(name for _, name in correlations.input_correlation))
    if not inputs:
        return []
    figure, axes = plt.subplots(
        len(outputs),
        len(inputs),
        figsize=(4.5 * len(inputs) + 1, 2.0 * len(outputs) + 0.6),
        squeeze=False,
        sharex=True,
    )
    for row, output in enumerate(outputs):
        for column, name in enumerate(inputs):
            _correlation_panel(
                axes[row, column],
                correlations.cross_lags,
                correlations.input_correlation[(output, name)],
                correlations.bound,
                f"residual of {output} vs input {name}",
            )
        axes[row, 0].set_ylabel("correlation [-]")
    axes[0, 0].legend(loc="best")
    for axis in axes[-1]:
        axis.set_xlabel(f"lag [samples of {time_step_s:g} s]")
    figure.tight_layout()
    return save_picture(figure, directory, INPUT_CORRELATION_FIGURE)


def write_parameter_table(result: IdentificationResult, directory: Path) -> Path:
    """``parameters.csv``: value, Cramer-Rao and colored sigma of every parameter, in ``unit``."""
    table = pd.DataFrame(
        [
            {
                "parameter": name,
                "value": estimate.value,
                "sigma_crb": estimate.sigma,
                "sigma_colored": estimate.sigma_colored,
                "unit": result.model.parameter(name).unit,
            }
            for name, estimate in result.parameters.items()
        ]
    )
    path = directory / PARAMETER_TABLE
    table.to_csv(path, index=False)
    return path


def write_correlation_tables(
    correlations: ResidualCorrelations, time_step_s: float, directory: Path
) -> list[Path]:
    """The correlation sequences as CSV: ``lag_samples``, ``lag_s`` and one column per output
    (autocorrelation) or per ``<output>_vs_<input>`` (residual-input correlation).
    """
    auto = pd.DataFrame({"lag_samples": correlations.auto_lags})
    auto["lag_s"] = correlations.auto_lags * time_step_s
    for output, values in correlations.autocorrelation.items():
        auto[output] = values
    cross = pd.DataFrame({"lag_samples": correlations.cross_lags})
    cross["lag_s"] = correlations.cross_lags * time_step_s
    for (output, name), values in correlations.input_correlation.items():
        cross[f"{output}_vs_{name}"] = values
    paths = [directory / AUTOCORRELATION_TABLE, directory / INPUT_CORRELATION_TABLE]
    auto.to_csv(paths[0], index=False)
    cross.to_csv(paths[1], index=False)
    return paths


def write_fit_report(
    result: IdentificationResult, log: pd.DataFrame, summary: dict[str, Any], directory: Path
) -> list[Path]:
    """Write every file of the report into ``directory`` (made by :func:`prepare_directory`);
    ``summary`` goes into the JSON with the residual tests and the list of files.
    """
    signals = model_data(result.model, log)
    measured, simulated, labels = _outputs_in_column_units(result, signals, log)
    time_s = signals.time_s - signals.time_s[0]
    correlations = correlation_sequences(
        signals.outputs - result.simulated_outputs,
        signals.inputs,
        result.model.outputs,
        result.model.inputs,
    )
    step = result.time_step_s
    try:
        written = compare_picture(time_s, measured, simulated, labels, result.fit, directory)
        written += residuals_picture(time_s, measured - simulated, labels, directory)
        written += autocorrelation_picture(correlations, step, directory)
        written += input_correlation_picture(correlations, step, directory)
        written += [write_parameter_table(result, directory)]
        written += write_correlation_tables(correlations, step, directory)
        written.append(directory / SUMMARY_FILE)
        document = {
            **summary,
            "residual_tests": asdict(result.residual_tests),
            "written": [str(path) for path in written],
        }
        written[-1].write_text(json.dumps(to_jsonable(document), indent=1))
    except OSError as error:
        raise UserInputError(
            f"{directory}", f"cannot write the report ({error.strerror or error})"
        ) from None
    return written
