"""``ornitail calibration ...`` commands: ATI conversion, hot-wire fit, tunnel table."""

from __future__ import annotations

from pathlib import Path

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.calibration.hotwire_fit import DEFAULT_POLYNOMIAL_ORDER
from ornitail.core.errors import UserInputError, require_finite
from ornitail.core.input_files import prepare_output_file

# The calibration modules are imported inside the commands (only hotwire_fit's default is needed above, and with
# it numpy): `ornitail calibration --help` stays fast.

DEFAULT_WIRE_TEMPERATURE_C = 250.0
MAX_WIRE_TEMPERATURE_C = 1000.0
"""Hottest wire (and reference) temperature accepted, degC (hot wires run at 200-300 degC)."""

calibration_group = click.Group("calibration", help="Balance, hot-wire and tunnel calibrations.")

_cal_option = click.option(
    "--cal",
    "cal_path",
    required=True,
    type=click.Path(path_type=Path),
    help="ATI calibration file (.cal, format 1.0 or 1.1).",
)


@calibration_group.command("convert")
@_cal_option
@click.option("--volts", required=True, help="Six raw gauge voltages v1,...,v6 in V.")
@click.option("--bias", default="0,0,0,0,0,0", show_default=True, help="Six bias voltages in V.")
@click.option(
    "--tool-transform",
    default="0,0,0,0,0,0",
    show_default=True,
    help="dx,dy,dz in mm and rx,ry,rz in degrees (ATI order: about x, then new y, then new z).",
)
@json_option
def convert_command(
    cal_path: Path, volts: str, bias: str, tool_transform: str, as_json: bool
) -> None:
    """Convert six raw gauge voltages to forces (N) and torques (N m)."""
    import numpy as np

    from ornitail.calibration.ati_calibration import (
        WRENCH_COMPONENT_KEYS,
        WRENCH_COMPONENT_NAMES,
        WRENCH_COMPONENT_UNITS,
        AtiCalibration,
    )
    from ornitail.calibration.number_lists import parse_comma_separated_numbers
    from ornitail.calibration.tool_transform import parse_tool_transform_option

    calibration = AtiCalibration.from_file(cal_path).with_tool_transform(
        parse_tool_transform_option(tool_transform)
    )
    if not np.all(np.isfinite(calibration.matrix_si)):
        raise UserInputError("--tool-transform", f"{tool_transform!r} is too large to use")
    volts_values = parse_comma_separated_numbers(volts, 6, "--volts")
    bias_values = parse_comma_separated_numbers(bias, 6, "--bias")
    with np.errstate(over="ignore", invalid="ignore"):
        wrench = calibration.forces_from_voltages(volts_values, bias_values)
    if not np.all(np.isfinite(wrench)):
        raise UserInputError(
            "--volts/--bias",
            f"volts {volts!r} minus bias {bias!r} give forces too large to represent "
            "(not finite); gauge voltages are a few volts",
        )
    result = dict(zip(WRENCH_COMPONENT_KEYS, wrench.tolist(), strict=True))

    def render(values: dict) -> str:
        return "\n".join(
            f"{name:>3}  {values[key]: .6g} {unit}"
            for name, key, unit in zip(
                WRENCH_COMPONENT_NAMES, WRENCH_COMPONENT_KEYS, WRENCH_COMPONENT_UNITS, strict=True
            )
        )

    emit(result, as_json, render)


@calibration_group.command("show")
@_cal_option
@json_option
def show_command(cal_path: Path, as_json: bool) -> None:
    """Show an ATI calibration: serial, units, SI matrix, rated ranges and content hash."""
    from ornitail.calibration.ati_cal_file import AXIS_NAMES
    from ornitail.calibration.ati_calibration import (
        WRENCH_COMPONENT_NAMES,
        WRENCH_COMPONENT_UNITS,
        AtiCalibration,
    )

    summary = AtiCalibration.from_file(cal_path).summary()

    def render(values: dict) -> str:
        units = values["file_units"]
        lines = [
            f"file:        {values['path']}",
            f"serial:      {values['serial']}  ({values['body_style']}, {values['part_number']})",
            f"cal date:    {values['calibration_date']}   format {values['file_format_version']}",
            f"file units:  force {units['force']}, torque {units['torque']}, "
            f"distance {units['distance']} (shown below in SI)",
            f"hash:        {values['content_hash']}",
            "matrix (N or N m per V):",
            "      " + "".join(f"{f'G{i}':>13}" for i in range(6)),
        ]
        for name, row in zip(AXIS_NAMES, values["matrix_si_per_volt"], strict=True):
            lines.append(f"  {name}  " + "".join(f"{value:13.5e}" for value in row))
        lines.append("rated ranges:")
        for name, value, unit in zip(
            WRENCH_COMPONENT_NAMES,
            values["rated_ranges"].values(),
            WRENCH_COMPONENT_UNITS,
            strict=True,
        ):
            lines.append(f"  {name}  {value:g} {unit}")
        return "\n".join(lines)

    emit(summary, as_json, render)


@calibration_group.command("hotwire-fit")
@click.option(
    "--points",
    "points_path",
    required=True,
    type=click.Path(path_type=Path),
    help="CSV with columns velocity_m_s,voltage_v,temperature_c.",
)
@click.option("--law", type=click.Choice(["king", "polynomial"]), default="king", show_default=True)
@click.option(
    "--order",
    type=int,
    default=DEFAULT_POLYNOMIAL_ORDER,
    show_default=True,
    help="Polynomial order (polynomial law only).",
)
@click.option(
    "--wire-temperature-c",
    type=float,
    default=DEFAULT_WIRE_TEMPERATURE_C,
    show_default=True,
    help="Hot-wire temperature, degC.",
)
@click.option(
    "--reference-temperature-c",
    type=float,
    default=None,
    help="Reference temperature of the law, degC (default: mean of the points).",
)
@click.option(
    "--out",
    "out_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Write the law to this .toml or .json file, and the fit's picture beside it "
    "(<name>_fit.png and .pdf).",
)
@json_option
def hotwire_fit_command(
    points_path: Path,
    law: str,
    order: int,
    wire_temperature_c: float,
    reference_temperature_c: float | None,
    out_path: Path | None,
    as_json: bool,
) -> None:
    """Fit King's law or a polynomial to hot-wire calibration points; report residuals."""
    from ornitail.calibration.hotwire_fit import fit_kings_law, fit_polynomial_law
    from ornitail.calibration.hotwire_laws import KingsLaw, save_hotwire_law
    from ornitail.calibration.hotwire_points import read_hotwire_points
    from ornitail.calibration.thermocouple_amplifier import CELSIUS_TO_KELVIN_OFFSET

    for option, value in (
        ("--wire-temperature-c", wire_temperature_c),
        ("--reference-temperature-c", reference_temperature_c),
    ):
        if value is None:
            continue
        require_finite(option, value)
        if not -CELSIUS_TO_KELVIN_OFFSET < value <= MAX_WIRE_TEMPERATURE_C:
            raise UserInputError(
                option,
                f"{value:g} degC is outside {-CELSIUS_TO_KELVIN_OFFSET:g}..{MAX_WIRE_TEMPERATURE_C:g} degC",
            )
    if out_path is not None and out_path.suffix.lower() not in (".toml", ".json"):
        raise UserInputError("--out", f"{out_path} must end in .toml or .json")
    if out_path is not None:
        prepare_output_file(out_path)
    points = read_hotwire_points(points_path)
    wire_temperature_k = wire_temperature_c + CELSIUS_TO_KELVIN_OFFSET
    reference_temperature_k = None
    if reference_temperature_c is not None:
        reference_temperature_k = reference_temperature_c + CELSIUS_TO_KELVIN_OFFSET
    try:
        if law == "king":
            fit = fit_kings_law(points, wire_temperature_k, reference_temperature_k)
        else:
            fit = fit_polynomial_law(points, wire_temperature_k, order, reference_temperature_k)
    except UserInputError as error:
        option = {"wire temperature": "--wire-temperature-c", "polynomial order": "--order"}
        if error.where in option:
            raise UserInputError(option[error.where], error.problem) from None
        raise
    fitted_law = fit.law if out_path is None else save_hotwire_law(fit.law, out_path)
    written = []
    if out_path is not None:
        from ornitail.calibration.hotwire_plots import write_hotwire_fit_picture

        written = [out_path, *write_hotwire_fit_picture(fit, points, out_path)]
    if isinstance(fitted_law, KingsLaw):
        coefficients = {
            "a_v2": fitted_law.a_v2,
            "b": fitted_law.b,
            "exponent_n": fitted_law.exponent_n,
        }
    else:
        coefficients = {"coefficients": fitted_law.coefficients.tolist()}
    result = {
        "law": fitted_law.law_name,
        "coefficients": coefficients,
        "parameter_standard_errors": fit.report.parameter_standard_errors,
        "reference_temperature_k": fitted_law.reference_temperature_k,
        "wire_temperature_k": fitted_law.wire_temperature_k,
        "rms_residual_m_s": fit.report.rms_residual_m_s,
        "max_abs_residual_m_s": fit.report.max_abs_residual_m_s,
        "points": [
            {"velocity_m_s": u, "fitted_velocity_m_s": f, "residual_m_s": r}
            for u, f, r in zip(
                fit.report.velocity_m_s.tolist(),
                fit.report.fitted_velocity_m_s.tolist(),
                fit.report.residual_m_s.tolist(),
                strict=True,
            )
        ],
        "points_content_hash": points.content_hash,
        "content_hash": fitted_law.content_hash,
        "out": None if out_path is None else str(out_path),
        "written": [str(path) for path in written],
    }

    def render(values: dict) -> str:
        lines = [
            f"law: {values['law']}  (T_ref {values['reference_temperature_k']:.2f} K, "
            f"T_wire {values['wire_temperature_k']:.2f} K)"
        ]
        lines += [f"  {name} = {value}" for name, value in values["coefficients"].items()]
        lines.append("  velocity_m_s  fitted_m_s  residual_m_s")
        lines += [
            f"  {point['velocity_m_s']:12.4f} {point['fitted_velocity_m_s']:11.4f}"
            f" {point['residual_m_s']:13.5f}"
            for point in values["points"]
        ]
        lines.append(
            f"RMS residual {values['rms_residual_m_s']:.5f} m/s, "
            f"max |residual| {values['max_abs_residual_m_s']:.5f} m/s"
        )
        lines.append(f"hash: {values['content_hash']}")
        if values["out"]:
            lines.append(f"written to {values['out']}")
        lines += [f"picture: {path}" for path in values["written"][1:]]
        return "\n".join(lines)

    emit(result, as_json, render)


@calibration_group.command("tunnel")
@click.option(
    "--table",
    "table_path",
    required=True,
    type=click.Path(path_type=Path),
    help="CSV with columns fan_rpm,velocity_m_s (strictly increasing).",
)
@click.option("--rpm", "fan_rpm", type=float, default=None, help="Fan speed, rev/min.")
@click.option(
    "--velocity-m-s",
    "velocity_m_s",
    type=float,
    default=None,
    help="Wanted jet velocity, m/s (gives the fan set point).",
)
@json_option
def tunnel_command(
    table_path: Path, fan_rpm: float | None, velocity_m_s: float | None, as_json: bool
) -> None:
    """Convert fan rpm to jet velocity, or a wanted velocity to the fan rpm set point."""
    from ornitail.calibration.tunnel_table import TunnelVelocityTable

    if (fan_rpm is None) == (velocity_m_s is None):
        raise UserInputError("--rpm/--velocity-m-s", "give exactly one of the two")
    table = TunnelVelocityTable.from_csv(table_path)
    try:
        if fan_rpm is not None:
            fan_rpm_value, velocity_value = fan_rpm, table.velocity_m_s_at_rpm(fan_rpm)
        else:
            fan_rpm_value, velocity_value = table.rpm_for_velocity(velocity_m_s), velocity_m_s
    except UserInputError as error:
        option = {"fan_rpm": "--rpm", "velocity_m_s": "--velocity-m-s"}.get(error.where)
        if option is None:
            raise
        raise UserInputError(option, error.problem) from None
    result = {
        "fan_rpm": float(fan_rpm_value),
        "velocity_m_s": float(velocity_value),
        "table_content_hash": table.content_hash,
    }
    emit(
        result,
        as_json,
        lambda values: f"fan {values['fan_rpm']:.1f} rpm  <->  {values['velocity_m_s']:.4f} m/s",
    )
