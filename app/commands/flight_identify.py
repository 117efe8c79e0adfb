"""``ornitail flight identify``: identify a model file's parameters from a flight log."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.flight.fit_report_files import prepare_directory, write_fit_report
from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.identification_result import IdentificationResult
from ornitail.flight.identify import METHODS, identify
from ornitail.flight.model_file import INPUT_HOLDS, load_model


def _status(result: dict[str, Any]) -> str:
    """``converged`` or ``NOT CONVERGED``, the number of warnings and any further message."""
    status = "converged" if result["converged"] else "NOT CONVERGED"
    count = len(result["warnings"])
    if count:
        status += f", with {count} warning{'s' if count > 1 else ''}"
    if result["message"] != "converged":
        status += f": {result['message']}"
    return status


def _render_identification(result: dict[str, Any]) -> str:
    lines = [
        f"model {result['model']}  method {result['method']}  input hold {result['input_hold']}  "
        + _status(result),
        f"{'parameter':12s} {'value':>13s} {'sigma':>11s} {'sigma_colored':>13s}  unit",
    ]
    for name, estimate in result["parameters"].items():
        lines.append(
            f"{name:12s} {estimate['value']:13.5g} {estimate['sigma']:11.3g} "
            f"{estimate['sigma_colored']:13.3g}  {estimate['unit']}"
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
    lines += [f"warning: {warning}" for warning in result["warnings"]]
    if "written" in result:
        written = result["written"]
        names = ", ".join(Path(path).name for path in written)
        lines.append(f"wrote {len(written)} files to {Path(written[0]).parent}: {names}")
    return "\n".join(lines)


def _details(result: IdentificationResult, method: str) -> dict[str, Any]:
    """The summary with the model, method, convergence and modes (text output and JSON file)."""
    return {
        **result.summary(),
        "model": result.model.name,
        "method": method,
        "converged": result.converged,
        "message": result.message,
        "modes": [
            {
                "oscillatory": mode.mode.oscillatory,
                "damping_ratio": mode.mode.damping_ratio,
                "natural_frequency_rad_s": mode.mode.natural_frequency_rad_s,
            }
            for mode in result.modes
        ],
    }


@click.command("identify")
@click.option("--model", "model_name", required=True, help="Model file (.toml) or preset name.")
@click.option("--data", "data_path", required=True, help="Flight log: .csv, .parquet or .mat.")
@click.option("--method", type=click.Choice(METHODS), default="output_error", show_default=True)
@click.option(
    "--input-hold",
    type=click.Choice(INPUT_HOLDS),
    default=None,
    help="Input hold between samples (default: the model file's [model].input_hold).",
)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(path_type=Path),
    default=None,
    help="Folder for the fit report: pictures, parameters.csv, identification.json.",
)
@json_option
def identify_command(
    model_name: str,
    data_path: str,
    method: str,
    input_hold: str | None,
    out_dir: Path | None,
    as_json: bool,
) -> None:
    """Estimate the parameters of a linear model from one flight log."""
    model = load_model(model_name)
    if input_hold is not None:
        model = model.with_input_hold(input_hold)
    if out_dir is not None:
        prepare_directory(out_dir)
    log = read_flight_log(data_path)
    result = identify(model, log, method=method, where=data_path)
    details = _details(result, method)
    printed = result.summary() if as_json else details
    if out_dir is not None:
        written = write_fit_report(result, log, details, out_dir)
        printed["written"] = [str(path) for path in written]
    emit(printed, as_json, _render_identification)
