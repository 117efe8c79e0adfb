"""Process recorded tunnel runs into the tables and figures of ``ornitail process`` (docs/processed-tables.md).

Per run set: the cycle-averaged table (all points). Per configuration (tail id and x_h) in it: the tail
contribution with plain statements, the stability derivatives (CSV and JSON) and three figures (PNG and PDF).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ornitail.acquisition.calibration_copies import CalibrationSources
from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.sweep import previous_sweep_chain
from ornitail.balance.condition_correction import at_reference_conditions
from ornitail.balance.derivatives import StabilityDerivatives, fit_stability_derivatives
from ornitail.balance.phase_loads import (
    PhaseAveragedLoads,
    phase_average_table,
    phase_averaged_loads,
)
from ornitail.balance.processing_plots import (
    phase_average_figure,
    save_figure,
    sweep_fit_figure,
    tail_comparison_figure,
)
from ornitail.balance.sweep_table import (
    SATURATION_COLUMNS,
    MeasuredSetPoint,
    frequency_check_warnings,
    measured_set_points,
    saturation_warnings,
    table_of_points,
    tail_contribution,
)
from ornitail.balance.tail_statement import (
    repeatability_statement,
    tail_contribution_statements,
)
from ornitail.balance.tare_drift import drift_statement
from ornitail.core.errors import UserInputError

CYCLE_AVERAGES_FILE = "cycle-averages.csv"


@dataclass(frozen=True)
class _PlanIdentity:
    """What :func:`previous_sweep_chain` needs of a plan: its name, tail and x_h (m)."""

    name: str
    tail_id: str | None
    x_h_m: float | None


def newest_sweep_chain(data_root: Path, plan_name: str) -> list[Path]:
    """Run directories of the newest sweep of the plan called ``plan_name`` in the catalog, oldest first."""
    catalog = RunCatalog(Path(data_root))
    runs = [run for run in catalog.runs_reconciled()[0] if run.plan_name == plan_name]
    if not runs:
        raise UserInputError(
            "plan_name", f"no runs of plan {plan_name!r} in the catalog of {Path(data_root)}"
        )
    newest = max(runs, key=lambda run: run.start_time_utc)
    return previous_sweep_chain(
        catalog,
        _PlanIdentity(plan_name, newest.tail_id, newest.x_h_m),  # type: ignore[arg-type]
    )


def json_safe(value: Any) -> Any:
    """``value`` with numpy scalars and arrays made plain and NaN or infinity made ``None`` (strict JSON)."""
    if isinstance(value, dict):
        return {str(key): json_safe(item) for key, item in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [json_safe(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def configuration_slug(tail_id: str, x_h_mm: float) -> str:
    """File-name-safe configuration name, e.g. ``S3-xh98mm``."""
    tail = re.sub(r"[^A-Za-z0-9_-]+", "_", tail_id or "tail")
    return f"{tail}-xh{x_h_mm:g}mm" if math.isfinite(x_h_mm) else tail


def _steady_state_phase_average(
    points: list[MeasuredSetPoint], tailed: bool
) -> PhaseAveragedLoads | None:
    for point in points:
        if point.row.get("sweep") == "steady_state" and bool(point.row["tail_attached"]) == tailed:
            gauge_volts, hall_v = point.gauge_and_hall_volts()
            return phase_averaged_loads(
                gauge_volts,
                hall_v,
                point.recording.sample_rate_hz,
                point.tare_volts,
                point.calibration,
            )
    return None


def _process_configuration(
    table: pd.DataFrame, points: list[MeasuredSetPoint], slug: str, name: str, out: Path
) -> dict[str, Any]:
    written: list[Path] = []
    record: dict[str, Any] = {"configuration": name}
    fit: StabilityDerivatives | None = None
    if table["tailed"].astype(bool).any():
        fit = fit_stability_derivatives(table, configuration=name)
    contribution = tail_contribution(at_reference_conditions(table, fit))
    if "drift_model" in table:
        record["drift_statement"] = " ".join(
            part
            for part in (
                drift_statement(
                    table["drift_model"].astype(str).tolist(),
                    table.get("drift_check", pd.Series(dtype=str)).astype(str).tolist(),
                ),
                repeatability_statement(contribution),
            )
            if part
        )
    if len(contribution):
        path = out / f"{slug}-tail-contribution.csv"
        contribution.to_csv(path, index=False)
        written.append(path)
        record["tail_contribution"] = contribution.to_dict(orient="records")
        record["tail_statements"] = tail_contribution_statements(contribution)
    if fit is not None:
        csv_path, json_path = out / f"{slug}-derivatives.csv", out / f"{slug}-derivatives.json"
        fit.table().to_csv(csv_path, index=False)
        json_path.write_text(json.dumps(json_safe(fit.to_json_dict()), indent=2) + "\n")
        written += [csv_path, json_path]
        record["derivatives"] = fit.to_json_dict()
    tailed_phase = _steady_state_phase_average(points, tailed=True)
    tailless_phase = _steady_state_phase_average(points, tailed=False)
    phase_table = phase_average_table({True: tailed_phase, False: tailless_phase})
    if len(phase_table):
        path = out / f"{slug}-phase-average.csv"
        phase_table.to_csv(path, index=False)
        written.append(path)
    if tailed_phase is not None and fit is not None:
        steady = fit.steady_state
        where = (
            f"steady state theta {math.degrees(steady.theta_rad):.1f} deg, V {steady.v_m_s:.2f} m/s, "
            f"f {steady.f_hz:.2f} Hz (first repeat)"
        )
        written += save_figure(
            phase_average_figure(tailed_phase, tailless_phase, name, where),
            out / f"{slug}-phase-average",
        )
        written += save_figure(sweep_fit_figure(table, fit), out / f"{slug}-sweep-fits")
    if len(contribution):
        written += save_figure(
            tail_comparison_figure(table, contribution, name), out / f"{slug}-tailed-vs-tailless"
        )
    flagged = int((table[list(SATURATION_COLUMNS)] > 0).any(axis=1).sum())
    if flagged:
        record.setdefault("tail_statements", []).append(
            f"FLAGGED: {flagged} set point(s) of {name} were kept, on request, with saturated or over-range "
            "samples; their loads, and the contribution and derivatives computed from them, are clipped, not "
            "measured."
        )
    record["written"] = [str(path) for path in written]
    return record


def process_runs(
    run_directories: Sequence[Path | str],
    out: Path,
    on_progress: Callable[[int, int], None] | None = None,
    keep_saturated: bool = False,
    calibration_sources: CalibrationSources | None = None,
) -> dict[str, Any]:
    """Write every table and figure of ``ornitail process`` for these runs into ``out``; return the summary.

    Records with saturated or over-range samples are refused unless ``keep_saturated``; then they are processed,
    flagged in the table's saturation columns and named in ``warnings``. Each run's balance calibration file is
    found by its recorded content hash (run folder copy, recorded path, then ``calibration_sources.search_path``)
    unless ``calibration_sources.overrides["balance"]`` names the file to use; an override with other content is
    used and named in ``warnings``.

    Returns
    -------
    dict
        ``runs``, ``table_csv``, ``calibration_files`` (run id -> ``{path, source}`` of the balance calibration
        used), ``warnings`` (overridden calibration, saturation, frequency cross-check), ``configurations`` (one
        record each: ``derivatives`` with sigma, ``tail_contribution``, ``tail_statements``, ``written``),
        ``written``.

    Raises
    ------
    UserInputError
        If no runs are given, a directory is not a recording, a measurement has no tare, no file with the
        recorded balance calibration's content is found, a record lost samples or (unless ``keep_saturated``)
        has saturated or over-range samples, or a record holds too few flapping cycles.
    """
    if not run_directories:
        raise UserInputError(
            "runs",
            "no run directories given (name run directories or a plan whose newest sweep to take)",
        )
    points = measured_set_points(run_directories, keep_saturated, calibration_sources)
    if not points:
        raise UserInputError(
            ", ".join(str(path) for path in run_directories), "the runs hold no measured set points"
        )
    table = table_of_points(points, on_progress)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    table_path = out / CYCLE_AVERAGES_FILE
    table.to_csv(table_path, index=False)
    calibration_files = {
        point.recording.run_id: point.calibration_file
        for point in points
        if point.calibration_file is not None
    }
    result: dict[str, Any] = {
        "runs": [str(path) for path in run_directories],
        "table_csv": str(table_path),
        "calibration_files": {
            run_id: {"path": str(resolved.path), "source": resolved.source}
            for run_id, resolved in calibration_files.items()
        },
        "warnings": [
            resolved.warning for resolved in calibration_files.values() if resolved.warning
        ]
        + saturation_warnings(table)
        + frequency_check_warnings(table),
        "configurations": [],
    }
    written = [str(table_path)]
    for (tail_id, x_h_mm), group in table.groupby(["tail_id", "x_h_mm"], dropna=False):
        slug = configuration_slug(str(tail_id), float(x_h_mm))
        name = f"{tail_id} x_h={float(x_h_mm):g}mm"
        run_ids = set(group["run_id"])
        configuration_points = [point for point in points if point.recording.run_id in run_ids]
        record = _process_configuration(
            group.reset_index(drop=True), configuration_points, slug, name, out
        )
        result["configurations"].append(record)
        written += record["written"]
    result["written"] = written
    return result
