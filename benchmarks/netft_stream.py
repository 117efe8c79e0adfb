"""Benchmark: stream the simulated Net F/T at 7 kHz over UDP on the loopback through the real driver.

The simulated device (``ornitail.simulated_instruments.netft``) runs in a child process, as a real device is a
machine of its own, and streams RDT records at ``--rate-hz`` to the real :class:`NetFtDriver` in this process,
which reads the calibration page over HTTP, decodes every datagram, converts to N and N m and counts gaps in
``rdt_sequence``. The main thread drains the driver's blocks, as a recorder would.

Target (issue 17): 7000 records/s for 10 minutes with 0 lost on the loopback. Exit code 0 if met (no record
lost, no block dropped, every record the device sent received or counted lost), 1 if not, 2 for a bad
command-line value. Usage and the meaning of each number: ``benchmarks/README.md``.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import sys
import time
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from ornitail.acquisition import netft_protocol as protocol
from ornitail.acquisition.netft_driver import NetFtDriver
from ornitail.app.cli_output import emit
from ornitail.simulated_instruments.netft import SimulatedNetFt

DEFAULT_DURATION_S = 600.0
DEFAULT_RATE_HZ = protocol.INTERNAL_SAMPLE_RATE_HZ


def flapping_load(times_s: np.ndarray) -> np.ndarray:
    """A 12 Hz flapping-like load on every axis (N, N m), so the records carry changing counts."""
    amplitude = np.array([0.3, 0.05, 0.6, 0.004, 0.01, 0.002])
    return np.sin(2 * np.pi * 12.0 * np.asarray(times_s))[:, None] * amplitude


def run_device(rate_hz: float, connection: Connection) -> None:
    """Child process: run the simulated device until told to stop; report its counts."""
    with SimulatedNetFt(flapping_load, rate_hz=rate_hz) as device:
        connection.send((device.rdt_port, device.http_port))
        connection.recv()  # the parent's "stop"
        connection.send({"records_sent": device.records_sent, "streaming_at_end": device.streaming})


def run_benchmark(duration_s: float, rate_hz: float) -> dict[str, Any]:
    """Stream for ``duration_s`` wall seconds; return the counts and rates."""
    context = multiprocessing.get_context(
        "fork"
    )  # before any thread starts here; the child runs the simulator
    parent_end, child_end = context.Pipe()
    child = context.Process(target=run_device, args=(rate_hz, child_end), daemon=True)
    child.start()
    try:
        rdt_port, http_port = parent_end.recv()
        driver = NetFtDriver("127.0.0.1", rdt_port=rdt_port, http_port=http_port)
        largest_gap_s = 0.0
        with driver:
            cpu_start_s = time.process_time()
            driver.start_streaming()
            started_s = time.monotonic()
            last_arrival_s = started_s
            while time.monotonic() - started_s < duration_s:
                block = driver.get_block(timeout_s=1.0)
                if block is not None:
                    largest_gap_s = max(largest_gap_s, block.host_time_s - last_arrival_s)
                    last_arrival_s = block.host_time_s
            streamed_s = time.monotonic() - started_s  # start command to stop command
            driver.stop()
            cpu_s = time.process_time() - cpu_start_s
            while driver.get_block(timeout_s=0.0) is not None:
                pass
            health = driver.link_health()
        parent_end.send("stop")
        device = parent_end.recv()
    finally:
        child.join(5.0)
        if child.is_alive():
            child.kill()
    # the device's count includes the one record open() asks for to check the device answers
    sent_in_stream = device["records_sent"] - 1
    accounted = health.records_received + health.lost_records
    targets = {
        "no_lost_records": health.lost_records == 0 and health.blocks_dropped == 0,
        "accounting_balanced": accounted == sent_in_stream,
        "device_stopped": not device["streaming_at_end"],
    }
    return {
        "requested_rate_hz": rate_hz,
        "duration_s": streamed_s,
        "records": {
            "sent_by_device": sent_in_stream,
            "received": health.records_received,
            "lost": health.lost_records,
            "malformed_datagrams": health.malformed_datagrams,
            "driver_blocks_dropped": health.blocks_dropped,
            "expected_at_requested_rate": rate_hz * streamed_s,
        },
        "achieved_rate_hz": health.records_received / streamed_s,
        "achieved_over_requested_rate": health.records_received / (rate_hz * streamed_s),
        "largest_gap_between_blocks_s": largest_gap_s,
        "driver_process_cpu_s_per_s": cpu_s / streamed_s,
        "targets": targets,
        "all_targets_met": all(targets.values()),
    }


def render_table(result: dict[str, Any]) -> str:
    """The result as a readable table."""
    records = result["records"]
    rows = [
        ("requested rate", f"{result['requested_rate_hz']:.1f} records/s"),
        ("duration", f"{result['duration_s']:.2f} s"),
        ("records sent by device", f"{records['sent_by_device']}"),
        ("records received", f"{records['received']}"),
        ("records lost (rdt_sequence gaps)", f"{records['lost']}"),
        ("malformed datagrams", f"{records['malformed_datagrams']}"),
        ("driver blocks dropped", f"{records['driver_blocks_dropped']}"),
        ("achieved rate", f"{result['achieved_rate_hz']:.1f} records/s"),
        ("achieved / requested", f"{result['achieved_over_requested_rate']:.6f}"),
        ("largest gap between blocks", f"{result['largest_gap_between_blocks_s'] * 1000:.1f} ms"),
        ("driver process CPU", f"{result['driver_process_cpu_s_per_s']:.3f} CPU-s per s"),
    ]
    rows += [
        (f"target: {name}", "met" if met else "MISSED") for name, met in result["targets"].items()
    ]
    width = max(len(label) for label, _ in rows)
    return "\n".join(f"{label:<{width}}  {value}" for label, value in rows)


def main(argv: list[str] | None = None) -> int:
    """Parse the command line, run the benchmark, print it; return the exit code (0, 1 or 2)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--duration-s",
        type=float,
        default=DEFAULT_DURATION_S,
        help=f"wall seconds of streaming (default {DEFAULT_DURATION_S:g}, the issue's 10 min)",
    )
    parser.add_argument(
        "--rate-hz",
        type=float,
        default=DEFAULT_RATE_HZ,
        help=f"RDT rate, 7000 Hz divided by a whole number (default {DEFAULT_RATE_HZ:g})",
    )
    parser.add_argument("--json", action="store_true", help="print exactly one JSON object")
    arguments = parser.parse_args(argv)
    ratio = protocol.INTERNAL_SAMPLE_RATE_HZ / arguments.rate_hz if arguments.rate_hz > 0 else 0
    if not (math.isfinite(arguments.duration_s) and arguments.duration_s > 0):
        print(
            f"error: --duration-s: {arguments.duration_s:g} must be a positive number",
            file=sys.stderr,
        )
        return 2
    if not (ratio >= 1 and float(ratio).is_integer()):
        print(
            f"error: --rate-hz: {arguments.rate_hz:g} is not 7000 Hz divided by a whole number",
            file=sys.stderr,
        )
        return 2
    result = run_benchmark(arguments.duration_s, arguments.rate_hz)
    emit(result, arguments.json, render_table)
    return 0 if result["all_targets_met"] else 1


if __name__ == "__main__":
    sys.exit(main())
