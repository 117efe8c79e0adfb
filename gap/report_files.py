"""Running a diagnosis on files and writing its report (JSON, text) and pictures to a folder."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.core.output import to_jsonable
from ornitail.gap.flight_diagnosis import FlightDiagnosis, diagnose_flight, residuals_of
from ornitail.gap.model_spec import read_baseline_spec
from ornitail.gap.plots import (
    derivative_refit_picture,
    flight_overlay_picture,
    localisation_picture,
    ranking_picture,
    residual_spectra_picture,
)
from ornitail.gap.report_text import render_report
from ornitail.gap.steady_data import is_steady_table
from ornitail.gap.steady_diagnosis import diagnose_steady
from ornitail.gap.tunnel_data import is_run_directory, is_tunnel_table
from ornitail.gap.tunnel_diagnosis import diagnose_tunnel


def _flight_pictures(diagnosis: FlightDiagnosis, folder: Path) -> list[str]:
    effect = diagnosis.report["best_candidate"]
    channels = diagnosis.baseline.output_names
    before = residuals_of(diagnosis.baseline, diagnosis.runs)
    written = residual_spectra_picture(
        [r / diagnosis.scales for r in before],
        [r / diagnosis.scales for r in diagnosis.after_residuals],
        diagnosis.runs[0].time_step_s,
        channels,
        effect,
        folder,
    )
    # The overlay shows the manoeuvre the baseline misses most (scaled residual energy), corrected with the
    # effect its own fold chose: the best candidate unless the folds disagree.
    worst = int(np.argmax([np.mean((r / diagnosis.scales) ** 2) for r in before]))
    run = diagnosis.runs[worst]
    choices = diagnosis.report.get("split", {}).get("test_choices") or {}
    written += flight_overlay_picture(
        run.time_s,
        run.outputs,
        run.outputs - before[worst],
        run.outputs - diagnosis.after_residuals[worst],
        run.label,
        "the effect its fold chose" if len(choices) > 1 else str(effect),
        folder,
        channels,
    )
    refit = diagnosis.report.get("derivative_refit")
    if refit and refit["derivatives"]:
        written += derivative_refit_picture(refit, folder)
    return written


def diagnose_files(
    model_path: Path,
    data_paths: Sequence[Path],
    seed: int,
    out: Path,
    pictures: bool = True,
    on_step: Callable[[int, int, str], None] | None = None,
) -> dict[str, object]:
    """Diagnose ``data_paths`` against the baseline file; write the report into ``out``. ``on_step(done, total,
    what)`` follows a flight diagnosis' steps (:func:`diagnose_flight`)."""
    spec = read_baseline_spec(model_path)
    for path in data_paths:
        if not Path(path).exists():
            raise UserInputError(str(path), "data file or run directory not found")
        if Path(path).is_dir() and not is_run_directory(Path(path)):
            raise UserInputError(
                str(path),
                "a folder but not a recorded run (no run.json); give each run directory itself",
            )
    tunnel = [is_tunnel_table(path) for path in data_paths]
    steady = [is_steady_table(path) for path in data_paths]
    if any(steady) and len(data_paths) > 1:
        raise UserInputError(
            "data_paths", "give one steady-state table alone (one row per configuration)"
        )
    if any(tunnel) and not all(tunnel):
        raise UserInputError("data_paths", "give either flight logs or tunnel tables, not both")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UserInputError(f"{out}", f"cannot create the folder: {error}") from None
    written: list[str] = []
    if any(steady):
        diagnosis = diagnose_steady(spec, data_paths[0], seed)
        report = diagnosis.report
        if pictures:
            written += diagnosis.pictures(out)
    elif all(tunnel):
        diagnosis = diagnose_tunnel(spec, data_paths, seed)
        report = diagnosis.report
        if pictures:
            written += diagnosis.pictures(out)
    else:
        flight = diagnose_flight(spec, data_paths, seed, on_step)
        report = flight.report
        if pictures:
            written += _flight_pictures(flight, out)
    if pictures:
        written += localisation_picture(report["where"], out)
        written += ranking_picture(report, out)
    json_path, text_path = out / "gap-report.json", out / "gap-report.txt"
    written = [str(json_path), str(text_path), *written]
    report["written"] = written
    json_path.write_text(json.dumps(to_jsonable(report), indent=1))
    text_path.write_text(render_report(report) + "\n")
    return report
