"""Start-up time of the ``ornitail`` command: ``import ornitail.app.cli`` and ``ornitail --help``.

Each case runs in a fresh subprocess of this venv's Python, ``--runs`` times, interleaved with a baseline
(``python -c "pass"``: the interpreter's own start-up) so that a machine slowing down during the run slows both.
Prints the median wall time of each case (s) and its ratio to the baseline's median.

    .venv/bin/python benchmarks/cli_startup.py [--runs 11] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

CONSOLE_SCRIPT = str(Path(sys.executable).parent / "ornitail")
"""The ``ornitail`` console script installed next to this Python."""
CASES: dict[str, list[str]] = {
    "baseline: python -c pass": [sys.executable, "-c", "pass"],
    "import ornitail.app.cli": [sys.executable, "-c", "import ornitail.app.cli"],
    "ornitail --help": [CONSOLE_SCRIPT, "--help"],
    "ornitail process --help": [CONSOLE_SCRIPT, "process", "--help"],
    "ornitail flight --help": [CONSOLE_SCRIPT, "flight", "--help"],
}


def wall_time_s(command: list[str]) -> float:
    """Wall time of one run of ``command`` (s); a failing command is an error."""
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return time.perf_counter() - started


def measure(runs: int) -> dict[str, dict[str, float]]:
    """Median wall time (s) of each case over ``runs`` interleaved runs, and its ratio to the baseline."""
    times: dict[str, list[float]] = {name: [] for name in CASES}
    for command in CASES.values():  # warm the file cache once
        wall_time_s(command)
    for _ in range(runs):
        for name, command in CASES.items():
            times[name].append(wall_time_s(command))
    baseline = statistics.median(times["baseline: python -c pass"])
    return {
        name: {
            "median_s": statistics.median(values),
            "ratio_to_baseline": statistics.median(values) / baseline,
        }
        for name, values in times.items()
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=11, help="runs of each case (default 11)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    arguments = parser.parse_args()
    if arguments.runs < 1:
        parser.error("--runs must be at least 1")
    results = measure(arguments.runs)
    if arguments.json:
        print(json.dumps(results, indent=2))
        return
    print(f"{'case':28s}{'median s':>10s}{'x baseline':>12s}")
    for name, result in results.items():
        print(f"{name:28s}{result['median_s']:>10.3f}{result['ratio_to_baseline']:>12.1f}")


if __name__ == "__main__":
    main()
