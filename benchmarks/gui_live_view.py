"""The window's live view at 10 kHz: frames per second, GUI-thread CPU, and samples lost while recording.

Two phases in one process on the simulated rig at time scale 1 (the board streams 10 000 samples/s over a pty
through the real driver, LiveBalance pump and Recorder):

1. baseline: record for ``--duration-s`` with no window;
2. window: the same with the main window shown on the Live tab (offscreen unless a display is set), redrawing at
   its ~30 Hz timer.

Prints fps, GUI-thread CPU (s per s), recorder and link losses, and ratios of the recorder's writer CPU and the
process CPU with the window against without. Targets: at least 30 fps, zero samples lost. Exit 1 if missed.

    .venv/bin/python benchmarks/gui_live_view.py [--duration-s 20] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PySide6 import QtWidgets  # noqa: E402

from ornitail.acquisition.recording_reader import load_recording  # noqa: E402
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE  # noqa: E402
from ornitail.gui.main_window import MainWindow  # noqa: E402
from ornitail.gui.rig_session import RigSession  # noqa: E402

TARGET_FPS = 30.0


def _record(session: RigSession, seconds: float, spin) -> dict:
    """Record ``seconds`` into a manual run while ``spin`` keeps the process busy as it would be."""
    session.start_recording("S3", 98.0, True).result()
    process_cpu = time.process_time()
    wall = time.monotonic()
    spin(seconds)
    process_cpu = time.process_time() - process_cpu
    wall = time.monotonic() - wall
    recording = session.recording
    assert recording is not None
    directory = recording.recorder.run_directory
    session.stop_recording().result()
    metadata = load_recording(directory).metadata
    return {
        "wall_s": wall,
        "process_cpu_per_s": process_cpu / wall,
        "writer_cpu_s": metadata["writer_cpu_s"],
        "samples": metadata["sample_count"],
        "recorder_lost_samples": metadata["queue_overflow"]["lost_samples"],
        "link_lost_samples": metadata["link_health"]["lost_samples"],
        "counter_gap_samples": metadata["counter_gaps"]["missing_samples"],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration-s", type=float, default=20.0)
    parser.add_argument("--json", action="store_true")
    arguments = parser.parse_args()
    application = QtWidgets.QApplication(sys.argv)
    with tempfile.TemporaryDirectory() as data_root:
        session = RigSession(Path(data_root))
        window = MainWindow(session)
        session.connect(DEFAULT_RIG_FILE, 1.0).result()
        for future in (
            session.set_pitch_deg(25.0),
            session.set_tunnel_velocity(0.8),
            session.set_flapping_frequency(13.5),
        ):
            future.result()
        time.sleep(3.0)

        def idle(seconds: float) -> None:
            time.sleep(seconds)

        window.timer.stop()
        baseline = _record(session, arguments.duration_s, idle)
        window.timer.start()
        window.resize(1500, 950)
        window.show()
        gui = {}

        def run_window(seconds: float) -> None:
            frames, cpu = window.frames, time.thread_time()
            started = time.monotonic()
            while time.monotonic() - started < seconds:
                application.processEvents()
                time.sleep(0.001)
            gui["fps"] = (window.frames - frames) / (time.monotonic() - started)
            gui["gui_thread_cpu_per_s"] = (time.thread_time() - cpu) / (time.monotonic() - started)

        with_window = _record(session, arguments.duration_s, run_window)
        with_window.update(gui)
        window.close()
    lost = with_window["recorder_lost_samples"] + with_window["link_lost_samples"]
    lost += with_window["counter_gap_samples"]
    result = {
        "baseline": baseline,
        "with_window": with_window,
        "ratios": {
            "writer_cpu_with_over_without": with_window["writer_cpu_s"] / baseline["writer_cpu_s"],
            "process_cpu_with_over_without": with_window["process_cpu_per_s"]
            / baseline["process_cpu_per_s"],
        },
        "targets": {"fps_at_least_30": gui["fps"] >= TARGET_FPS, "zero_samples_lost": lost == 0},
    }
    if arguments.json:
        print(json.dumps(result, indent=2))
    else:
        print(f"{'':28s}{'no window':>14s}{'window':>14s}")
        for key in baseline:
            print(f"{key:28s}{baseline[key]:14.4g}{with_window[key]:14.4g}")
        print(f"frames per second: {gui['fps']:.1f} (target >= {TARGET_FPS:g})")
        print(f"GUI-thread CPU: {gui['gui_thread_cpu_per_s']:.3f} s per s")
        for name, value in result["ratios"].items():
            print(f"{name}: {value:.2f}")
        for name, met in result["targets"].items():
            print(f"{name}: {'met' if met else 'MISSED'}")
    return 0 if all(result["targets"].values()) else 1


if __name__ == "__main__":
    sys.exit(main())
