"""``ornitail design trends``: fit trends from the chosen sources, print them, optionally predict a geometry."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.app.trend_source_options import trend_source_options
from ornitail.core.errors import UserInputError, require_finite
from ornitail.core.input_files import prepare_output_directory
from ornitail.core.output import to_jsonable
from ornitail.design.trend_sources import gather_observations
from ornitail.design.trends import fit_trends
from ornitail.vehicle.constants import TAIL_POSITION_RANGE_MM
from ornitail.vehicle.geometry import TailGeometry

_PREDICT_OPTIONS = ("predict_b", "predict_b_le", "predict_c_r", "predict_c_t", "predict_x_h_mm")


def _prediction_vector(options: dict[str, float | None]) -> tuple[float, ...] | None:
    given = {name: options[name] for name in _PREDICT_OPTIONS if options[name] is not None}
    if not given:
        return None
    missing = [f"--{name.replace('_', '-')}" for name in _PREDICT_OPTIONS if name not in given]
    if missing:
        raise UserInputError("--predict-*", f"a prediction needs {', '.join(missing)} too")
    for name, value in given.items():
        require_finite(f"--{name.replace('_', '-')}", value)
    x_h_low, x_h_high = TAIL_POSITION_RANGE_MM
    if not x_h_low <= given["predict_x_h_mm"] <= x_h_high:
        raise UserInputError(
            "--predict-x-h-mm",
            f"{given['predict_x_h_mm']:g} mm is outside {x_h_low:g}-{x_h_high:g} mm",
        )
    TailGeometry.from_mm(
        given["predict_b"], given["predict_b_le"], given["predict_c_r"], given["predict_c_t"]
    ).validate("--predict-b/--predict-b-le/--predict-c-r/--predict-c-t")
    return tuple(given[name] / 1000.0 for name in _PREDICT_OPTIONS)


def _at_the_edge(name: str) -> tuple[str, float]:
    """A quantity's name and factor as the text shows it: angles in degrees (``theta_ss_rad`` -> ``theta_ss_deg``)."""
    if name.endswith("_rad"):
        return name[: -len("_rad")] + "_deg", math.degrees(1.0)
    return name, 1.0


def _render(result: dict[str, Any]) -> str:
    lines = []
    for quantity, trend in result["trends"].items():
        name, scale = _at_the_edge(quantity)
        coefficients = "  ".join(
            f"{feature} {item['value'] * scale:+.4g}+-{item['sigma'] * scale:.2g}"
            for feature, item in trend["coefficients"].items()
            if feature not in trend["fixed_features"]  # not fitted: said on its own line
        )
        lines.append(
            f"{name:13s} {trend['weighting'].upper()} n={trend['observation_count']} "
            f"dof={trend['degrees_of_freedom']} residual sigma {trend['residual_sigma'] * scale:.3g} "
            f"LOO RMSE {trend['loo_rmse'] * scale:.3g}  [{', '.join(trend['sources'])}]"
        )
        lines.append(f"{'':13s} {coefficients}")
        if trend["fixed_features"]:
            fixed = ", ".join(f"{k} = {v:.4g}" for k, v in trend["fixed_features"].items())
            lines.append(f"{'':13s} constant in the data, not fitted: {fixed}")
    for name, reason in result["unfitted"].items():
        lines.append(f"{name:13s} not fitted: {reason}")
    if result.get("prediction"):
        lines.append("prediction (value, 1 sigma mean trend, 1 sigma new flight, extrapolation):")
        for quantity, item in result["prediction"]["quantities"].items():
            name, scale = _at_the_edge(quantity)
            lines.append(
                f"  {name:13s} {item['value'] * scale:+.5g}  +-{item['sigma_mean'] * scale:.3g}"
                f"  +-{item['sigma_new'] * scale:.3g}"
                f"  Mahalanobis {item['extrapolation_mahalanobis']:.2f}  {item['extrapolation_note']}"
            )
    lines += [f"wrote {path}" for path in result["written"]]
    return "\n".join(lines)


@click.command("trends")
@trend_source_options
@click.option("--predict-b", type=float, help="Span b (mm) of a geometry to predict.")
@click.option("--predict-b-le", type=float, help="Leading-edge span b_LE (mm).")
@click.option("--predict-c-r", type=float, help="Root chord c_r (mm).")
@click.option("--predict-c-t", type=float, help="Tip chord c_t (mm).")
@click.option("--predict-x-h-mm", type=float, help="Tail position x_h (mm).")
@click.option(
    "--out", "out_dir", type=click.Path(file_okay=False), help="Write trends.json and plots."
)
@json_option
def trends_command(
    study: bool,
    campaigns: tuple[str, ...],
    tunnels: tuple[str, ...],
    user_csvs: tuple[str, ...],
    basis: str,
    out_dir: str | None,
    as_json: bool,
    **predict_options: float | None,
) -> None:
    """Fit steady state and derivatives against tail geometry and x_h; print coefficients, LOO RMSE,
    sources and, with --predict-*, a prediction with both intervals and its extrapolation measure."""
    if not (study or campaigns or tunnels or user_csvs):
        raise UserInputError(
            "sources", "give at least one of --study, --campaign, --tunnel, --user-csv"
        )
    vector = _prediction_vector(predict_options)
    if out_dir is not None:
        prepare_output_directory(out_dir)
    observations = gather_observations(study, campaigns, tunnels, user_csvs)
    model = fit_trends(observations, basis=basis)
    result: dict[str, Any] = {
        "basis": basis,
        "trends": {name: trend.summary() for name, trend in model.trends.items()},
        "unfitted": dict(model.unfitted),
        "prediction": None,
        "written": [],
    }
    if vector is not None:
        result["prediction"] = {
            "geometry_m": dict(zip(("b", "b_le", "c_r", "c_t", "x_h"), vector, strict=True)),
            "quantities": {
                name: prediction.as_dict() for name, prediction in model.predict(vector).items()
            },
        }
    if out_dir is not None:
        from ornitail.design.trends_plots import write_trend_picture

        directory = Path(out_dir)
        directory.mkdir(parents=True, exist_ok=True)
        table = directory / "trends.json"
        written = [table]
        for trend in model.trends.values():
            written += write_trend_picture(trend, observations, directory)
        result["written"] = [str(path) for path in written]
        table.write_text(json.dumps(to_jsonable(result), indent=2) + "\n", encoding="utf-8")
    emit(result, as_json, _render)
