"""The gap diagnosis on three realities, scored part by part.

1. ``sim``: the simulator's own flights with withheld effects (``ornitail gap benchmark``'s cases,
   :mod:`ornitail.gap.benchmark`); every effect is in the library.
2. ``independent``: flapper B (benchmarks/independent_reality.py), a vehicle and physics the
   library was not written for, against its own linearisation; ``input_delay``,
   ``input_filter`` and ``added_mass`` are in the library, ``static_stability`` and
   ``frequency_sag`` are not.
3. ``semi_real``: NASA's Twin Otter record with an injected effect (benchmarks/semi_real.py),
   against the model identified on the untouched record; all injected effects are in the library.

Per part: false alarms (an effect named on a no-effect case; how many of them were a
derivative-level finding) and ``unexplained`` on no-effect cases; the named-in-library rate (the
reported set holds the library's name of the true effect) with the median magnitude error of
those, and each miss with its verdict and its best candidate's closure on test runs; for
out-of-library effects the rate of ``unexplained`` or a derivative-level candidate
(:mod:`ornitail.gap.derivative_candidates`: the nearest derivative change) rather than a wrong
measurement effect; and for named effects how often a fresh flight's closure
(another noise and gust seed; the diagnosis' model and channel weights) lies inside the reported
90 % interval (semi-real: one record, no fresh flight). The semi-real and independent cases also
run the derivative re-fit (docs/gap-diagnosis.md, Method step 7): how often its moves are supported
by the test runs, and its median closure there.

Each rate also gets its counts (``rate_counts``: [successes, cases]) and its 95 % Wilson score
interval (``rate_intervals_95``): with 4 effect-free flights a seed, one false alarm is 0.25 with an
interval of 0.05-0.70.

``python benchmarks/gap_realities.py [--sim-cases 10] [--independent-cases 12] [--seed 2018]
[--out result.json] [--validation first-fold] [--null-directions any]
[--validation-weighting winsorised]``

``python benchmarks/gap_realities.py --combine a.json b.json ... [--out pooled.json]`` pools the cases
of earlier results (each seed's part once: a seed run as two processes, one per part, writes its
semi-real part twice) and scores them as one. ``--figure scores.png`` (either mode) also draws the
rates against issue 15's targets (benchmarks/realities_figure.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import independent_reality
import numpy as np
import semi_real
from realities_figure import PARTS, save_realities_figure
from scipy import stats

from ornitail.core.output import to_jsonable
from ornitail.gap.benchmark import draw_case as draw_sim_case
from ornitail.gap.benchmark import run_case as run_sim_case
from ornitail.gap.derivative_candidates import DERIVATIVE_LEVEL_CANDIDATES
from ornitail.gap.detection import closure_of
from ornitail.gap.flight_diagnosis import (
    FlightDiagnosis,
    diagnose_flight,
    read_record,
    residuals_of,
)
from ornitail.gap.model_spec import (
    FLIGHT_NULL_DIRECTIONS,
    NULL_DIRECTIONS,
    VALIDATION_DESIGNS,
    VALIDATION_WEIGHTINGS,
    BaselineSpec,
    read_baseline_spec,
)

SEMI_REAL_CASES = (
    semi_real.InjectedCase(None),
    semi_real.InjectedCase("elevator_delay", 0.04),
    semi_real.InjectedCase("elevator_delay", 0.08),
    semi_real.InjectedCase("elevator_filter", 0.05),
    semi_real.InjectedCase("elevator_filter", 0.1),
    semi_real.InjectedCase("alpha_bias", 0.25),
    semi_real.InjectedCase("alpha_bias", 0.5),
)


def _outcome(
    report: dict, expected: str | None, magnitude: float, in_library: bool
) -> dict[str, object]:
    """One case's scores from its report (``expected``: the library's name, None for no effect)."""
    named = set(report["indistinguishable_set"]) if report["verdict"] == "effect" else set()
    result: dict[str, object] = {
        "expected": expected,
        "in_library": in_library,
        "verdict": report["verdict"],
        "verdict_basis": report["verdict_basis"],
        "reported": report["effect"],
        "reported_set": sorted(named),
        "closure_test": report["closure"]["realised_test"],
        "closure_interval": report["closure"]["interval"],
        "closure_fresh_data_interval": report["closure"]["fresh_data_interval"],
    }
    if expected is not None and expected in named and magnitude:
        entry = next(e for e in report["ranking"] if e["name"] == expected)
        result["magnitude_error"] = abs(entry["magnitude"] - magnitude) / abs(magnitude)
    return result


def run_energies(
    diagnosis: FlightDiagnosis, spec_path: Path, log_path: Path
) -> tuple[np.ndarray, np.ndarray]:
    """Each run's residual energy on another flight (summed over channels, each divided by the
    diagnosis' channel weight) under the baseline and under the diagnosis' chosen model."""
    runs = read_record(read_baseline_spec(spec_path), [log_path]).runs

    def energies(model) -> np.ndarray:
        return np.array([np.sum((r / diagnosis.weights) ** 2) for r in residuals_of(model, runs)])

    return energies(diagnosis.baseline), energies(diagnosis.chosen)


def fresh_closure(diagnosis: FlightDiagnosis, spec_path: Path, log_path: Path) -> float:
    """Closure of the diagnosis' chosen model on another flight (its own channel weights)."""
    before, after = run_energies(diagnosis, spec_path, log_path)
    return closure_of(before.sum(), after.sum())


def _within(result: dict[str, object], fresh: float) -> None:
    low, high = result["closure_interval"]
    fresh_low, fresh_high = result["closure_fresh_data_interval"]
    result["closure_fresh_flight"] = fresh
    result["fresh_within_interval"] = bool(low <= fresh <= high)
    result["fresh_within_prediction_interval"] = bool(fresh_low <= fresh <= fresh_high)


def _spec(path: Path, design: dict[str, str]) -> BaselineSpec:
    """The baseline file at ``path`` with ``design``'s keys set (``validation``, ``null_directions``,
    ``validation_weighting``)."""
    return dataclasses.replace(read_baseline_spec(path), **design)


def _refit_fields(report: dict) -> dict[str, object]:
    """The derivative re-fit's findings kept per case (docs/gap-diagnosis.md, Method step 7)."""
    refit = report["derivative_refit"]
    return {
        "refit_moved": refit.get("moved"),
        "refit_closure_test": refit.get("closure_test"),
        "refit_supported": refit.get("supported_by_test_runs", False),
    }


def sim_part(
    cases: int, seed: int, tick: Callable[[str], None], design: dict[str, str]
) -> list[dict[str, object]]:
    results = []
    for index in range(cases):
        case = draw_sim_case(index, seed, independent_reality.MANOEUVRES)
        with tempfile.TemporaryDirectory(prefix="ornitail-gap-") as folder:
            scored = run_sim_case(case, Path(folder), seed, **design)
        truth = scored["true_effects"]
        result = {
            "expected": ",".join(sorted(truth)) or None,
            "in_library": True,
            "verdict": scored["verdict"],
            "reported": scored["reported"],
            "reported_set": scored["reported_set"],
            "named_in_library": bool(scored["top1"]),
            "closure_test": scored["closure_reported"],
        }
        if "magnitude_error" in scored:
            result["magnitude_error"] = scored["magnitude_error"]
        if "closure_fresh_flight" in scored:
            result["closure_interval"] = scored["closure_interval"]
            result["closure_fresh_data_interval"] = scored["closure_fresh_data_interval"]
            _within(result, scored["closure_fresh_flight"])
        results.append(result)
        tick(f"sim {index + 1}/{cases}: {result['expected']} -> {result['verdict']}")
    return results


def independent_part(
    cases: int, seed: int, tick: Callable[[str], None], design: dict[str, str]
) -> list[dict[str, object]]:
    results = []
    for index in range(cases):
        case = independent_reality.draw_case(index, seed)
        with tempfile.TemporaryDirectory(prefix="ornitail-gap-") as folder:
            log_path, spec_path = independent_reality.write_case(case, Path(folder))
            diagnosis = diagnose_flight(_spec(spec_path, design), [log_path], seed=seed)
            expected = independent_reality.IN_LIBRARY.get(case.effect)
            result = _outcome(
                diagnosis.report,
                None if case.effect == "none" else expected or case.effect,
                case.magnitude,
                case.effect == "none" or expected is not None,
            )
            result["effect"], result["magnitude"] = case.effect, case.magnitude
            result |= _refit_fields(diagnosis.report)
            if diagnosis.report["verdict"] == "effect":
                fresh_case = type(case)(case.effect, case.magnitude, case.seed + 1)
                fresh_log, _ = independent_reality.write_case(fresh_case, Path(folder) / "fresh")
                _within(result, fresh_closure(diagnosis, spec_path, fresh_log))
        results.append(result)
        tick(f"independent {index + 1}/{cases}: {case.effect} -> {result['verdict']}")
    return results


def semi_real_part(
    seed: int, tick: Callable[[str], None], design: dict[str, str]
) -> list[dict[str, object]]:
    """The Twin Otter cases, diagnosed with ``design`` except its validation weighting: the record
    is cut into segments, which winsorising refuses (gap/validation_weighting.py)."""
    design = design | {"validation_weighting": "none"}
    results = []
    with tempfile.TemporaryDirectory(prefix="ornitail-gap-") as folder:
        model_file = semi_real.identified_model_file(Path(folder))
        for index, case in enumerate(SEMI_REAL_CASES):
            log_path, spec_path = semi_real.write_case(
                case, Path(folder) / str(index), model_file, derivative_refit=True
            )
            report = diagnose_flight(_spec(spec_path, design), [log_path], seed=seed).report
            expected, magnitude = case.expected
            result = _outcome(report, expected, magnitude, True)
            result["effect"], result["magnitude"] = case.effect, case.magnitude
            result |= _refit_fields(report)
            results.append(result)
            tick(
                f"semi-real {index + 1}/{len(SEMI_REAL_CASES)}: {case.effect} -> {report['verdict']}"
            )
    return results


WILSON_Z = float(stats.norm.isf(0.025))  # two-sided 95 %


def _rate(flags: list[bool]) -> str:
    return f"{sum(flags)} of {len(flags)}" if flags else "-"


def wilson_interval(successes: int, trials: int) -> list[float] | None:
    """95 % Wilson score interval of a binomial rate (None without trials): unlike the normal
    approximation it stays inside [0, 1] and keeps its coverage near 0 and 1 and at small n."""
    if trials == 0:
        return None
    rate = successes / trials
    spread = WILSON_Z**2 / trials
    centre = (rate + spread / 2) / (1 + spread)
    half = WILSON_Z * np.sqrt(rate * (1 - rate) / trials + spread / (4 * trials)) / (1 + spread)
    low = 0.0 if successes == 0 else float(centre - half)  # exactly 0 and 1 there, not rounding's
    high = 1.0 if successes == trials else float(centre + half)
    return [low, high]


def _missed(result: dict[str, object]) -> dict[str, object]:
    """What an in-library case that was not named was taken for, and how much its best candidate
    (or the procedure's choice) closed on the test runs: a miss closing little is under the
    detection limit, one closing much was held back by the null."""
    return {
        "expected": result["expected"],
        "verdict": result["verdict"],
        "reported": result["reported"],
        "closure_test": result["closure_test"],
    }


def summarise(results: list[dict[str, object]]) -> dict[str, object]:
    """The per-part scores of the module docstring."""
    none_cases = [r for r in results if r["expected"] is None]
    library = [r for r in results if r["expected"] is not None and r["in_library"]]
    outside = [r for r in results if not r["in_library"]]
    named = [r.get("named_in_library", r["expected"] in r["reported_set"]) for r in library]
    errors = [r["magnitude_error"] for r in results if "magnitude_error" in r]
    fresh = [r["fresh_within_interval"] for r in results if "fresh_within_interval" in r]
    predicted = [
        r["fresh_within_prediction_interval"] for r in results if "fresh_within_interval" in r
    ]
    refits = [r for r in results if "refit_supported" in r]
    refit_closures = [
        r["refit_closure_test"] for r in refits if r["refit_closure_test"] is not None
    ]
    false_alarms = [r["verdict"] == "effect" for r in none_cases]
    outside_right = [
        r["verdict"] == "unexplained"
        or (r["verdict"] == "effect" and r["reported"] in DERIVATIVE_LEVEL_CANDIDATES)
        for r in outside
    ]
    rates = {
        "false_alarms_on_no_effect": false_alarms,
        "named_in_library": named,
        "out_of_library_unexplained_or_nearest_derivative": outside_right,
        "fresh_flight_closure_within_prediction_interval": predicted,
    }
    return {
        "cases": len(results),
        "derivative_refit_supported_by_test_runs": _rate([r["refit_supported"] for r in refits]),
        "derivative_refit_closure_test_median": float(np.median(refit_closures))
        if refit_closures
        else None,
        "false_alarms_on_no_effect": _rate(false_alarms),
        "false_alarms_derivative_level": _rate(
            [
                r["verdict"] == "effect" and r["reported"] in DERIVATIVE_LEVEL_CANDIDATES
                for r in none_cases
            ]
        ),
        "unexplained_on_no_effect": _rate([r["verdict"] == "unexplained" for r in none_cases]),
        "named_in_library": _rate(named),
        "in_library_missed": [
            _missed(r) for r, was_named in zip(library, named, strict=True) if not was_named
        ],
        "magnitude_error_median": float(np.median(errors)) if errors else None,
        "magnitude_error_max": float(np.max(errors)) if errors else None,
        "out_of_library_unexplained_or_nearest_derivative": _rate(outside_right),
        "out_of_library_named_as": [r["reported"] or r["verdict"] for r in outside],
        "fresh_flight_closure_within_reported_interval": _rate(fresh),
        "fresh_flight_closure_within_prediction_interval": _rate(predicted),
        "rate_counts": {name: [sum(flags), len(flags)] for name, flags in rates.items()},
        "rate_intervals_95": {
            name: wilson_interval(sum(flags), len(flags)) for name, flags in rates.items()
        },
    }


def combine(paths: list[Path]) -> dict[str, object]:
    """Earlier results (``--out`` files, all of one design: validation, null directions and
    validation weighting) pooled:
    per part, each seed's cases once (the longest list any file holds for that seed: a seed's parts
    run as separate processes each carry the same semi-real cases), scored by :func:`summarise`."""
    by_part: dict[str, dict[int, list]] = {}
    designs: dict[tuple[str, str, str], Path] = {}
    for path in paths:
        try:
            result = json.loads(path.read_text())
            seed, parts = int(result["seed"]), result["results"]
            design = (
                result["validation"],
                result.get("null_directions", "any"),
                result.get("validation_weighting", "none"),
            )
        except (OSError, ValueError, KeyError, TypeError) as error:
            raise SystemExit(f"{path}: not a gap_realities result file ({error})") from None
        designs.setdefault(design, path)
        if len(designs) > 1:
            other = next(where for kept, where in designs.items() if kept != design)
            raise SystemExit(
                f"{path}: validation {design[0]!r}, null_directions {design[1]!r}, "
                f"validation_weighting {design[2]!r}; {other} differs: "
                "results of different designs are not pooled"
            )
        for part, cases in parts.items():
            kept = by_part.setdefault(part, {})
            if len(cases) > len(kept.get(seed, [])):
                kept[seed] = cases
    pooled = {
        part: [case for cases in seeds.values() for case in cases]
        for part, seeds in by_part.items()
    }
    (validation, null_directions, weighting), *_ = designs
    return {
        "validation": validation,
        "null_directions": null_directions,
        "validation_weighting": weighting,
        "seeds": {
            part: sorted(s for s, cases in seeds.items() if cases)
            for part, seeds in by_part.items()
        },
        "scores": {part: summarise(cases) for part, cases in pooled.items()},
    }


def seed_ranges(seeds: list[int]) -> str:
    """Sorted seeds as ranges: [2018, 2019, 2020, 2024] -> "2018-2020, 2024"."""
    ranges: list[list[int]] = []
    for seed in sorted(seeds):
        if ranges and seed == ranges[-1][-1] + 1:
            ranges[-1].append(seed)
        else:
            ranges.append([seed])
    return ", ".join(f"{run[0]}-{run[-1]}" if len(run) > 1 else f"{run[0]}" for run in ranges)


def figure_title(design: dict[str, str], seeds: dict[str, list[int]]) -> str:
    """The figure's title: the design (``validation``, ``null_directions``) and each part's seeds."""
    parts = "; ".join(
        f"{name} {seed_ranges(seeds[part])}" for part, name in PARTS.items() if seeds.get(part)
    )
    weighting = design.get("validation_weighting", "none")
    return (
        f"gap diagnosis on three realities, null directions {design['null_directions']}, "
        f"validation {design['validation']}, validation runs {weighting}\nseeds: {parts}"
    )


def refuse_missing_folders(
    parser: argparse.ArgumentParser, outputs: dict[str, Path | None]
) -> None:
    """One line (exit 2) for an output option whose folder does not exist, before a run of minutes."""
    for option, path in outputs.items():
        if path is not None and not path.parent.is_dir():
            parser.error(f"{option} {path}: the folder {path.parent} does not exist")


def main(argv: list[str] | None = None) -> dict[str, object]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim-cases", type=int, default=10)
    parser.add_argument("--independent-cases", type=int, default=12)
    parser.add_argument("--seed", type=int, default=2018)
    parser.add_argument("--out", type=Path)
    parser.add_argument(
        "--validation",
        choices=VALIDATION_DESIGNS,
        default="all-folds",
        help="the baseline files' [baseline].validation (first-fold: the first fold's validation runs alone)",
    )
    parser.add_argument(
        "--null-directions",
        choices=NULL_DIRECTIONS,
        default=FLIGHT_NULL_DIRECTIONS,
        help="the baseline files' [baseline].null_directions (default: %(default)s)",
    )
    parser.add_argument(
        "--validation-weighting",
        choices=VALIDATION_WEIGHTINGS,
        default="winsorised",
        help="the baseline files' [baseline].validation_weighting (default: %(default)s, the diagnosis' "
        'default for manoeuvres since stop 43; "none" the design before)',
    )
    parser.add_argument(
        "--combine", type=Path, nargs="+", metavar="RESULT", help="pool earlier --out files"
    )
    parser.add_argument(
        "--figure",
        type=Path,
        metavar="PNG",
        help="also draw the scores against issue 15's targets (benchmarks/realities_figure.py)",
    )
    arguments = parser.parse_args(argv)
    refuse_missing_folders(parser, {"--out": arguments.out, "--figure": arguments.figure})
    if arguments.combine:
        pooled = combine(arguments.combine)
        if arguments.out:
            arguments.out.write_text(json.dumps(to_jsonable(pooled), indent=1))
        if arguments.figure:
            title = figure_title(pooled, pooled["seeds"])
            save_realities_figure(pooled["scores"], title, arguments.figure)
        print(json.dumps(to_jsonable(pooled), indent=1))
        return pooled
    started = time.monotonic()

    def tick(what: str) -> None:
        print(f"[{time.monotonic() - started:7.1f} s] {what}", file=sys.stderr, flush=True)

    design = {
        "validation": arguments.validation,
        "null_directions": arguments.null_directions,
        "validation_weighting": arguments.validation_weighting,
    }
    parts = {
        "semi_real": semi_real_part(arguments.seed, tick, design),
        "independent": independent_part(arguments.independent_cases, arguments.seed, tick, design),
        "sim": sim_part(arguments.sim_cases, arguments.seed, tick, design),
    }
    result = {
        "seed": arguments.seed,
        **design,
        "scores": {name: summarise(results) for name, results in parts.items()},
        "results": parts,
    }
    if arguments.out:
        arguments.out.write_text(json.dumps(to_jsonable(result), indent=1))
    if arguments.figure:
        seeds = {part: [arguments.seed] for part, results in parts.items() if results}
        save_realities_figure(result["scores"], figure_title(design, seeds), arguments.figure)
    print(json.dumps(to_jsonable(result["scores"]), indent=1))
    return result


if __name__ == "__main__":
    main()
