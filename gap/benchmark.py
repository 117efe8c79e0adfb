"""``ornitail gap benchmark``: diagnose flights whose withheld effects are known, and score it.

Each case draws a study tail, a tail position, a noise scale (x the simulator's sensor noise and
gusts) and the magnitudes of its withheld effects from :data:`MAGNITUDE_RANGES`; flies it in the
simulator with those effects (:mod:`ornitail.gap.withheld_effects`); writes the log and the
baseline file; and diagnoses the files blind. Case kinds repeat in the order of :data:`KINDS`
(no effect, each single effect, two pairs). Everything derives from one seed.

Scores: top-1 = an effect is reported and the reported set holds a true effect; top-3 = every true
effect is in the reported set, the second effect's set or the first three of the ranking; false alarm = a no-effect case
not reported as ``none``; magnitude error |k - k_true| / |k_true| of the true effect's fitted
magnitude (single-effect cases named correctly); closure achieved by the reported effect (test
runs, and validation runs) next to the validation closure the true effect's candidate achieved;
for every named effect, its closure on a fresh flight of the same case (another noise and gust
seed) against the reported closure and its interval; confusion matrix of single-effect and
no-effect cases (true kind by reported name, ``none`` or ``unexplained``).
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ornitail.gap.flight_data import read_flight_runs
from ornitail.gap.flight_diagnosis import FlightDiagnosis, diagnose_flight, residuals_of
from ornitail.gap.model_spec import read_baseline_spec, write_baseline_spec
from ornitail.gap.withheld_effects import WithheldCase, simulate_withheld_log, true_magnitudes
from ornitail.sim.free_flight import write_flight_log_csv

KINDS: tuple[tuple[str, ...], ...] = (
    (),
    ("added_mass",),
    ("wake_profile",),
    ("cg_shift_with_x_h",),
    ("pitch_damping",),
    ("input_delay",),
    ("theta_drift",),
    (),
    ("added_mass", "input_delay"),
    ("pitch_damping", "theta_drift"),
)
MAGNITUDE_RANGES = {
    "added_mass": (1.5, 4.0),  # x flat-plate added inertia (the simulator's default is 1)
    "wake_profile": (1.0, 1.0),  # on, default shape
    "cg_shift_with_x_h": (1.0, 1.0),  # on; x_h drawn away from its 98 mm reference
    "pitch_damping": (0.3, 1.0),  # wing pitch-damping coefficient x (1 + factor)
    "input_delay": (0.04, 0.10),  # s
    "theta_drift": (0.005, 0.015),  # rad/s (0.3-0.9 deg/s)
}
TAILS = ("S1", "S2", "S3", "S4", "S5", "AR2", "AR4", "AR5", "AR6")
X_H_RANGE_MM = (60.0, 126.0)
CG_SHIFT_X_H_MM = ((57.0, 75.0), (115.0, 126.0))
NOISE_RANGE = (0.5, 1.5)


def draw_case(index: int, seed: int, manoeuvres: int) -> WithheldCase:
    """The ``index``-th case of a benchmark seeded with ``seed``."""
    generator = np.random.default_rng([seed, index])
    kind = KINDS[index % len(KINDS)]
    tail = str(generator.choice(TAILS))
    if "cg_shift_with_x_h" in kind:
        low, high = CG_SHIFT_X_H_MM[int(generator.integers(2))]
        x_h_mm = float(generator.uniform(low, high))
    else:
        x_h_mm = float(generator.uniform(*X_H_RANGE_MM))
    effects = {name: float(generator.uniform(*MAGNITUDE_RANGES[name])) for name in kind}
    return WithheldCase(
        tail=tail,
        x_h_mm=round(x_h_mm, 1),
        effects=effects,
        manoeuvres=manoeuvres,
        noise_scale=float(generator.uniform(*NOISE_RANGE)),
        seed=int(generator.integers(2**31)),
    )


def fresh_flight_closure(case: WithheldCase, diagnosis: FlightDiagnosis, folder: Path) -> float:
    """Closure of the diagnosis' chosen model on a fresh flight of the same case (another noise and
    gust seed), with the diagnosis' own channel weights: what a user would see on new data."""
    fresh = dataclasses.replace(case, seed=case.seed + 1)
    path = write_flight_log_csv(simulate_withheld_log(fresh), folder / "fresh-flight.csv")
    runs = read_flight_runs([path])

    def energy(model) -> float:
        return float(sum(np.sum((r / diagnosis.weights) ** 2) for r in residuals_of(model, runs)))

    return 1.0 - float(np.sqrt(energy(diagnosis.chosen) / energy(diagnosis.baseline)))


def run_case(case: WithheldCase, folder: Path, seed: int, **design: str) -> dict[str, object]:
    """Fly, write, diagnose blind, and score one case (and, when an effect is named, its closure
    on a fresh flight of the same case against the reported intervals); ``design``: baseline-file
    keys to set (``validation``, ``null_directions``)."""
    log_path = write_flight_log_csv(simulate_withheld_log(case), folder / "flight.csv")
    spec = dataclasses.replace(case.baseline_spec(), **design)
    spec_path = write_baseline_spec(spec, folder / "baseline.toml")
    diagnosis = diagnose_flight(read_baseline_spec(spec_path), [log_path], seed=seed)
    report = diagnosis.report
    truth = true_magnitudes(case)
    ranking = report["ranking"]
    names = [entry["name"] for entry in ranking]
    reported = set(report["indistinguishable_set"]) if report["verdict"] == "effect" else set()
    second = report.get("second_effect") or {}
    first_three = (
        reported | set(names[:3]) | set(second.get("indistinguishable_set", []))
        if report["verdict"] == "effect"
        else set()
    )
    by_name = {entry["name"]: entry for entry in ranking}
    result: dict[str, object] = {
        "tail": case.tail,
        "x_h_mm": case.x_h_mm,
        "noise_scale": case.noise_scale,
        "true_effects": dict(truth),
        "verdict": report["verdict"],
        "reported": report["effect"],
        "reported_set": sorted(reported),
        "second_effect": second.get("effect"),
        "top1": bool(truth) and bool(reported & set(truth)),
        "top3": bool(truth) and set(truth) <= first_three,
        "closure_reported": report["closure"]["realised_test"],
        "closure_reported_validation": report["closure"]["realised_validation"],
        "detection_threshold": report["detection_rule"]["threshold"],
        "gap_before": report["gap_before"]["total"],
        "gap_after": report["gap_after"]["total"],
    }
    if report["verdict"] == "effect":
        low, high = report["closure"]["interval"]
        fresh_low, fresh_high = report["closure"]["fresh_data_interval"]
        fresh = fresh_flight_closure(case, diagnosis, folder)
        result["closure_interval"] = [low, high]
        result["closure_fresh_data_interval"] = [fresh_low, fresh_high]
        result["closure_fresh_flight"] = fresh
        result["fresh_within_interval"] = bool(low <= fresh <= high)
        result["fresh_within_prediction_interval"] = bool(fresh_low <= fresh <= fresh_high)
    if len(truth) == 1:
        ((name, magnitude),) = truth.items()
        entry = by_name.get(name)
        result["closure_true_effect"] = entry["validation_closure"] if entry else None
        if entry and result["top1"] and magnitude != 0:
            result["magnitude_error"] = abs(entry["magnitude"] - magnitude) / abs(magnitude)
    return result


def _label(result: dict[str, object]) -> str:
    if result["verdict"] != "effect":
        return str(result["verdict"])
    truth = set(result["true_effects"])
    shared = truth & set(result["reported_set"])
    return sorted(shared)[0] if shared else str(result["reported"])


def summarise(results: list[dict[str, object]]) -> dict[str, object]:
    """Accuracy, false alarms, confusion matrix, magnitude error and closure over ``results``."""
    effect_cases = [r for r in results if r["true_effects"]]
    none_cases = [r for r in results if not r["true_effects"]]
    singles = [r for r in results if len(r["true_effects"]) <= 1]
    truths = sorted(
        {(next(iter(r["true_effects"])) if r["true_effects"] else "none") for r in singles}
    )
    columns = sorted({_label(r) for r in singles} | set(truths))
    matrix = {truth: dict.fromkeys(columns, 0) for truth in truths}
    for result in singles:
        truth = next(iter(result["true_effects"])) if result["true_effects"] else "none"
        matrix[truth][_label(result)] += 1
    errors = [r["magnitude_error"] for r in results if "magnitude_error" in r]
    paired = [
        (r["closure_reported"], r["closure_true_effect"], r["closure_reported_validation"])
        for r in results
        if r.get("closure_true_effect") is not None and r["verdict"] == "effect"
    ]
    named = [r for r in results if "closure_fresh_flight" in r]
    return {
        "cases": len(results),
        "effect_cases": len(effect_cases),
        "no_effect_cases": len(none_cases),
        "top1_accuracy": float(np.mean([r["top1"] for r in effect_cases]))
        if effect_cases
        else None,
        "top3_accuracy": float(np.mean([r["top3"] for r in effect_cases]))
        if effect_cases
        else None,
        "false_alarm_rate": float(np.mean([r["verdict"] != "none" for r in none_cases]))
        if none_cases
        else None,
        "mean_reported_set_size": float(
            np.mean([len(r["reported_set"]) for r in effect_cases if r["reported_set"]] or [0])
        ),
        "magnitude_error_median": float(np.median(errors)) if errors else None,
        "magnitude_error_90th_percentile": float(np.quantile(errors, 0.9)) if errors else None,
        "closure_reported_median": float(np.median([p[0] for p in paired])) if paired else None,
        "closure_reported_validation_median": float(np.median([p[2] for p in paired]))
        if paired
        else None,
        "closure_true_effect_median": float(np.median([p[1] for p in paired])) if paired else None,
        "fresh_flight_within_interval": float(np.mean([r["fresh_within_interval"] for r in named]))
        if named
        else None,
        "fresh_flight_within_prediction_interval": float(
            np.mean([r["fresh_within_prediction_interval"] for r in named])
        )
        if named
        else None,
        "fresh_flight_below_reported": float(
            np.mean([r["closure_fresh_flight"] < r["closure_reported"] for r in named])
        )
        if named
        else None,
        "closure_reported_minus_fresh_median": float(
            np.median([r["closure_reported"] - r["closure_fresh_flight"] for r in named])
        )
        if named
        else None,
        "confusion_matrix": {"rows_true": truths, "columns_reported": columns, "counts": matrix},
    }


def run_benchmark(
    cases: int,
    seed: int,
    manoeuvres: int = 20,
    progress: Callable[[int], None] | None = None,
) -> dict[str, object]:
    """Run ``cases`` cases (see the module docstring) and return per-case results and scores."""
    results = []
    for index in range(cases):
        case = draw_case(index, seed, manoeuvres)
        with tempfile.TemporaryDirectory(prefix="ornitail-gap-") as folder:
            results.append(run_case(case, Path(folder), seed))
        if progress is not None:
            progress(1)
    return {
        "format": "ornitail gap benchmark",
        "version": 1,
        "seed": seed,
        "manoeuvres_per_case": manoeuvres,
        "magnitude_ranges": {name: list(bounds) for name, bounds in MAGNITUDE_RANGES.items()},
        "scores": summarise(results),
        "results": results,
    }
