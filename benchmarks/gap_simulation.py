"""Benchmark: a flight gap diagnosis with its runs simulated together against one run at a time.

Every candidate, null direction and relaxation pass of a diagnosis simulates the linear model on a fold's runs
(``gap/flight_model.py`` ``simulate_runs``): thousands of simulations per flight. They are propagated together,
the runs of one sample time as the columns of one state recursion. The baseline, in the same process on the same
data, puts back one recursion per run (each run simulated alone through the same function). The case is the
worked example's flight (``ornitail gap example --effect input_delay``, 16 manoeuvres, seed 1), diagnosed with
seed 2018 under both validation designs' costs (``first-fold``, the default, and ``all-folds``), alternating.
Printed: the medians, their ratio and the largest difference between the two reports' numbers (one JSON object
with ``--json``).

Usage::

    .venv/bin/python benchmarks/gap_simulation.py
    .venv/bin/python benchmarks/gap_simulation.py --repeats 5 --json

Exit code 0 when the two ways give the same report (every number within 1e-9 relative, or absolute below 1e-6)
and the batched way is faster, 1 otherwise, 2 for a bad option.
"""

from __future__ import annotations

import dataclasses
import sys
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from benchmark_timing import alternating_medians_s, repeats_and_json_options

from ornitail.app.cli_output import emit
from ornitail.gap import flight_diagnosis
from ornitail.gap.example_data import write_example
from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_model import LinearFlightModel, simulate_runs
from ornitail.gap.model_spec import read_baseline_spec

MANOEUVRES = 16
DESIGNS = ("first-fold", "all-folds")


def one_run_at_a_time(model: LinearFlightModel, runs: Sequence[FlightRun]) -> list[np.ndarray]:
    """The baseline: each run propagated by a recursion of its own (``simulate_runs``'s signature)."""
    return [simulate_runs(model, [run])[0] for run in runs]


@contextmanager
def runs_one_at_a_time() -> Iterator[None]:
    """The diagnosis with the baseline's simulation put back."""
    flight_diagnosis.simulate_runs = one_run_at_a_time
    try:
        yield
    finally:
        flight_diagnosis.simulate_runs = simulate_runs


def numbers_of(value: object) -> list[float]:
    """Every number in a JSON-ready report, in document order."""
    if isinstance(value, dict):
        return [number for key in sorted(value) for number in numbers_of(value[key])]
    if isinstance(value, list | tuple):
        return [number for item in value for number in numbers_of(item)]
    if isinstance(value, bool) or not isinstance(value, int | float):
        return []
    return [float(value)]


def largest_relative_difference(first: dict, second: dict) -> float:
    """Largest |a - b| / max(|a|, |b|, 1e-6) over the reports' numbers (inf when they differ in shape): a number
    at the rounding floor, such as a closure of 1e-16 against 0, counts absolutely."""
    a, b = np.array(numbers_of(first)), np.array(numbers_of(second))
    if a.shape != b.shape or not np.array_equal(np.isfinite(a), np.isfinite(b)):
        return float("inf")
    finite = np.isfinite(a)
    scale = np.maximum(np.maximum(np.abs(a[finite]), np.abs(b[finite])), 1e-6)
    return float(np.max(np.abs(a[finite] - b[finite]) / scale, initial=0.0))


def main(argv: list[str] | None = None) -> int:
    arguments = repeats_and_json_options("gap_simulation", __doc__.splitlines()[0], argv)
    if arguments is None:
        return 2
    record: dict[str, object] = {"repeats": arguments.repeats, "manoeuvres": MANOEUVRES}
    agreed = True
    with tempfile.TemporaryDirectory(prefix="ornitail-gap-simulation-") as folder:
        example = write_example(
            "flight", {"input_delay": None}, "S3", 98.0, MANOEUVRES, 1, Path(folder)
        )
        spec = read_baseline_spec(example["model"])
        for design in DESIGNS:
            designed = dataclasses.replace(spec, validation=design)

            def diagnose(designed=designed) -> dict:
                return flight_diagnosis.diagnose_flight(designed, [example["data"]]).report

            together = diagnose()  # also warms imports and caches
            with runs_one_at_a_time():
                alone = diagnose()
            difference = largest_relative_difference(together, alone)
            together_s, alone_s = alternating_medians_s(
                diagnose, runs_one_at_a_time, arguments.repeats
            )
            key = design.replace("-", "_")
            record |= {
                f"{key}_together_s": together_s,
                f"{key}_one_run_at_a_time_s": alone_s,
                f"{key}_speed_ratio": alone_s / together_s,
                f"{key}_largest_relative_difference": difference,
            }
            agreed &= difference <= 1e-9 and together_s < alone_s
    emit(
        record,
        arguments.json,
        lambda r: "\n".join(
            f"{design}: diagnosis {r[f'{key}_together_s']:.2f} s with the runs simulated together, "
            f"{r[f'{key}_one_run_at_a_time_s']:.2f} s one run at a time "
            f"({r[f'{key}_speed_ratio']:.2f}x faster); reports differ by at most "
            f"{r[f'{key}_largest_relative_difference']:.1e} relative"
            for design, key in ((d, d.replace("-", "_")) for d in DESIGNS)
        ),
    )
    return 0 if agreed else 1


if __name__ == "__main__":
    sys.exit(main())
