"""The campaign's table of representative models (CSV and JSON; format: docs/flight-campaign.md).

One row per configuration: tail and position, planform area and aspect ratio, mass properties, the
steady state (means over the manoeuvres' run-ins), the representative model's derivatives with
standard errors, its poles, the damping ratio and natural frequency of the oscillatory mode, which
averaged model won and by which rule (with every averaged model's win counts and mean scores on
the validation manoeuvres), the glitch rule and input hold used, and the manoeuvre counts. SI
units and radians (docs/frames.md), with the steady-state pitch also in degrees for reading.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ornitail.flight.campaign import ConfigurationResult

TABLE_FORMAT_VERSION = 1


def _oscillatory(result: ConfigurationResult) -> dict[str, float]:
    for estimate in result.representative_modes:
        if estimate.mode.oscillatory:
            return {
                "damping_ratio": estimate.mode.damping_ratio,
                "damping_ratio_sigma": estimate.sigma_damping_ratio,
                "natural_frequency_rad_s": estimate.mode.natural_frequency_rad_s,
                "natural_frequency_sigma_rad_s": estimate.sigma_natural_frequency_rad_s,
            }
    return {
        "damping_ratio": math.nan,
        "damping_ratio_sigma": math.nan,
        "natural_frequency_rad_s": math.nan,
        "natural_frequency_sigma_rad_s": math.nan,
    }


def representative_record(result: ConfigurationResult) -> dict[str, Any]:
    """The JSON record of one configuration (nested: derivatives, poles, scores, reference)."""
    configuration, steady = result.configuration, result.steady_state
    representative = result.representative
    derivatives = {
        name: {
            "value": float(value),
            "sigma": float(sigma),
            "unit": result.spec.parameter(name).unit,
        }
        for name, value, sigma in zip(
            representative.parameter_names,
            representative.estimate.values,
            representative.estimate.sigmas,
            strict=True,
        )
    }
    merge = next(model.merge for model in result.averaged if model.merge is not None)
    record: dict[str, Any] = {
        "configuration": configuration.label,
        "tail": configuration.tail,
        "x_h_m": configuration.x_h_m,
        "area_m2": configuration.area_m2,
        "aspect_ratio": configuration.aspect_ratio,
        "mass_kg": result.mass.mass_kg,
        "iyy_kg_m2": result.mass.iyy_kg_m2,
        "theta0_rad": steady.theta_rad,
        "theta0_deg": math.degrees(steady.theta_rad),
        "airspeed_m_s": steady.airspeed_m_s,
        "u0_m_s": steady.u_m_s,
        "w0_m_s": steady.w_m_s,
        "flapping_frequency_hz": steady.flapping_frequency_hz,
        "model": result.spec.name,
        "nuisance_parameters": [
            name
            for name in result.spec.free_parameter_names
            if name not in result.spec.derivative_names
        ],
        "representative_model": representative.name,
        "selection_rule": result.selection_rule,
        "glitch_rule": result.glitch_rule,
        "input_hold": result.spec.input_hold,
        "colored_sigma": result.colored_sigma,
        "derivatives": derivatives,
        "poles": [
            [float(value.real), float(value.imag)] for value in result.representative_eigenvalues
        ],
        **_oscillatory(result),
        "scores": dict(result.scores),
        "mean_pcc": result.validation_scores.mean_pcc(),
        "wins": {
            name: {**counts, "total": counts["rms"] + counts["pcc"]}
            for name, counts in result.validation_scores.wins().items()
        },
        "merge_chi_square": merge.chi_square,
        "merge_degrees_of_freedom": merge.degrees_of_freedom,
        "merge_p_value": merge.p_value,
        "manoeuvres": result.manoeuvre_count,
        "diverged": len(result.diverged),
        "elevator_glitches_removed": result.glitches_removed,
        "rejected": result.rejected_count,
        "accepted": int(result.accepted.size),
        "training": int(result.training.size),
        "validation": int(result.validation.size),
    }
    reference = result.simulator_reference
    if reference is not None:
        record["simulator_reference"] = {
            "derivatives": dict(reference.derivatives),
            "poles": [[float(v.real), float(v.imag)] for v in reference.eigenvalues()],
            "damping_ratio": reference.oscillatory_damping_ratio(),
            "natural_frequency_rad_s": reference.oscillatory_natural_frequency_rad_s(),
            "theta0_rad": reference.trim.theta_rad,
            "airspeed_m_s": reference.trim.airspeed_m_s,
            "flapping_frequency_hz": reference.trim.flapping_frequency_hz,
        }
    return record


def flat_row(record: dict[str, Any]) -> dict[str, Any]:
    """One CSV row from a JSON record: derivatives as NAME and NAME_sigma, poles as
    pole<i>_real_1_s / pole<i>_imag_1_s, scores as score_<model>, mean PCC as mean_pcc_<model>,
    wins as wins_<model> (total), wins_rms_<model> and wins_pcc_<model>, reference as
    sim_<field>, the nuisance parameters' names separated by spaces.
    """
    nested = ("derivatives", "poles", "scores", "mean_pcc", "wins", "simulator_reference")
    row = {key: value for key, value in record.items() if key not in nested}
    row["nuisance_parameters"] = " ".join(record["nuisance_parameters"])
    for name, estimate in record["derivatives"].items():
        row[name] = estimate["value"]
        row[f"{name}_sigma"] = estimate["sigma"]
    for index, (real, imag) in enumerate(record["poles"], start=1):
        row[f"pole{index}_real_1_s"] = real
        row[f"pole{index}_imag_1_s"] = imag
    for name, score in record["scores"].items():
        row[f"score_{name}"] = score
    for name, pcc in record["mean_pcc"].items():
        row[f"mean_pcc_{name}"] = pcc
    for name, counts in record["wins"].items():
        row[f"wins_{name}"] = counts["total"]
        row[f"wins_rms_{name}"] = counts["rms"]
        row[f"wins_pcc_{name}"] = counts["pcc"]
    reference = record.get("simulator_reference")
    if reference is not None:
        row["sim_damping_ratio"] = reference["damping_ratio"]
        row["sim_natural_frequency_rad_s"] = reference["natural_frequency_rad_s"]
    return row


def write_campaign_table(
    results: list[ConfigurationResult], directory: Path, campaign_info: dict[str, Any]
) -> tuple[Path, Path, list[dict[str, Any]]]:
    """Write ``representative_models.csv`` and ``representative_models.json`` into
    ``directory``; return both paths and the JSON records.
    """
    directory.mkdir(parents=True, exist_ok=True)
    records = [representative_record(result) for result in results]
    rows = [flat_row(record) for record in records]
    columns: list[str] = []
    for row in rows:
        columns += [key for key in row if key not in columns]
    csv_path = directory / "representative_models.csv"
    with csv_path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({key: _csv_value(row.get(key)) for key in columns})
    json_path = directory / "representative_models.json"
    document = {
        "format": "ornitail flight campaign",
        "version": TABLE_FORMAT_VERSION,
        **campaign_info,
        "configurations": records,
    }
    json_path.write_text(json.dumps(_json_ready(document), indent=2) + "\n", encoding="utf-8")
    return csv_path, json_path, records


def _json_ready(value: Any) -> Any:
    """Plain JSON types; non-finite floats become null (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(key): _json_ready(item) for key, item in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_json_ready(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _csv_value(value: Any) -> Any:
    if value is None:
        return ""
    if isinstance(value, float | np.floating):
        return "" if not math.isfinite(float(value)) else repr(float(value))
    return value
