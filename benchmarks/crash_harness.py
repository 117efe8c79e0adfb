"""Crash harness: `ornitail sweep` killed and signalled at random phases against instruments that outlive it.

The simulated rig's instruments run in a process of their own (``python -m
ornitail.simulated_instruments.rig_simulator_server``, on ptys), so, as with hardware, they outlive a killed host:
the fan and motor keep turning and the DAQ board keeps streaming. The harness runs ``ornitail sweep`` as a
subprocess and sends it kill -9, SIGTERM, SIGHUP or SIGINT (once or twice) at a random moment, then checks:

- samples lost at a kill -9: the board's counter right after the kill against the last counter on disk (in
  seconds of data, and in wall seconds = what a rig at time scale 1 would lose);
- after SIGTERM, SIGHUP and SIGINT: the documented exit code, a stop record on every run (none left ``running``),
  the reason naming the signal, and fan, motor and strut in their safe state (queried from the simulator);
- ``ornitail sweep --resume`` completes without help every time, and every plan point is recorded across the chain
  (whole records), each measurement exactly once (the tares bracketing a point recorded again are recorded again
  in its run: its zero), with fan, motor and strut safe afterwards;
- exclusive access: a second sweep on the same rig, and a second ``--resume`` of one crashed chain, are refused
  (exit 5, one line) while the first goes on unharmed.

Run it (it takes a while; nice it on a shared machine)::

    nice python benchmarks/crash_harness.py --kill9 30 --sigterm 30 --sighup 8 --sigint 8

It prints the figures; ``--json`` prints them as one JSON object instead.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import random
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ornitail.acquisition.recording_reader import load_recording
from ornitail.acquisition.run_files import read_journal
from ornitail.simulated_instruments.rig_simulator_server import SimulatorControl

ORNITAIL = str(Path(sys.executable).parent / "ornitail")
EXIT_BUSY = 5
EXPECTED_EXIT = {"sigterm": 143, "sighup": 129, "sigint": 130, "sigint2": 130}
SIGNALS = {
    "kill9": signal.SIGKILL,
    "sigterm": signal.SIGTERM,
    "sighup": signal.SIGHUP,
    "sigint": signal.SIGINT,
    "sigint2": signal.SIGINT,
}
COUNTER_MODULUS = 2**32
PLAN = """
[plan]
name = "crash-harness"
[configuration]
tail_id = "S3"
x_h_mm = 98
[steady_state]
theta_deg = 25.0
v_m_s = 0.8
f_hz = 13.5
[sweeps]
v_m_s = [-0.2, 0.2]
[protocol]
steady_state_repeats = 1
record_s = {record_s}
sample_rate_hz = {rate}
[settle]
stable_for_s = 0.3
"""


@dataclass
class SimulatorServer:
    """A running ``rig_simulator_server`` process: its rig file, control client and time scale."""

    process: subprocess.Popen
    rig_file: Path
    control: SimulatorControl
    time_scale: float
    ports: dict[str, str]

    def stop(self) -> None:
        """End the server (SIGTERM, then kill)."""
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def start_server(directory: Path, time_scale: float, timeout_s: float = 120.0) -> SimulatorServer:
    """Start the simulator server in ``directory`` and wait (up to ``timeout_s``) for its JSON line."""
    directory.mkdir(parents=True, exist_ok=True)
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "ornitail.simulated_instruments.rig_simulator_server",
            "--directory",
            str(directory),
            "--time-scale",
            repr(time_scale),
        ],
        stdout=subprocess.PIPE,
        stderr=open(directory / "server.err", "w"),  # noqa: SIM115 - the server's lifetime
        text=True,
        start_new_session=True,
    )
    line: list[str] = []
    reader = threading.Thread(target=lambda: line.append(process.stdout.readline()), daemon=True)
    reader.start()
    reader.join(timeout_s)
    if not line or not line[0].strip():
        process.kill()
        raise RuntimeError(
            f"the simulator server did not start: {(directory / 'server.err').read_text()}"
        )
    announced = json.loads(line[0])
    return SimulatorServer(
        process,
        Path(announced["rig_file"]),
        SimulatorControl(announced["control"]),
        time_scale,
        dict(announced["ports"]),
    )


def write_plan(path: Path, sample_rate_hz: float, record_s: float = 0.5) -> Path:
    """The harness's short plan (tare + 3 tailed points, tare + 1 tailless point) at ``sample_rate_hz``, with
    ``record_s`` of data per point."""
    path.write_text(
        PLAN.replace("{rate}", f"{sample_rate_hz:g}").replace("{record_s}", f"{record_s:g}")
    )
    return path


def spawn_sweep(
    plan: Path, rig_file: Path, data_root: Path, *, resume: bool = False
) -> subprocess.Popen:
    """``ornitail sweep PLAN --rig RIG --data-root ROOT --json [--resume]`` as a process of its own session."""
    data_root.mkdir(parents=True, exist_ok=True)
    suffix = "resume" if resume else "sweep"
    arguments = [
        ORNITAIL,
        "sweep",
        str(plan),
        "--rig",
        str(rig_file),
        "--data-root",
        str(data_root),
        "--json",
    ]
    return subprocess.Popen(
        arguments + (["--resume"] if resume else []),
        stdout=open(data_root / f"{suffix}.out", "w"),  # noqa: SIM115 - closed with the process
        stderr=open(data_root / f"{suffix}.err", "w"),  # noqa: SIM115
        stdin=subprocess.DEVNULL,
        start_new_session=True,
    )


def run_directories(data_root: Path) -> list[Path]:
    """Run directories under ``data_root``, oldest first."""
    runs = data_root / "runs"
    return sorted(runs.iterdir()) if runs.is_dir() else []


def journalled_points(data_root: Path) -> int:
    """Set points journalled so far in every run under ``data_root`` (readable while a sweep records)."""
    return sum(len(read_journal(directory)) for directory in run_directories(data_root))


def whole_record_counts(data_root: Path) -> collections.Counter:
    """How often each plan point was journalled with a whole record, over every run under ``data_root``."""
    return collections.Counter(
        record.plan_point_index
        for directory in run_directories(data_root)
        for record in read_journal(directory)
        if record.samples_missing_in_record == 0
    )


def recorded_once_each(data_root: Path, total_points: int) -> bool:
    """Every plan point journalled whole, each measurement exactly once: a resumed sweep records the wind-off
    tares that bracket a point it records again a second time (the point's zero comes from its own run)."""
    records = [
        record
        for directory in run_directories(data_root)
        for record in read_journal(directory)
        if record.samples_missing_in_record == 0
    ]
    measurements = collections.Counter(
        record.plan_point_index for record in records if record.kind != "tare"
    )
    return {record.plan_point_index for record in records} == set(range(total_points)) and all(
        count == 1 for count in measurements.values()
    )


def sweep_under_way(data_root: Path) -> bool:
    """True once the sweep holds its chain lock: its signal handlers are in place and it is about to connect."""
    locks = data_root / "locks"
    return locks.is_dir() and any(locks.glob("sweep-*.lock"))


def wait_until(condition, timeout_s: float, interval_s: float = 0.05) -> bool:
    """Poll ``condition`` until it is true or ``timeout_s`` passed; return whether it became true."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(interval_s)
    return bool(condition())


def rig_safe(state: dict[str, Any]) -> dict[str, bool]:
    """Fan and motor commanded to zero, strut not moving (from a simulator state)."""
    return {name: bool(state[name]["safe"]) for name in ("fan", "motor", "strut")}


def last_counter_on_disk(run_directory: Path) -> int | None:
    """The board counter of the last row in a run's samples file (None: no rows)."""
    recording = load_recording(run_directory)
    if recording.sample_count == 0:
        return None
    counters, _ = recording.read_raw(recording.sample_count - 1, recording.sample_count - 1)
    return int(counters[0])


@dataclass
class Trial:
    """One signal sent to one sweep, what followed, and the resume."""

    kind: str
    delay_s: float
    points_at_signal: int = 0
    runs_at_signal: int = 0
    exit_code: int | None = None
    exit_after_signal_s: float | None = None
    stderr_tail: str = ""
    counter_after_kill: int | None = None
    loss_samples: int | None = None
    run_statuses: list[str] = field(default_factory=list)
    newest_reason: str | None = None
    stop_records_ok: bool = True
    reason_names_signal: bool | None = None
    safe_before_signal: dict[str, bool] = field(default_factory=dict)
    safe_after_exit: dict[str, bool] = field(default_factory=dict)
    outcome: str = ""
    resume_exit_code: int | None = None
    resume_status: str | None = None
    exactly_once: bool = False
    safe_after_resume: dict[str, bool] = field(default_factory=dict)
    board_streaming_before_resume: bool | None = None
    link_samples_lost: int = 0


def run_trial(
    server: SimulatorServer,
    plan: Path,
    data_root: Path,
    kind: str,
    *,
    delay_s: float | None = None,
    after_points: int | None = None,
    total_points: int,
    rng: random.Random,
    timeout_s: float = 180.0,
    resume: bool = True,
) -> Trial:
    """Run a sweep, send ``kind`` ``delay_s`` wall seconds after the sweep took its chain lock (its handlers are
    installed; it is about to connect), or once ``after_points`` points are journalled; wait for the end, check,
    resume, check again."""
    trial = Trial(kind, delay_s if delay_s is not None else -1.0)
    process = spawn_sweep(plan, server.rig_file, data_root)
    if not wait_until(lambda: sweep_under_way(data_root) or process.poll() is not None, timeout_s):
        process.kill()
        raise RuntimeError(f"{kind}: the sweep did not start within {timeout_s} s")
    if after_points is not None:
        if not wait_until(lambda: journalled_points(data_root) >= after_points, timeout_s):
            process.kill()
            raise RuntimeError(
                f"{kind}: {after_points} point(s) not journalled within {timeout_s} s"
            )
    else:
        wait_until(lambda: process.poll() is not None, delay_s or 0.0)
    trial.points_at_signal = journalled_points(data_root)
    trial.runs_at_signal = len(run_directories(data_root))
    if kind != "kill9":  # a kill -9 is measured against the board's counter right after it
        trial.safe_before_signal = rig_safe(server.control.state())
    signalled = time.monotonic()
    if process.poll() is None:
        os.kill(process.pid, SIGNALS[kind])
        if kind == "kill9":
            trial.counter_after_kill = int(server.control.state()["daq"]["next_counter"])
        if kind == "sigint2":
            time.sleep(
                rng.uniform(0.05, 1.0)
            )  # the second Ctrl-C at a random moment after the first
            if process.poll() is None:
                os.kill(process.pid, signal.SIGINT)
    try:
        trial.exit_code = process.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        process.kill()
        trial.exit_code = process.wait()
        trial.outcome = "hung"
    trial.exit_after_signal_s = time.monotonic() - signalled
    trial.stderr_tail = (
        (data_root / "sweep.err").read_text(errors="replace").replace("\r", "\n")[-600:]
    )
    state = server.control.state()
    trial.safe_after_exit = rig_safe(state)
    trial.board_streaming_before_resume = bool(state["daq"]["streaming"])
    directories = run_directories(data_root)
    recordings = [load_recording(directory) for directory in directories]
    trial.run_statuses = [recording.status for recording in recordings]
    if recordings:
        trial.newest_reason = recordings[-1].metadata.get("failure_reason")
    if kind == "kill9":
        crashed = [d for d, r in zip(directories, recordings, strict=True) if r.status == "crashed"]
        if crashed and trial.counter_after_kill is not None:
            last = last_counter_on_disk(crashed[-1])
            if last is not None:
                trial.loss_samples = (trial.counter_after_kill - last - 1) % COUNTER_MODULUS
        trial.outcome = trial.outcome or (
            "killed while recording" if crashed else "killed outside a run"
        )
    else:
        trial.stop_records_ok = all(
            status not in ("running", "crashed") for status in trial.run_statuses
        )
        expected = EXPECTED_EXIT[kind]
        name = signal.Signals(SIGNALS[kind]).name
        if trial.exit_code == expected:
            trial.outcome = trial.outcome or "stopped"
            if recordings and trial.run_statuses[-1] == "aborted":
                reason = trial.newest_reason or ""
                # a first Ctrl-C ends the run at the next point ("stopped by the operator ..."), also when a
                # second one came too late to stop anything sooner
                trial.reason_names_signal = name in reason or (
                    kind.startswith("sigint") and "stopped by the operator" in reason
                )
        elif trial.exit_code == 0:
            trial.outcome = "signal after the sweep had completed"
        elif trial.exit_code is not None and trial.exit_code < 0 and not recordings:
            trial.outcome = "signal before the command had started (nothing connected)"
        else:
            trial.outcome = trial.outcome or f"unexpected exit code {trial.exit_code}"
    if not resume:
        return trial
    resumed = spawn_sweep(plan, server.rig_file, data_root, resume=True)
    try:
        trial.resume_exit_code = resumed.wait(timeout=timeout_s * 2)
    except subprocess.TimeoutExpired:
        resumed.kill()
        trial.resume_exit_code = resumed.wait()
    try:
        trial.resume_status = json.loads((data_root / "resume.out").read_text())["status"]
    except (OSError, ValueError, KeyError):
        trial.resume_status = None
    trial.exactly_once = recorded_once_each(data_root, total_points)
    trial.safe_after_resume = rig_safe(server.control.state())
    trial.link_samples_lost = sum(
        load_recording(directory).effective_metadata["counter_gaps"]["missing_samples"]
        for directory in run_directories(data_root)
    )
    return trial


def calibrate(server: SimulatorServer, plan: Path, data_root: Path) -> float:
    """Run one whole sweep; return its wall duration from taking the chain lock to the end (checks it
    completes)."""
    process = spawn_sweep(plan, server.rig_file, data_root)
    wait_until(lambda: sweep_under_way(data_root) or process.poll() is not None, 600)
    started = time.monotonic()
    code = process.wait(timeout=600)
    if code != 0:
        error = (data_root / "sweep.err").read_text()
        raise RuntimeError(f"the calibration sweep failed ({code}): {error}")
    return time.monotonic() - started


def second_sweep_on_the_same_rig(
    server: SimulatorServer, plan: Path, work: Path, total_points: int
) -> dict[str, Any]:
    """Start a sweep (a plan with long records), then a second one on the same rig (another data root): the
    second must be refused while the first goes on and completes."""
    first_root, second_root = work / "first", work / "second"
    first = spawn_sweep(plan, server.rig_file, first_root)
    wait_until(lambda: journalled_points(first_root) >= 1, 300)
    second = spawn_sweep(plan, server.rig_file, second_root)
    second_code = second.wait(timeout=300)
    first_running_when_refused = first.poll() is None
    first_code = first.wait(timeout=600)
    counts = whole_record_counts(first_root)
    error = (second_root / "sweep.err").read_text().strip().splitlines()
    return {
        "second_exit_code": second_code,
        "second_error": error[-1] if error else "",
        "second_one_line": len([line for line in error if line.startswith("ornitail:")]) == 1,
        "names_first_pid": f"process {first.pid}" in (error[-1] if error else ""),
        "second_recorded_nothing": not run_directories(second_root),
        "first_running_when_refused": first_running_when_refused,
        "first_exit_code": first_code,
        "first_complete_once": set(counts) == set(range(total_points))
        and all(count == 1 for count in counts.values()),
    }


def two_resumes_of_one_crashed_chain(
    server: SimulatorServer, plan: Path, data_root: Path, total_points: int
) -> dict[str, Any]:
    """Crash a sweep with kill -9 after its first point, then start two ``--resume`` at once."""
    first = spawn_sweep(plan, server.rig_file, data_root)
    wait_until(lambda: journalled_points(data_root) >= 1, 300)
    first.kill()
    first.wait()
    resumes = []
    for index in range(2):
        folder = data_root / f"resume-{index}"
        folder.mkdir(parents=True, exist_ok=True)
        arguments = [ORNITAIL, "sweep", str(plan), "--rig", str(server.rig_file)]
        arguments += ["--data-root", str(data_root), "--resume", "--json"]
        resumes.append(
            subprocess.Popen(
                arguments,
                stdout=open(folder / "out", "w"),  # noqa: SIM115
                stderr=open(folder / "err", "w"),  # noqa: SIM115
                stdin=subprocess.DEVNULL,
                start_new_session=True,
            )
        )
    codes = sorted(process.wait(timeout=600) for process in resumes)
    errors = [
        line
        for index in range(2)
        for line in (data_root / f"resume-{index}" / "err").read_text().splitlines()
        if line.startswith("ornitail: error")
    ]
    return {
        "exit_codes": codes,
        "refusal": errors[0] if errors else "",
        "exactly_once": recorded_once_each(data_root, total_points),
    }


def _median_max(values: list[float]) -> str:
    if not values:
        return "n/a"
    return f"median {statistics.median(values):.3f}, max {max(values):.3f}"


def summarise(
    trials: list[Trial],
    concurrency: dict[str, Any],
    settings: dict[str, Any],
) -> dict[str, Any]:
    """The figures, per kind of signal."""
    by_kind: dict[str, list[Trial]] = collections.defaultdict(list)
    for trial in trials:
        by_kind[trial.kind].append(trial)
    rate, scale = settings["sample_rate_hz"], settings["time_scale"]
    figures: dict[str, Any] = {"settings": settings, "kinds": {}, "concurrency": concurrency}
    for kind, group in by_kind.items():
        entry: dict[str, Any] = {
            "trials": len(group),
            "outcomes": dict(collections.Counter(trial.outcome for trial in group)),
            "resume_completed": sum(
                trial.resume_exit_code == 0 and trial.resume_status == "completed"
                for trial in group
            ),
            "exactly_once": sum(trial.exactly_once for trial in group),
            "safe_after_resume": sum(all(trial.safe_after_resume.values()) for trial in group),
            "link_samples_lost": sum(trial.link_samples_lost for trial in group),
            "exit_after_signal_s": [round(trial.exit_after_signal_s or 0.0, 3) for trial in group],
        }
        if kind == "kill9":
            losses = [trial.loss_samples for trial in group if trial.loss_samples is not None]
            entry["recording_at_kill"] = len(losses)
            entry["loss_data_s"] = [loss / rate for loss in losses]
            entry["loss_wall_s"] = [loss / rate / scale for loss in losses]
            entry["loss_within_0_5_s_wall"] = sum(loss / rate / scale <= 0.5 for loss in losses)
            entry["left_running_by_dead_host"] = {
                name: sum(not trial.safe_after_exit.get(name, True) for trial in group)
                for name in ("fan", "motor", "strut")
            }
            entry["board_still_streaming_at_resume"] = sum(
                bool(trial.board_streaming_before_resume) for trial in group
            )
        else:
            entry["documented_exit_code"] = sum(
                trial.exit_code == EXPECTED_EXIT[kind] for trial in group
            )
            entry["stop_record_on_every_run"] = sum(trial.stop_records_ok for trial in group)
            named = [
                trial.reason_names_signal
                for trial in group
                if trial.reason_names_signal is not None
            ]
            entry["aborted_runs_naming_signal"] = f"{sum(named)}/{len(named)}"
            entry["safe_after_exit"] = sum(all(trial.safe_after_exit.values()) for trial in group)
        figures["kinds"][kind] = entry
    return figures


def render(figures: dict[str, Any]) -> str:
    """The figures as text."""
    settings = figures["settings"]
    lines = [
        f"crash harness: plan of {settings['total_points']} points, time scale {settings['time_scale']:g}, "
        f"DAQ {settings['sample_rate_hz']:g} Hz, whole sweep {settings['sweep_wall_s']:.1f} s wall, "
        f"{settings['trials']} trials in {settings['elapsed_min']:.1f} min (seed {settings['seed']})"
    ]
    for kind, entry in figures["kinds"].items():
        n = entry["trials"]
        lines.append(f"{kind} ({n}): outcomes {entry['outcomes']}")
        if kind == "kill9":
            lines.append(
                f"  samples lost at the kill ({entry['recording_at_kill']} kills while recording): data s "
                f"{_median_max(entry['loss_data_s'])}; wall s {_median_max(entry['loss_wall_s'])}; "
                f"<= 0.5 s wall: {entry['loss_within_0_5_s_wall']}/{entry['recording_at_kill']}"
            )
            lines.append(
                f"  left running by the dead host: {entry['left_running_by_dead_host']}; board still "
                f"streaming when --resume started: {entry['board_still_streaming_at_resume']}/{n}"
            )
        else:
            lines.append(
                f"  exit code {EXPECTED_EXIT[kind]}: {entry['documented_exit_code']}/{n}; stop record on every "
                f"run: {entry['stop_record_on_every_run']}/{n}; aborted runs naming the signal: "
                f"{entry['aborted_runs_naming_signal']}; fan/motor/strut safe after exit: "
                f"{entry['safe_after_exit']}/{n}"
            )
        lines.append(
            f"  --resume completed: {entry['resume_completed']}/{n}; every point exactly once: "
            f"{entry['exactly_once']}/{n}; safe after resume: {entry['safe_after_resume']}/{n}; "
            f"signal to exit s: {_median_max(entry['exit_after_signal_s'])}; link samples lost in the "
            f"kept files: {entry['link_samples_lost']}"
        )
    for name, outcome in figures["concurrency"].items():
        lines.append(f"{name}: {outcome}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the harness and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kill9", type=int, default=30)
    parser.add_argument("--sigterm", type=int, default=30)
    parser.add_argument("--sighup", type=int, default=8)
    parser.add_argument(
        "--sigint", type=int, default=8, help="half once (finish the point), half twice"
    )
    parser.add_argument(
        "--concurrency", type=int, default=2, help="rounds of the exclusive-access checks"
    )
    parser.add_argument("--time-scale", type=float, default=5.0)
    parser.add_argument("--sample-rate", type=float, default=2000.0)
    parser.add_argument("--seed", type=int, default=2018)
    parser.add_argument("--work", type=Path, default=None, help="folder kept for inspection")
    parser.add_argument("--json", action="store_true")
    arguments = parser.parse_args(argv)
    rng = random.Random(arguments.seed)
    work = arguments.work or Path(tempfile.mkdtemp(prefix="ornitail-crash-harness-"))
    work.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    server = start_server(work / "server", arguments.time_scale)
    try:
        plan = write_plan(work / "plan.toml", arguments.sample_rate)
        long_plan = write_plan(work / "long-plan.toml", arguments.sample_rate, record_s=10.0)
        sweep_wall_s = calibrate(server, plan, work / "calibration")
        total_points = len(whole_record_counts(work / "calibration"))
        kinds = ["kill9"] * arguments.kill9 + ["sigterm"] * arguments.sigterm
        kinds += ["sighup"] * arguments.sighup
        kinds += ["sigint"] * (arguments.sigint // 2) + ["sigint2"] * (
            arguments.sigint - arguments.sigint // 2
        )
        rng.shuffle(kinds)
        trials = []
        for index, kind in enumerate(kinds):
            trial = run_trial(
                server,
                plan,
                work / f"trial-{index:03d}-{kind}",
                kind,
                delay_s=rng.uniform(0.0, sweep_wall_s),
                total_points=total_points,
                rng=rng,
            )
            trials.append(trial)
            if not arguments.json:
                print(
                    f"[{index + 1}/{len(kinds)}] {kind:8s} at {trial.delay_s:5.2f} s ({trial.points_at_signal} "
                    f"points): exit {trial.exit_code}, {trial.outcome}; resume {trial.resume_exit_code} "
                    f"{trial.resume_status}, once {trial.exactly_once}, loss {trial.loss_samples}",
                    flush=True,
                )
        concurrency: dict[str, Any] = {}
        for round_index in range(arguments.concurrency):
            concurrency[f"second sweep on the same rig #{round_index + 1}"] = (
                second_sweep_on_the_same_rig(
                    server, long_plan, work / f"same-rig-{round_index}", total_points
                )
            )
            concurrency[f"two --resume of one crashed chain #{round_index + 1}"] = (
                two_resumes_of_one_crashed_chain(
                    server, plan, work / f"two-resumes-{round_index}", total_points
                )
            )
        settings = {
            "time_scale": arguments.time_scale,
            "sample_rate_hz": arguments.sample_rate,
            "total_points": total_points,
            "sweep_wall_s": sweep_wall_s,
            "trials": len(trials),
            "seed": arguments.seed,
            "elapsed_min": (time.monotonic() - started) / 60.0,
            "work": str(work),
        }
        figures = summarise(trials, concurrency, settings)
        figures["trials"] = [asdict(trial) for trial in trials]
        if arguments.json:
            print(json.dumps(figures))
        else:
            print(render(figures))
        (work / "figures.json").write_text(json.dumps(figures, indent=1))
    finally:
        server.stop()
        if arguments.work is None and os.environ.get("ORNITAIL_KEEP_HARNESS") is None:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
