"""Benchmark: stream the simulated ORNI-DAQ9 board through the real driver and recorder.

The simulated board (``ornitail.simulated_instruments.daq_board``) runs in real time (time scale 1)
behind a pty; :class:`SerialDaqDriver` reads and parses the frames and hands every block, in its
reader thread, to :class:`Recorder`, which writes them to ``samples.h5`` in a temporary data root.
The script prints the samples lost, CRC errors, achieved / requested rate, the CPU seconds the
driver's reader thread and the recorder's writer thread use per second of data, and the link
ceiling (baud / 250 bits per frame).

Baseline, measured in the same process: a plain pyserial reader of the same board's byte stream at
the same rate that only reads and discards the bytes (no parsing, no recording). It runs for half
of ``--baseline-s`` before and half after the main run, so drift of the machine shows up in both.

Targets (issue 3): zero lost samples over 10 minutes at 10 kHz; driver + recorder under
0.2 CPU-seconds per second of data. Exit code 0 if every target is met, 1 if one is missed, 2 for a
bad command-line value. Usage and the meaning of each number: ``benchmarks/README.md``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import serial

from ornitail.acquisition.daq_protocol import (
    CHANNEL_NAMES,
    DEFAULT_BAUD,
    FRAME_LENGTH_BYTES,
    MINIMUM_SAMPLE_RATE_HZ,
    link_ceiling_frames_per_s,
)
from ornitail.acquisition.recorder import Recorder
from ornitail.acquisition.recording_layout import ChannelSpec, RunConfiguration, StreamLayout
from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.serial_daq_driver import DaqBlock, SerialDaqDriver
from ornitail.app.cli_output import emit
from ornitail.core.errors import UserInputError, require_finite
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.daq_board import SimulatedDaqBoard
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

CPU_TARGET_S_PER_S_OF_DATA = 0.2
DEFAULT_DURATION_S = 30.0
DEFAULT_RATE_HZ = 10_000.0
LONGEST_DEFAULT_BASELINE_S = 10.0
LINK_HEALTH_REPORT_INTERVAL_S = 1.0
SIGNAL_SEED = 0


@dataclass
class RawReadBaseline:
    """CPU cost of only reading the board's byte stream from the pty.

    duration_s : wall time the reader ran, s. bytes_read : bytes it read. frames_per_s : bytes_read
    / 25 / duration_s (how much of the stream it saw). reader_cpu_s : CPU time of the reader
    thread, s. cpu_s_per_s_of_data : reader_cpu_s / duration_s.
    """

    duration_s: float
    bytes_read: int
    frames_per_s: float
    reader_cpu_s: float
    cpu_s_per_s_of_data: float


@dataclass
class StreamMeasurement:
    """What one driver + recorder run at ``rate_hz`` for ``duration_s`` of wall time did.

    Sample counts are numbers of samples; CPU times are seconds of CPU; ``duration_s`` is the wall
    time between ``start()`` and ``stop()`` of the driver, s.
    """

    rate_hz: float
    duration_s: float
    board_samples_taken: int
    board_samples_dropped: int
    recorded_samples: int
    link_lost_samples: int
    recorder_queue_lost_samples: int
    driver_blocks_dropped: int
    file_counter_gap_missing_samples: int
    crc_errors: int
    truncated_frames: int
    garbage_bytes: int
    reader_cpu_s: float
    writer_cpu_s: float
    process_cpu_s: float
    samples_file_bytes: int
    link_ceiling_hz: float
    exit_status: str


def _start_board(rate_hz: float) -> SimulatedDaqBoard:
    signals = SharedTunnelSignals.from_simulator(seed=SIGNAL_SEED, sample_rate_hz=rate_hz)
    return SimulatedDaqBoard(signals, SimulatedClock(1.0), sample_rate_hz=rate_hz).start()


def _command(port: serial.Serial, line: str) -> str:
    port.write(line.encode("ascii") + b"\n")
    reply = port.read_until(b"\n")
    if not reply.endswith(b"\n"):
        raise RuntimeError(f"simulated board did not answer {line!r} (got {reply!r})")
    return reply.decode("ascii").strip()


def measure_raw_read_baseline(duration_s: float, rate_hz: float) -> RawReadBaseline:
    """Read a simulated board's stream at ``rate_hz`` for ``duration_s`` s, discarding the bytes.

    The reader uses the driver's own read pattern (``read(in_waiting or 1)``, 50 ms timeout) so the
    difference to the driver is parsing, conversion to volts and handing blocks to the recorder.
    """
    board = _start_board(rate_hz)
    try:
        port = serial.Serial(board.port_path, DEFAULT_BAUD, timeout=0.05, write_timeout=1.0)
        try:
            port.reset_input_buffer()
            _command(port, f"RATE {rate_hz:g}")
            stop_requested = threading.Event()
            totals = {"bytes": 0, "cpu_s": 0.0}

            def read_and_discard() -> None:
                cpu_at_start_s = time.thread_time()
                while not stop_requested.is_set():
                    totals["bytes"] += len(port.read(port.in_waiting or 1))
                totals["cpu_s"] = time.thread_time() - cpu_at_start_s

            if _command(port, "START") != "OK":
                raise RuntimeError("simulated board refused START")
            reader = threading.Thread(target=read_and_discard, name="baseline reader")
            started_s = time.monotonic()
            reader.start()
            time.sleep(duration_s)
            stop_requested.set()
            reader.join()
            elapsed_s = time.monotonic() - started_s
            port.write(b"STOP\n")
        finally:
            port.close()
    finally:
        board.close()
    return RawReadBaseline(
        duration_s=elapsed_s,
        bytes_read=totals["bytes"],
        frames_per_s=totals["bytes"] / FRAME_LENGTH_BYTES / elapsed_s,
        reader_cpu_s=totals["cpu_s"],
        cpu_s_per_s_of_data=totals["cpu_s"] / elapsed_s,
    )


def measure_driver_and_recorder(
    duration_s: float, rate_hz: float, data_root: Path
) -> StreamMeasurement:
    """Stream ``duration_s`` s at ``rate_hz`` through SerialDaqDriver into a Recorder under
    ``data_root``, then read the recording back to count what reached the file."""
    board = _start_board(rate_hz)
    try:
        layout = StreamLayout(
            [ChannelSpec(name, "V") for name in CHANNEL_NAMES], rate_hz, counter_dtype="uint32"
        )
        configuration = RunConfiguration(None, None, False, plan_name="daq_stream_benchmark")
        rig = {"balance": "simulated ORNI-DAQ9", "port": board.port_path, "baud": DEFAULT_BAUD}
        with Recorder(data_root, configuration, layout, rig_description=rig) as recorder:

            def record_block(block: DaqBlock) -> None:
                recorder.put_block(block.counters, block.volts)

            driver = SerialDaqDriver(
                board.port_path, name="simulated ORNI-DAQ9", block_callback=record_block
            )
            driver.open()
            try:
                driver.set_sample_rate(rate_hz)
                process_cpu_at_start_s = time.process_time()
                started_s = time.monotonic()
                driver.start()
                reported_crc_errors = reported_lost_samples = 0
                while (remaining_s := started_s + duration_s - time.monotonic()) > 0:
                    time.sleep(min(LINK_HEALTH_REPORT_INTERVAL_S, remaining_s))
                    driver.raise_if_failed()
                    if not driver.streaming:
                        raise RuntimeError("the driver's reader thread ended during the benchmark")
                    statistics = driver.statistics
                    recorder.report_link_health(
                        crc_errors=statistics.crc_failures - reported_crc_errors,
                        lost_samples=statistics.lost_samples - reported_lost_samples,
                    )
                    reported_crc_errors = statistics.crc_failures
                    reported_lost_samples = statistics.lost_samples
                stopped_s = time.monotonic()
                driver.stop()
                statistics = driver.statistics
                recorder.report_link_health(
                    crc_errors=statistics.crc_failures - reported_crc_errors,
                    lost_samples=statistics.lost_samples - reported_lost_samples,
                )
            finally:
                driver.close()
        process_cpu_s = time.process_time() - process_cpu_at_start_s
        board_samples_taken = board.samples_sent + board.samples_dropped_by_board
        board_samples_dropped = board.samples_dropped_by_board
    finally:
        board.close()
    recording = load_recording(recorder.run_directory)
    metadata = recording.metadata
    return StreamMeasurement(
        rate_hz=rate_hz,
        duration_s=stopped_s - started_s,
        board_samples_taken=board_samples_taken,
        board_samples_dropped=board_samples_dropped,
        recorded_samples=recording.sample_count,
        link_lost_samples=statistics.lost_samples,
        recorder_queue_lost_samples=metadata["queue_overflow"]["lost_samples"],
        driver_blocks_dropped=driver.blocks_dropped,
        file_counter_gap_missing_samples=metadata["counter_gaps"]["missing_samples"],
        crc_errors=statistics.crc_failures,
        truncated_frames=statistics.truncated_frames,
        garbage_bytes=statistics.garbage_bytes,
        reader_cpu_s=driver.reader_cpu_s,
        writer_cpu_s=float(metadata["writer_cpu_s"]),
        process_cpu_s=process_cpu_s,
        samples_file_bytes=recording.samples_path.stat().st_size,
        link_ceiling_hz=driver.link_ceiling_hz(),
        exit_status=recording.status,
    )


def summarize(stream: StreamMeasurement, baselines: list[RawReadBaseline]) -> dict[str, Any]:
    """Turn the measurements into the printed result: losses, rates, CPU per s of data, ratios."""
    data_s = stream.recorded_samples / stream.rate_hz
    lost_samples = stream.link_lost_samples + stream.recorder_queue_lost_samples
    driver_and_recorder_cpu_s = stream.reader_cpu_s + stream.writer_cpu_s
    cpu_per_s = driver_and_recorder_cpu_s / data_s if data_s > 0 else float("inf")
    baseline_cpu_per_s = sum(b.cpu_s_per_s_of_data for b in baselines) / len(baselines)
    targets = {
        "no_lost_samples": lost_samples == 0 and stream.driver_blocks_dropped == 0,
        "driver_and_recorder_cpu_below_target": cpu_per_s < CPU_TARGET_S_PER_S_OF_DATA,
        "accounting_balanced": stream.recorded_samples + lost_samples == stream.board_samples_taken,
        "recording_completed": stream.exit_status == "completed",
    }
    return {
        "benchmark": "daq_stream",
        "requested_rate_hz": stream.rate_hz,
        "duration_s": stream.duration_s,
        "link_ceiling_hz": stream.link_ceiling_hz,
        "link_utilisation": stream.rate_hz / stream.link_ceiling_hz,
        "samples": {
            "board_taken": stream.board_samples_taken,
            "recorded": stream.recorded_samples,
            "expected_at_requested_rate": stream.rate_hz * stream.duration_s,
            "lost": lost_samples,
            "lost_on_link": stream.link_lost_samples,
            "lost_in_recorder_queue": stream.recorder_queue_lost_samples,
            "dropped_by_board_fifo": stream.board_samples_dropped,
            "driver_blocks_dropped": stream.driver_blocks_dropped,
            "file_counter_gap_missing": stream.file_counter_gap_missing_samples,
        },
        "link": {
            "crc_errors": stream.crc_errors,
            "truncated_frames": stream.truncated_frames,
            "garbage_bytes": stream.garbage_bytes,
        },
        "achieved_rate_hz": stream.recorded_samples / stream.duration_s,
        "achieved_over_requested_rate": stream.recorded_samples
        / (stream.rate_hz * stream.duration_s),
        "cpu_s": {
            "driver_reader_thread": stream.reader_cpu_s,
            "recorder_writer_thread": stream.writer_cpu_s,
            "whole_process": stream.process_cpu_s,
        },
        "cpu_s_per_s_of_data": {
            "driver_reader_thread": stream.reader_cpu_s / data_s,
            "recorder_writer_thread": stream.writer_cpu_s / data_s,
            "driver_and_recorder": cpu_per_s,
            "whole_process": stream.process_cpu_s / data_s,
            "target_driver_and_recorder": CPU_TARGET_S_PER_S_OF_DATA,
        },
        "baseline_raw_pty_read": {
            "runs": [asdict(baseline) for baseline in baselines],
            "cpu_s_per_s_of_data": baseline_cpu_per_s,
        },
        "ratio_to_baseline": {
            "driver_reader_thread": stream.reader_cpu_s / data_s / baseline_cpu_per_s,
            "driver_and_recorder": cpu_per_s / baseline_cpu_per_s,
        },
        "samples_file_mb_per_s_of_data": stream.samples_file_bytes / 1e6 / data_s,
        "targets": targets,
        "all_targets_met": all(targets.values()),
    }


def run_benchmark(duration_s: float, rate_hz: float, baseline_s: float) -> dict[str, Any]:
    """Baseline (first half), driver + recorder run, baseline (second half); return the summary."""
    baselines = [measure_raw_read_baseline(baseline_s / 2, rate_hz)]
    with tempfile.TemporaryDirectory(prefix="ornitail-daq-bench-") as data_root:
        stream = measure_driver_and_recorder(duration_s, rate_hz, Path(data_root))
    baselines.append(measure_raw_read_baseline(baseline_s / 2, rate_hz))
    return summarize(stream, baselines)


def render_table(result: dict[str, Any]) -> str:
    """The summary as a readable two-column table."""
    samples, link = result["samples"], result["link"]
    per_s, ratio = result["cpu_s_per_s_of_data"], result["ratio_to_baseline"]
    baseline = result["baseline_raw_pty_read"]
    rows = [
        ("requested rate", f"{result['requested_rate_hz']:.0f} Hz"),
        ("duration (wall)", f"{result['duration_s']:.2f} s"),
        (
            "link ceiling",
            f"{result['link_ceiling_hz']:.0f} Hz (baud / 250 bits per frame; "
            f"{100 * result['link_utilisation']:.1f} % used)",
        ),
        ("samples taken by board", f"{samples['board_taken']}"),
        ("samples recorded", f"{samples['recorded']}"),
        (
            "samples lost",
            f"{samples['lost']} (link {samples['lost_on_link']}, "
            f"recorder queue {samples['lost_in_recorder_queue']})",
        ),
        ("driver blocks dropped", f"{samples['driver_blocks_dropped']}"),
        ("board FIFO drops", f"{samples['dropped_by_board_fifo']}"),
        ("counter-gap samples in file", f"{samples['file_counter_gap_missing']}"),
        ("CRC errors", f"{link['crc_errors']}"),
        ("truncated frames", f"{link['truncated_frames']}"),
        ("garbage bytes", f"{link['garbage_bytes']}"),
        ("achieved / requested rate", f"{result['achieved_over_requested_rate']:.6f}"),
        ("CPU-s per s: driver reader", f"{per_s['driver_reader_thread']:.4f}"),
        ("CPU-s per s: recorder writer", f"{per_s['recorder_writer_thread']:.4f}"),
        (
            "CPU-s per s: driver + recorder",
            f"{per_s['driver_and_recorder']:.4f} (target < {per_s['target_driver_and_recorder']})",
        ),
        ("CPU-s per s: whole process", f"{per_s['whole_process']:.4f} (includes the simulator)"),
        (
            "CPU-s per s: baseline raw read",
            f"{baseline['cpu_s_per_s_of_data']:.4f} (mean of "
            + ", ".join(f"{run['cpu_s_per_s_of_data']:.4f}" for run in baseline["runs"])
            + ")",
        ),
        ("ratio driver reader / baseline", f"{ratio['driver_reader_thread']:.2f}"),
        ("ratio driver + recorder / baseline", f"{ratio['driver_and_recorder']:.2f}"),
        ("samples.h5 per s of data", f"{result['samples_file_mb_per_s_of_data']:.3f} MB"),
    ]
    rows += [
        (f"target: {name}", "met" if met else "MISSED") for name, met in result["targets"].items()
    ]
    width = max(len(name) for name, _ in rows)
    return "\n".join(f"{name:<{width}}  {value}" for name, value in rows)


def _positive_finite(where: str, value: float) -> float:
    require_finite(where, value)
    if value <= 0:
        raise UserInputError(where, f"{value:g} must be > 0")
    return value


def main(argv: list[str] | None = None) -> int:
    """Parse the command line, run the benchmark, print it; return the exit code (0, 1 or 2)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--duration-s",
        type=float,
        default=DEFAULT_DURATION_S,
        help=f"wall seconds of streaming (default {DEFAULT_DURATION_S:g})",
    )
    parser.add_argument(
        "--rate-hz",
        type=float,
        default=DEFAULT_RATE_HZ,
        help=f"sample rate, Hz (default {DEFAULT_RATE_HZ:g})",
    )
    parser.add_argument(
        "--baseline-s",
        type=float,
        default=None,
        help="wall seconds of the raw-read baseline, split before/after the run "
        f"(default: min(duration, {LONGEST_DEFAULT_BASELINE_S:g}))",
    )
    parser.add_argument("--json", action="store_true", help="print exactly one JSON object")
    arguments = parser.parse_args(argv)
    try:
        duration_s = _positive_finite("--duration-s", arguments.duration_s)
        rate_hz = _positive_finite("--rate-hz", arguments.rate_hz)
        ceiling_hz = link_ceiling_frames_per_s(DEFAULT_BAUD)
        if not MINIMUM_SAMPLE_RATE_HZ <= rate_hz <= ceiling_hz:
            raise UserInputError(
                "--rate-hz",
                f"{rate_hz:g} Hz is outside {MINIMUM_SAMPLE_RATE_HZ:g}..{ceiling_hz:g} Hz "
                f"(link ceiling = {DEFAULT_BAUD} baud / 250 bits per frame)",
            )
        baseline_s = arguments.baseline_s
        if baseline_s is None:
            baseline_s = min(duration_s, LONGEST_DEFAULT_BASELINE_S)
        baseline_s = _positive_finite("--baseline-s", baseline_s)
    except UserInputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    result = run_benchmark(duration_s, rate_hz, baseline_s)
    emit(result, arguments.json, render_table)
    return 0 if result["all_targets_met"] else 1


if __name__ == "__main__":
    sys.exit(main())
