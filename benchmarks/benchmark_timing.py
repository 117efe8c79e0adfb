"""Wall-time helpers shared by the benchmarks that compare a change with its baseline in one process."""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Any


def timed_s(action: Callable[[], Any]) -> tuple[float, Any]:
    """Wall time of one run of ``action``, s, and its result."""
    started = time.perf_counter()
    result = action()
    return time.perf_counter() - started, result


def median_time_s(action: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    """Median wall time of ``repeats`` runs of ``action``, s, and its last result."""
    times, result = [], None
    for _ in range(repeats):
        elapsed, result = timed_s(action)
        times.append(elapsed)
    return statistics.median(times), result


def alternating_medians_s(
    action: Callable[[], Any], baseline: Callable[[], AbstractContextManager[Any]], repeats: int
) -> tuple[float, float]:
    """Median wall times of ``action`` as it is and inside ``baseline()`` (the code it replaced, put back), s: run
    alternately, ``repeats`` times each, so a host whose speed drifts slows both alike."""
    change, before = [], []
    for _ in range(repeats):
        change.append(timed_s(action)[0])
        with baseline():
            before.append(timed_s(action)[0])
    return statistics.median(change), statistics.median(before)


def repeats_and_json_options(
    name: str, description: str, argv: list[str] | None, default_repeats: int = 3
) -> argparse.Namespace | None:
    """``--repeats N`` (timed runs per variant) and ``--json``; None, after one line on stderr, when N < 1."""
    parser = argparse.ArgumentParser(prog=name, description=description)
    parser.add_argument("--repeats", type=int, default=default_repeats)
    parser.add_argument("--json", action="store_true")
    arguments = parser.parse_args(argv)
    if arguments.repeats < 1:
        print(f"{name}: --repeats must be >= 1", file=sys.stderr)
        return None
    return arguments
