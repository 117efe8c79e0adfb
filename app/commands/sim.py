"""``ornitail sim``: trim a simulated build and print its linear model; fly a flight log."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import prepare_output_directory, prepare_output_file

# The simulator (numpy, scipy, pandas) is imported inside the commands: `ornitail sim --help` stays fast.

MAX_SEED = 2**32 - 1
"""Largest random seed accepted (seeds are 0..2**32 - 1)."""

sim_group = click.Group("sim", help="Physics simulator of the DelFly II with its tail.")


def trim_summary(tail: str, x_h_mm: float) -> dict[str, Any]:
    """Trim, eigenstructure and derivatives of a study tail at x_h (mm) as a JSON-ready dict."""
    from ornitail.sim.configuration import study_configuration
    from ornitail.sim.dynamics import TrimNotFoundError, linearise
    from ornitail.sim.effects import EffectSet

    configuration = study_configuration(tail, x_h_mm)
    try:
        model = linearise(configuration, EffectSet())
    except TrimNotFoundError as error:
        raise UserInputError(f"--tail {tail} --x-h-mm {x_h_mm:g}", str(error)) from error
    trim = model.trim
    return {
        "tail": tail,
        "x_h_mm": x_h_mm,
        "theta_deg": math.degrees(trim.theta_rad),
        "v_m_s": trim.airspeed_m_s,
        "f_hz": trim.flapping_frequency_hz,
        "throttle": trim.throttle,
        "mass_kg": model.mass_kg,
        "iyy_kg_m2": model.iyy_kg_m2,
        "eigenvalues_real": [value.real for value in model.eigenvalues()],
        "eigenvalues_imag": [value.imag for value in model.eigenvalues()],
        "damping_ratio": model.oscillatory_damping_ratio(),
        "natural_frequency_rad_s": model.oscillatory_natural_frequency_rad_s(),
        "derivatives": model.derivatives,
        "derivative_units": _derivative_units(model.derivatives),
    }


def _derivative_units(derivatives: dict[str, float]) -> dict[str, str]:
    """The unit of each derivative, as the study's model file declares it (flight/models/delfly_longitudinal)."""
    from ornitail.flight.model_file import load_model

    spec = load_model("delfly_longitudinal")
    return {name: spec.parameter(name).unit for name in derivatives if name in spec.parameter_names}


def _write_trim_pictures(result: dict[str, Any], out_dir: Path) -> list[str]:
    from ornitail.sim.trim_plots import write_pole_map

    eigenvalues = [
        complex(re, im)
        for re, im in zip(result["eigenvalues_real"], result["eigenvalues_imag"], strict=True)
    ]
    title = f"tail {result['tail']} at x_h {result['x_h_mm']:g} mm"
    paths = write_pole_map(
        eigenvalues,
        result["damping_ratio"],
        result["natural_frequency_rad_s"],
        title,
        out_dir,
    )
    return [str(path) for path in paths]


def _render_trim(result: dict[str, Any]) -> str:
    poles = ", ".join(
        f"{re:.3f}{im:+.3f}j"
        for re, im in zip(result["eigenvalues_real"], result["eigenvalues_imag"], strict=True)
    )
    lines = [
        f"tail {result['tail']} at x_h = {result['x_h_mm']:g} mm",
        f"theta_deg {result['theta_deg']:.2f}  v_m_s {result['v_m_s']:.3f}"
        f"  f_hz {result['f_hz']:.2f}"
        f"  throttle {result['throttle']:.3f}",
        f"eigenvalues [1/s]: {poles}",
        f"damping ratio {result['damping_ratio']:.3f}  natural frequency "
        f"{result['natural_frequency_rad_s']:.3f} rad/s",
        "derivatives (body frame of docs/frames.md):",
    ]
    units = result["derivative_units"]
    lines += [
        f"  {name:4s} {value: .4e} {units.get(name, '')}".rstrip()
        for name, value in result["derivatives"].items()
    ]
    lines += [f"wrote {path}" for path in result.get("written", [])]
    return "\n".join(lines)


@sim_group.command("trim")
@click.option("--tail", required=True, help="Study tail name, e.g. S3, AR1, T2.")
@click.option(
    "--x-h-mm", type=float, default=98.0, show_default=True, help="Tail position x_h in mm."
)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(path_type=Path),
    default=None,
    help="Folder for the pole map (trim_poles.png and .pdf).",
)
@json_option
def trim_command(tail: str, x_h_mm: float, out_dir: Path | None, as_json: bool) -> None:
    """Free-flight trim and linearised model of a study tail; with --out, its pole map."""
    if out_dir is not None:
        prepare_output_directory(out_dir)
    result = trim_summary(tail, x_h_mm)
    if out_dir is not None:
        result["written"] = _write_trim_pictures(result, out_dir)
    emit(result, as_json, _render_trim)


@sim_group.command("flight")
@click.option("--tail", required=True, help="Study tail name, e.g. S3.")
@click.option(
    "--x-h-mm", type=float, default=98.0, show_default=True, help="Tail position x_h in mm."
)
@click.option(
    "--duration-s", type=float, default=60.0, show_default=True, help="Flight length in s."
)
@click.option(
    "--seed",
    type=click.IntRange(0, MAX_SEED),
    default=0,
    show_default=True,
    help="Random seed (gusts, noise, turns).",
)
@click.option(
    "--out", type=click.Path(dir_okay=False, path_type=Path), required=True, help="CSV to write."
)
@json_option
def flight_command(
    tail: str, x_h_mm: float, duration_s: float, seed: int, out: Path, as_json: bool
) -> None:
    """Fly elevator doublets with a study tail and write the 512 Hz flight log as CSV."""
    from ornitail.sim.configuration import study_configuration
    from ornitail.sim.dynamics import TrimNotFoundError
    from ornitail.sim.effects import EffectSet
    from ornitail.sim.free_flight import FlightPlan, simulate_flight, write_flight_log_csv

    if not (math.isfinite(duration_s) and 1.0 <= duration_s <= 3600.0):
        raise UserInputError("--duration-s", f"value {duration_s!r} is outside 1..3600 s")
    configuration = study_configuration(tail, x_h_mm)
    prepare_output_file(out)
    try:
        log = simulate_flight(
            configuration, EffectSet(), FlightPlan(duration_s=duration_s), seed=seed
        )
    except TrimNotFoundError as error:
        raise UserInputError(f"--tail {tail}", str(error)) from error
    write_flight_log_csv(log, out)
    result = {"path": str(out), "rows": len(log), "columns": list(log.columns), "seed": seed}
    emit(result, as_json, lambda r: f"wrote {r['rows']} rows to {r['path']}")


TUNNEL_POINT_RANGES = {
    "--theta-deg": (-90.0, 90.0, "deg"),
    "--v-m-s": (0.0, 10.0, "m/s"),
    "--f-hz": (0.0, 30.0, "Hz"),
    "--day": (0, 10_000, "days"),
}
"""Accepted operating points of ``sim tunnel``: pitch, tunnel speed, flapping frequency, day of the drift."""


def _check_tunnel_point(**values: float) -> None:
    for option, value in values.items():
        low, high, unit = TUNNEL_POINT_RANGES[option]
        if not (math.isfinite(value) and low <= value <= high):
            raise UserInputError(option, f"value {value!r} is outside {low:g}..{high:g} {unit}")


def _render_tunnel_truth(result: dict[str, Any]) -> str:
    point = result["operating_point"]
    state = "with tail" if result["tail_attached"] else "tailless"
    loads = result["loads"]
    transform = ", ".join(f"{value:g}" for value in result["reference_point_tool_transform_mm_deg"])
    lines = [
        f"{result['configuration']} {state} at theta {point['theta_deg']:.2f} deg, V {point['v_m_s']:.3f} m/s, "
        f"f {point['f_hz']:.2f} Hz: the simulator's truth",
        f"({result['effects']}), about the rig's reference point (tool transform [{transform}] mm, deg),",
        f"{result['frame']}:",
        f"  X {loads['x_n']:+.5f} N   Z {loads['z_n']:+.5f} N   M {loads['m_n_m']:+.6f} N m",
        "derivatives:",
    ]
    lines += [
        f"  {name:3s} {entry['value']:+.4e} {entry['unit']}"
        for name, entry in result["derivatives"].items()
    ]
    return "\n".join(lines)


@sim_group.command("tunnel")
@click.option("--tail", required=True, help="Study tail name, e.g. S3, AR1, T2.")
@click.option(
    "--x-h-mm", type=float, default=98.0, show_default=True, help="Tail position x_h in mm."
)
@click.option("--theta-deg", type=float, required=True, help="Pitch angle theta, degrees.")
@click.option("--v-m-s", type=float, required=True, help="Tunnel speed V, m/s.")
@click.option("--f-hz", type=float, required=True, help="Flapping frequency f, Hz.")
@click.option("--tailless", is_flag=True, help="The vehicle with its tail removed.")
@click.option(
    "--day",
    type=int,
    default=0,
    show_default=True,
    help="Day of the day-to-day drift effect (the simulated rig flies day 0).",
)
@click.option(
    "--rig",
    "rig_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Rig file whose tool transform sets the reference point [default: the simulated rig].",
)
@json_option
def tunnel_command(
    tail: str,
    x_h_mm: float,
    theta_deg: float,
    v_m_s: float,
    f_hz: float,
    tailless: bool,
    day: int,
    rig_path: Path | None,
    as_json: bool,
) -> None:
    """The simulator's truth at a tunnel point: the cycle-averaged loads about the rig's reference point and the
    tunnel derivatives that `ornitail process` estimates (effects on the air and the vehicle, none of the
    sensor's). Compare them with a processed sweep of the simulated rig."""
    from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, read_rig_file
    from ornitail.sim.configuration import study_configuration
    from ornitail.sim.effects import EffectSet
    from ornitail.sim.tunnel_truth import tunnel_truth

    _check_tunnel_point(
        **{"--theta-deg": theta_deg, "--v-m-s": v_m_s, "--f-hz": f_hz, "--day": day}
    )
    configuration = study_configuration(tail, x_h_mm)
    rig = read_rig_file(rig_path or DEFAULT_RIG_FILE)
    truth = tunnel_truth(
        configuration,
        math.radians(theta_deg),
        v_m_s,
        f_hz,
        tail_attached=not tailless,
        effects=EffectSet().replace_effect("day_to_day_drift", day=day),
        reference_transform=rig.tool_transform,
    )
    emit(truth.to_json_dict(), as_json, _render_tunnel_truth)
