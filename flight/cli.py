"""``ornitail flight``: identify a model file's parameters from a flight log."""

from __future__ import annotations

from typing import Any

import click

from ornitail.core.output import emit, json_option
from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.identify import METHODS, identify
from ornitail.flight.model_file import load_model

flight_group = click.Group("flight", help="Free-flight system identification.")


def _render_identification(result: dict[str, Any]) -> str:
    lines = [
        f"model {result['model']}  method {result['method']}  "
        f"{'converged' if result['converged'] else 'NOT CONVERGED'}: {result['message']}",
        f"{'parameter':12s} {'value':>13s} {'sigma':>11s} {'sigma_colored':>13s}",
    ]
    for name, estimate in result["parameters"].items():
        lines.append(
            f"{name:12s} {estimate['value']:13.5g} {estimate['sigma']:11.3g} "
            f"{estimate['sigma_colored']:13.3g}"
        )
    lines.append("fit (1 - NRMSE): " + "  ".join(f"{k} {v:.3f}" for k, v in result["fit"].items()))
    lines.append(
        "eigenvalues [1/s]: "
        + ", ".join(f"{real:.4g}{imag:+.4g}j" for real, imag in result["eigenvalues"])
    )
    for mode in result["modes"]:
        if mode["oscillatory"]:
            lines.append(
                f"  oscillatory mode: damping ratio {mode['damping_ratio']:.3f}, natural "
                f"frequency {mode['natural_frequency_rad_s']:.3f} rad/s"
            )
    return "\n".join(lines)


@flight_group.command("identify")
@click.option("--model", "model_name", required=True, help="Model file (.toml) or preset name.")
@click.option("--data", "data_path", required=True, help="Flight log: .csv, .parquet or .mat.")
@click.option("--method", type=click.Choice(METHODS), default="output_error", show_default=True)
@json_option
def identify_command(model_name: str, data_path: str, method: str, as_json: bool) -> None:
    """Estimate the parameters of a linear model from one flight log."""
    model = load_model(model_name)
    result = identify(model, read_flight_log(data_path), method=method, where=data_path)
    summary = result.summary()
    if as_json:
        emit(summary, True, _render_identification)
        return
    summary.update(
        model=model.name,
        method=method,
        converged=result.converged,
        message=result.message,
        modes=[
            {
                "oscillatory": mode.mode.oscillatory,
                "damping_ratio": mode.mode.damping_ratio,
                "natural_frequency_rad_s": mode.mode.natural_frequency_rad_s,
            }
            for mode in result.modes
        ],
    )
    emit(summary, False, _render_identification)
