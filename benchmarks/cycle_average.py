"""Benchmark: cycle-average a 10-minute, 10 kHz, 9-channel recording (issue 4, section 6).

The recording is a synthetic float32 array shaped like ``samples.h5``'s ``/samples/raw``: six gauge channels
with flap ripple and noise, hot-wire and thermocouple lines, and a realistic Hall line (a 5 % wide pulse per
flap at 13.5 Hz with 0.2 % speed wander, 0.2 ms flanks and 20 mV noise). Cycle boundaries come from
:func:`~ornitail.balance.hall_cycles.flap_cycles` (timed separately); the benchmark times
:func:`~ornitail.balance.cycle_averages.cycle_means` on all nine channels against two yardsticks measured in the
same process on the same array:

- a plain pandas implementation of the same computation: a cycle id per sample (-1 outside accepted cycles),
  then ``DataFrame.groupby(cycle_id).mean()`` without the -1 group;
- numpy's raw reduction ``array.sum(axis=0)`` over the whole array: one pass over memory, the floor for any
  method that reads every sample.

Each is run ``--repeats`` times and the median reported. ``cycle_means`` sums blocks of 64 rows with ``einsum`` on
as many threads as there are cores (numpy releases the GIL); the yardsticks run on one thread, as pandas and
numpy do. Targets: at least 10x faster than pandas, within 3x of
the raw reduction. The results are checked to agree (pandas vs cycle_means, relative 1e-9 in float64).

Usage::

    .venv/bin/python benchmarks/cycle_average.py                 # 10 min at 10 kHz, 5 repeats
    .venv/bin/python benchmarks/cycle_average.py --minutes 1 --json

Exit code 0 when both targets are met, 1 when one is missed, 2 for a bad option value.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np
import pandas as pd
from benchmark_timing import median_time_s

from ornitail.app.cli_output import emit
from ornitail.balance.cycle_averages import _cycle_sample_bounds, cycle_means
from ornitail.balance.hall_cycles import FlapCycles, flap_cycles

SAMPLE_RATE_HZ = 10_000.0
CHANNELS = 9
FLAPPING_FREQUENCY_HZ = 13.5
PANDAS_TARGET_RATIO = 10.0
RAW_REDUCTION_TARGET_RATIO = 3.0


def synthetic_recording(minutes: float, seed: int = 0) -> np.ndarray:
    """A (n, 9) float32 recording: gauges 0-5, hot-wire, thermocouple, Hall line (V)."""
    generator = np.random.default_rng(seed)
    count = int(minutes * 60 * SAMPLE_RATE_HZ)
    # Speed wander: a slow random walk of the frequency, about 0.2 % rms.
    wander = np.cumsum(generator.normal(0.0, 1.0, count // 1000 + 2))
    wander = 0.002 * (wander - wander.mean()) / max(wander.std(), 1e-12)
    frequency = FLAPPING_FREQUENCY_HZ * (
        1.0 + np.interp(np.arange(count), np.arange(wander.size) * 1000, wander)
    )
    phase = np.cumsum(frequency) / SAMPLE_RATE_HZ  # cycles
    fraction = phase % 1.0
    data = np.empty((count, CHANNELS), dtype=np.float32)
    ripple = np.sin(2 * np.pi * fraction)
    for channel in range(6):
        data[:, channel] = 0.1 * channel + 0.05 * ripple + generator.normal(0.0, 2e-3, count)
    data[:, 6] = 2.1 + generator.normal(0.0, 1e-3, count)
    data[:, 7] = 0.01 + generator.normal(0.0, 1e-4, count)
    # Hall pulse with 0.2 ms linear flanks (2 samples) at the start of each cycle.
    flank_fraction = 2e-4 * frequency
    pulse = np.clip(fraction / flank_fraction, 0.0, 1.0) * np.clip(
        (0.05 - fraction) / flank_fraction, 0.0, 1.0
    )
    data[:, 8] = 3.3 * pulse + generator.normal(0.0, 0.02, count)
    return data


def pandas_cycle_means(data: np.ndarray, cycles: FlapCycles) -> np.ndarray:
    """The same computation in plain pandas: cycle id per sample, then groupby mean."""
    bounds = _cycle_sample_bounds(cycles, SAMPLE_RATE_HZ, len(data))
    cycle_id = np.full(len(data), -1, dtype=np.int64)
    for index, (first, stop) in enumerate(bounds):
        cycle_id[first:stop] = index
    return pd.DataFrame(data).groupby(cycle_id).mean().drop(index=-1, errors="ignore").to_numpy()


def run(minutes: float, repeats: int) -> dict[str, Any]:
    data = synthetic_recording(minutes)
    edges_s, cycles = median_time_s(lambda: flap_cycles(data[:, 8], SAMPLE_RATE_HZ), repeats)
    raw_s, _ = median_time_s(lambda: data.sum(axis=0), repeats)
    ours_s, ours = median_time_s(lambda: cycle_means(data, cycles, SAMPLE_RATE_HZ), repeats)
    pandas_s, reference = median_time_s(lambda: pandas_cycle_means(data, cycles), repeats)
    agree = bool(np.allclose(ours, reference, rtol=1e-6, atol=1e-6))
    return {
        "samples": len(data),
        "channels": CHANNELS,
        "bytes": int(data.nbytes),
        "cycles": len(cycles),
        "repeats": repeats,
        "hall_edges_s": edges_s,
        "cycle_means_s": ours_s,
        "pandas_groupby_s": pandas_s,
        "raw_sum_s": raw_s,
        "speedup_over_pandas": pandas_s / ours_s,
        "ratio_to_raw_reduction": ours_s / raw_s,
        "results_agree": agree,
        "pandas_target_met": pandas_s / ours_s >= PANDAS_TARGET_RATIO,
        "raw_target_met": ours_s / raw_s <= RAW_REDUCTION_TARGET_RATIO,
    }


def _render(result: dict[str, Any]) -> str:
    mark = {True: "ok", False: "MISSED"}
    return "\n".join(
        [
            f"recording: {result['samples']} samples x {result['channels']} channels float32 "
            f"({result['bytes'] / 1e6:.0f} MB), {result['cycles']} accepted cycles; median of {result['repeats']}",
            f"Hall edges and cycles (flap_cycles):   {result['hall_edges_s'] * 1e3:9.1f} ms",
            f"cycle_means, 9 channels:                {result['cycle_means_s'] * 1e3:9.1f} ms",
            f"pandas cycle id + groupby mean:         {result['pandas_groupby_s'] * 1e3:9.1f} ms",
            f"numpy array.sum(axis=0):                {result['raw_sum_s'] * 1e3:9.1f} ms",
            f"speed-up over pandas: {result['speedup_over_pandas']:6.1f}x  (target >= {PANDAS_TARGET_RATIO:g}x) "
            f"{mark[result['pandas_target_met']]}",
            f"ratio to raw reduction: {result['ratio_to_raw_reduction']:4.2f}x  (target <= "
            f"{RAW_REDUCTION_TARGET_RATIO:g}x) {mark[result['raw_target_met']]}",
            f"cycle means agree with pandas: {result['results_agree']}",
        ]
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0, help="recording length, minutes")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per method (median)")
    parser.add_argument("--json", dest="as_json", action="store_true", help="print one JSON object")
    options = parser.parse_args(argv)
    if not 0.05 <= options.minutes <= 60 or options.repeats < 1:
        print("cycle_average.py: --minutes must be 0.05..60 and --repeats >= 1", file=sys.stderr)
        return 2
    result = run(options.minutes, options.repeats)
    emit(result, options.as_json, _render)
    return (
        0
        if result["pandas_target_met"] and result["raw_target_met"] and result["results_agree"]
        else 1
    )


if __name__ == "__main__":
    sys.exit(main())
