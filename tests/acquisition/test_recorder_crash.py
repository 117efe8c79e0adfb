"""kill -9 of a recording process: every flushed sample stays readable; the run reads as crashed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np

from ornitail.acquisition.catalog import RunCatalog
from ornitail.acquisition.recording_reader import load_recording

# A real recording process: 10 kHz x 9 channels in 0.1 s blocks, paced in real time, a set point
# every 0.5 s. After each block it prints "<flushed samples> <produced samples> <set points>".
RECORDING_SCRIPT = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from ornitail.acquisition.recorder import Recorder
    from ornitail.acquisition.recording_layout import (
        ChannelSpec, RunConfiguration, SetPointRecord, StreamLayout)
    from ornitail.acquisition.run_documents import DocumentDispatcher
    from ornitail.acquisition.run_engine import open_run

    data_root = sys.argv[1]
    layout = StreamLayout([ChannelSpec(f"channel_{i}", "V") for i in range(9)], 10_000.0)
    configuration = RunConfiguration("S3", 0.098, True, plan_name="crash_test")
    recorder = Recorder(data_root, configuration, layout)
    with open_run(recorder, DocumentDispatcher(), set_points_planned=0):  # as sweeps open their runs
        print(recorder.run_id, flush=True)
        start = time.monotonic()
        block_index = 0
        set_points = 0
        while True:
            counters = np.arange(block_index * 1000, (block_index + 1) * 1000, dtype=np.uint64)
            phase = counters.astype(np.float64)[:, None] * 1e-3 + np.arange(9)[None, :]
            recorder.put_block(counters, np.sin(phase))
            block_index += 1
            if block_index % 5 == 0:
                recorder.complete_set_point(SetPointRecord(
                    set_points, "measurement", (block_index - 5) * 1000, block_index * 1000 - 1,
                    0.26, 1.3, 12.0, True))
                set_points += 1
            time.sleep(max(0.0, start + block_index * 0.1 - time.monotonic()))
            print(recorder.flushed_sample_count, block_index * 1000, set_points, flush=True)
    """
)


def _record_and_kill(data_root, seconds_before_kill: float, jitter_s: float) -> dict:
    process = subprocess.Popen(
        [sys.executable, "-c", RECORDING_SCRIPT, str(data_root)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        run_id = process.stdout.readline().strip()
        started = time.monotonic()
        flushed = produced = 0
        while time.monotonic() - started < seconds_before_kill:
            flushed, produced, _ = (int(word) for word in process.stdout.readline().split())
        time.sleep(jitter_s)  # land the kill anywhere in the 0.1 s block cycle, also mid-write
        os.kill(process.pid, signal.SIGKILL)
    finally:
        process.kill()
        process.wait()
    return {"run_id": run_id, "last_reported_flushed": flushed, "produced": produced}


def test_kill_9_mid_stream_keeps_every_flushed_sample_and_reads_as_crashed(tmp_path):
    random = np.random.default_rng(20240607)
    losses_s = []
    kill_moments = zip(
        random.uniform(0.6, 1.6, size=3), random.uniform(0.0, 0.1, size=3), strict=True
    )
    for kill_number, (seconds_before_kill, jitter_s) in enumerate(kill_moments):
        data_root = tmp_path / f"kill_{kill_number}"
        data_root.mkdir()
        outcome = _record_and_kill(data_root, seconds_before_kill, jitter_s)
        assert outcome["last_reported_flushed"] > 0

        recording = load_recording(data_root / "runs" / outcome["run_id"])
        assert recording.status == "crashed"
        # Everything the process had reported as flushed before the kill is in the file.
        assert recording.sample_count >= outcome["last_reported_flushed"]
        frame = recording.samples_frame()
        counters = frame["sample_counter"].to_numpy()
        np.testing.assert_array_equal(counters, np.arange(recording.sample_count))
        phase = counters.astype(np.float64)[:, None] * 1e-3 + np.arange(9)[None, :]
        np.testing.assert_array_equal(frame.iloc[:, 2:].to_numpy(), np.sin(phase))
        # Journaled set points refer only to samples that are in the file.
        assert all(r.last_sample_index < recording.sample_count for r in recording.set_points)
        assert recording.effective_metadata["counter_gaps"]["count"] == 0

        catalog = RunCatalog(data_root)
        assert catalog.get_run(outcome["run_id"]).exit_status == "running"
        report = catalog.reconcile()
        assert report.crashed_run_ids == [outcome["run_id"]]
        entry = catalog.get_run(outcome["run_id"])
        assert entry.exit_status == "crashed"
        assert entry.sample_count == recording.sample_count
        assert entry.set_point_count == len(recording.set_points)
        assert catalog.reconcile().crashed_run_ids == []  # reconciling twice changes nothing
        losses_s.append((outcome["produced"] - recording.sample_count) / 10_000.0)
    print(f"data reported produced but not in the file at kill -9 (s): {losses_s}")


def test_sigterm_without_a_handler_also_leaves_a_readable_crashed_run(tmp_path):
    process = subprocess.Popen(
        [sys.executable, "-c", RECORDING_SCRIPT, str(tmp_path)], stdout=subprocess.PIPE, text=True
    )
    try:
        run_id = process.stdout.readline().strip()
        flushed = 0
        while flushed < 3000:
            flushed = int(process.stdout.readline().split()[0])
        process.send_signal(signal.SIGTERM)
        process.wait(timeout=30)
    finally:
        process.kill()
        process.wait()
    recording = load_recording(tmp_path / "runs" / run_id)
    assert recording.status == "crashed"
    assert recording.sample_count >= flushed
