"""Several fresh flights per case: how often the reported prediction interval holds a new flight.

``gap_realities.py`` scores each named effect against one fresh flight. This script diagnoses the
same cases (the simulator's, ``--part sim``, or flapper B's, ``--part independent``; the default
design) and flies ``--fresh`` new flights of each named case (the case's seed + 1 ... + K: other
gusts and noise, the same vehicle and effect). Each new flight's closure under the diagnosis'
model and channel weights is held against the report's ``fresh_data_interval`` (90 %). With
several flights per case a case's own rate shows: an interval centred on a flight that differs
from the others as a whole misses all of them (docs/gap-diagnosis.md, *Detection limits*).

Each fresh flight's per-run energies (before and after, under the diagnosis' model and weights) are
kept, and with two or more per case the ``replay`` part of the output asks why an interval misses:
every fresh flight in turn gives the interval from its own runs and the others are held against it,
as flown and with the case's runs dealt out at random into flights of the same size (runs as
independent draws: what the interval assumes), and the runs' intraclass correlation (what the runs
of one flight share, which no interval built from one flight can see).

``python benchmarks/fresh_flights.py --part independent --seed 2040 --cases 24 --fresh 4
[--out result.json] [--figure cases.png]``; ``--draw a.json b.json ... --figure cases.png`` draws
earlier results without a run: a panel per file, each named case's interval, its test closure and
its fresh flights (those outside in red).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
from pathlib import Path

import independent_reality
import matplotlib
import numpy as np
from gap_realities import refuse_missing_folders, run_energies, wilson_interval
from realities_figure import PARTS as PART_NAMES

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend is chosen first: the benchmarks run headless)

from ornitail.core.output import to_jsonable
from ornitail.gap.benchmark import draw_case as draw_sim_case
from ornitail.gap.detection import closure_of
from ornitail.gap.flight_diagnosis import diagnose_flight
from ornitail.gap.intervals import fresh_data_interval
from ornitail.gap.model_spec import read_baseline_spec, write_baseline_spec
from ornitail.gap.withheld_effects import simulate_withheld_log
from ornitail.sim.free_flight import write_flight_log_csv

PARTS = ("sim", "independent")
REGROUPINGS = 20  # random regroupings of each case's runs: one alone moves the rate by a few points


def _flights(
    part: str, index: int, seed: int, fresh: int, folder: Path
) -> tuple[str | None, Path, Path, list[Path]]:
    """The case's label, its log, its baseline file and its ``fresh`` new flights' logs."""
    if part == "sim":
        case = draw_sim_case(index, seed, independent_reality.MANOEUVRES)
        log = write_flight_log_csv(simulate_withheld_log(case), folder / "flight.csv")
        spec_path = write_baseline_spec(case.baseline_spec(), folder / "baseline.toml")
        new = [
            write_flight_log_csv(
                simulate_withheld_log(dataclasses.replace(case, seed=case.seed + number)),
                folder / f"fresh-{number}.csv",
            )
            for number in range(1, fresh + 1)
        ]
        return ",".join(sorted(case.effects)) or None, log, spec_path, new
    case = independent_reality.draw_case(index, seed)
    log, spec_path = independent_reality.write_case(case, folder)
    new = [
        independent_reality.write_case(
            dataclasses.replace(case, seed=case.seed + number), folder / f"fresh-{number}"
        )[0]
        for number in range(1, fresh + 1)
    ]
    return None if case.effect == "none" else case.effect, log, spec_path, new


def run_case(part: str, index: int, seed: int, fresh: int) -> dict[str, object]:
    """Diagnose the ``index``-th case of ``part`` at ``seed``; when it names an effect, score
    ``fresh`` new flights against its prediction interval."""
    with tempfile.TemporaryDirectory(prefix="ornitail-fresh-") as folder:
        expected, log, spec_path, new = _flights(part, index, seed, fresh, Path(folder))
        diagnosis = diagnose_flight(read_baseline_spec(spec_path), [log], seed=seed)
        report = diagnosis.report
        result = {"index": index, "expected": expected, "verdict": report["verdict"]}
        if report["verdict"] != "effect":
            return result
        low, high = report["closure"]["fresh_data_interval"]
        energies = [run_energies(diagnosis, spec_path, path) for path in new]
    closures = [closure_of(np.sum(before), np.sum(after)) for before, after in energies]
    return result | {
        "reported": report["effect"],
        "closure_test": report["closure"]["realised_test"],
        "closure_fresh_data_interval": [low, high],
        "closure_fresh_flights": closures,
        "fresh_run_energies_before": [before for before, _ in energies],
        "fresh_run_energies_after": [after for _, after in energies],
        "below": sum(value < low for value in closures),
        "above": sum(value > high for value in closures),
    }


def summarise(results: list[dict[str, object]]) -> dict[str, object]:
    """Fresh flights inside the interval (with a 95 % Wilson interval, flights counted as if
    independent: those of one case are not, so it is narrower than it should be), below and above
    it, and the cases whose interval held none of their fresh flights."""
    named = [r for r in results if "closure_fresh_flights" in r]
    flights = sum(len(r["closure_fresh_flights"]) for r in named)
    below = sum(r["below"] for r in named)
    above = sum(r["above"] for r in named)
    inside = flights - below - above
    return {
        "cases": len(results),
        "cases_named": len(named),
        "fresh_flights": flights,
        "inside": inside,
        "below": below,
        "above": above,
        "inside_rate": inside / flights if flights else None,
        "inside_rate_interval_95": wilson_interval(inside, flights),
        "cases_missing_every_fresh_flight": sum(
            r["below"] + r["above"] == len(r["closure_fresh_flights"]) for r in named
        ),
    }


def _pairs_inside(flights: list[tuple[np.ndarray, np.ndarray]], seed: int) -> tuple[int, int, int]:
    """Every flight in turn gives the 90 % prediction interval (from its own runs) and every other
    one is held against it: (pairs, below, above)."""
    closures = [closure_of(np.sum(before), np.sum(after)) for before, after in flights]
    pairs = below = above = 0
    for giver, (before, after) in enumerate(flights):
        low, high = fresh_data_interval(before, after, seed)
        for other, closure in enumerate(closures):
            if other != giver:
                pairs += 1
                below += closure < low
                above += closure > high
    return pairs, below, above


def _regrouped(
    flights: list[tuple[np.ndarray, np.ndarray]], generator: np.random.Generator
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The same runs dealt out at random into flights of the same sizes: runs as independent draws."""
    before, after, edges = _pooled(flights)
    order = generator.permutation(len(before))
    return list(zip(np.split(before[order], edges), np.split(after[order], edges), strict=True))


def _pooled(
    flights: list[tuple[np.ndarray, np.ndarray]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every flight's runs in one row (before, after) and where each flight ends in it (np.split)."""
    before = np.concatenate([b for b, _ in flights])
    after = np.concatenate([a for _, a in flights])
    return before, after, np.cumsum([len(b) for b, _ in flights])[:-1]


def intraclass_correlation(flights: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """One-way ANOVA estimate of the share of the run influences' variance that the runs of one
    flight share (Fisher's intraclass correlation). A run's influence on the closure of all the
    runs pooled is -(r / 2) N (a_i / A - b_i / B) (intervals.closures_and_standard_errors); a
    fresh flight's closure varies (1 + (n - 1) ICC) times as much as its n runs, taken as
    independent, make it (the design effect)."""
    before, after, edges = _pooled(flights)
    ratio = np.sqrt(after.sum() / before.sum())
    influence = -(ratio / 2) * len(before) * (after / after.sum() - before / before.sum())
    groups = np.split(influence, edges)
    sizes = np.array([len(g) for g in groups], dtype=float)
    between = np.sum(sizes * (np.array([g.mean() for g in groups]) - influence.mean()) ** 2)
    within = sum(np.sum((g - g.mean()) ** 2) for g in groups)
    between_mean = between / (len(groups) - 1)
    within_mean = within / (len(influence) - len(groups))
    size = (len(influence) - np.sum(sizes**2) / len(influence)) / (len(groups) - 1)
    return float((between_mean - within_mean) / (between_mean + (size - 1) * within_mean))


def replay(results: list[dict[str, object]], seed: int) -> dict[str, object] | None:
    """How the interval does when the fresh flights, scored with the diagnosis' model, give it in
    turn: pairs inside as flown and with their runs regrouped at random (what the interval would do
    if runs were independent draws), and the runs' intraclass correlation per case (the part of a
    flight the interval cannot see from its own runs). None without two fresh flights a case."""
    cases = [
        list(
            zip(
                map(np.asarray, r["fresh_run_energies_before"]),
                map(np.asarray, r["fresh_run_energies_after"]),
                strict=True,
            )
        )
        for r in results
        if len(r.get("fresh_run_energies_before", ())) >= 2
    ]
    if not cases:
        return None
    generator = np.random.default_rng(seed)
    flown = np.array([_pairs_inside(flights, seed) for flights in cases]).sum(axis=0)
    regrouped = np.array(
        [
            _pairs_inside(_regrouped(flights, generator), seed)
            for flights in cases
            for _ in range(REGROUPINGS)
        ]
    ).sum(axis=0)
    correlations = np.array([intraclass_correlation(flights) for flights in cases])
    runs = np.mean([len(b) for flights in cases for b, _ in flights])

    def rate(counts: np.ndarray) -> dict[str, object]:
        pairs, below, above = (int(value) for value in counts)
        return {
            "pairs": pairs,
            "inside": pairs - below - above,
            "below": below,
            "above": above,
            "inside_rate": (pairs - below - above) / pairs,
        }

    return {
        "cases": len(cases),
        "as_flown": rate(flown),
        "runs_regrouped_at_random": rate(regrouped),
        "intraclass_correlation_median": float(np.median(correlations)),
        "intraclass_correlation_mean": float(np.mean(correlations)),
        "intraclass_correlation_standard_error": float(
            np.std(correlations, ddof=1) / np.sqrt(len(correlations))
        )
        if len(correlations) > 1
        else None,
        "design_effect_at_mean": float(1.0 + (runs - 1.0) * np.mean(correlations)),
    }


def fresh_flights_figure(outputs: list[dict[str, object]]) -> plt.Figure:
    """A panel per result (``main``'s output: part, seed, summary, results): for each named case its
    90 % prediction interval (grey bar), its closure on test runs (black dot) and its fresh flights'
    closures (crosses, red outside the interval)."""
    figure, axes = plt.subplots(
        len(outputs), 1, figsize=(8.0, 2.6 * len(outputs)), squeeze=False, sharey=True
    )
    for axis, output in zip(axes[:, 0], outputs, strict=True):
        named = [r for r in output["results"] if "closure_fresh_flights" in r]
        for position, result in enumerate(named):
            low, high = result["closure_fresh_data_interval"]
            axis.vlines(position, low, high, color="lightgrey", linewidth=6)
            axis.plot(position, result["closure_test"], "o", color="black", markersize=4)
            for value in result["closure_fresh_flights"]:
                outside = value < low or value > high
                axis.plot(position, value, "x", color="tab:red" if outside else "tab:blue")
        summary = output["summary"]
        axis.set_title(
            f"{PART_NAMES[output['part']]}, seed {output['seed']}: {summary['inside']} of "
            f"{summary['fresh_flights']} fresh flights inside ({summary['below']} below, "
            f"{summary['above']} above)",
            fontsize=9,
        )
        axis.set_xticks(range(len(named)), [str(r["index"]) for r in named], fontsize=7)
        axis.set_xlim(-0.7, max(len(named), 1) - 0.3)
        axis.grid(axis="y", alpha=0.3)
        axis.set_ylabel("closure (-)", fontsize=8)
    axes[-1, 0].set_xlabel(
        "named case (index); grey: 90 % prediction interval, dot: test runs, x: fresh flights "
        "(red: outside)",
        fontsize=8,
    )
    figure.tight_layout()
    return figure


def _saved_output(parser: argparse.ArgumentParser, path: Path) -> dict[str, object]:
    """An earlier ``--out`` file, or one line (exit 2) saying why it is not one."""
    try:
        output = json.loads(path.read_text())
        missing = {"part", "seed", "summary", "results"} - set(output)
    except (OSError, ValueError, TypeError) as error:
        parser.error(f"--draw {path}: not a fresh_flights result file ({error})")
    if missing:
        parser.error(
            f"--draw {path}: not a fresh_flights result file (no {', '.join(sorted(missing))})"
        )
    if output["part"] not in PARTS:
        parser.error(f"--draw {path}: part {output['part']!r} is not one of {', '.join(PARTS)}")
    return output


def main(argv: list[str] | None = None) -> dict[str, object]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=PARTS)
    parser.add_argument("--seed", type=int, default=2040)
    parser.add_argument("--cases", type=int, default=10)
    parser.add_argument("--fresh", type=int, default=4, help="new flights per named case")
    parser.add_argument("--out", type=Path)
    parser.add_argument("--figure", type=Path, metavar="PNG", help="also draw the cases")
    parser.add_argument(
        "--draw", type=Path, nargs="+", metavar="RESULT", help="draw earlier --out files (no run)"
    )
    arguments = parser.parse_args(argv)
    refuse_missing_folders(parser, {"--out": arguments.out, "--figure": arguments.figure})
    if arguments.draw:
        if arguments.figure is None:
            parser.error("--draw needs --figure PNG: the picture to write")
        outputs = [_saved_output(parser, path) for path in arguments.draw]
        fresh_flights_figure(outputs).savefig(arguments.figure, dpi=120)
        return {"drawn": [str(path) for path in arguments.draw]}
    if arguments.part is None:
        parser.error("--part is required unless --draw is given")
    if arguments.fresh < 1 or arguments.cases < 1:
        parser.error(
            f"--cases {arguments.cases} --fresh {arguments.fresh}: both must be at least 1"
        )
    results = []
    for index in range(arguments.cases):
        results.append(run_case(arguments.part, index, arguments.seed, arguments.fresh))
        print(json.dumps(to_jsonable(results[-1])), file=sys.stderr, flush=True)
    output = {
        "part": arguments.part,
        "seed": arguments.seed,
        "summary": summarise(results),
        "replay": replay(results, arguments.seed),
        "results": results,
    }
    if arguments.out:
        arguments.out.write_text(json.dumps(to_jsonable(output), indent=1))
    if arguments.figure:
        fresh_flights_figure([to_jsonable(output)]).savefig(arguments.figure, dpi=120)
    print(json.dumps(to_jsonable({key: output[key] for key in ("summary", "replay")}), indent=1))
    return output


if __name__ == "__main__":
    main()
