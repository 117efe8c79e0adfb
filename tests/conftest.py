"""A hard deadline for every test and for the end of the session: a hang fails fast, with every thread's stack;
and the README's demo run in the background while the tests that do not drive a simulated rig run.

pytest-timeout (``timeout`` in pyproject.toml, signal method) fails a test that runs too long, but only when the
main thread gets back to Python bytecode: a test stuck in native code (a Qt call, a lock taken in C) or whose
timeout lands inside a Qt slot (where PySide swallows it) would hang CI until its own limit. ``faulthandler``'s
watchdog thread needs no GIL: past ``HARD_DEADLINE_S`` it writes every thread's stack to the report and ends
the process with exit status 1. The same watchdog covers interpreter shutdown (threads joined at exit).

`ornitail demo` (tests/test_demo.py) spends about two minutes on its simulated rig (the fan spinning up and down around
27 wind-off tares; it takes about 0.7 of one core, measured beside the rig tests at stop 37). When the session holds the
demo's test, the demo is started as its own process when collection ends (under pytest-xdist, by the worker that runs
its test, when it does), and the tests that drive no simulated rig (simulator, flight, design, gap, calibration,
balance processing of simulated signals, the bad-input corpus) run first, while it records; the demo's test then only
reads what it printed. The demo retakes a record that lost samples, so a busy neighbour cannot change its results,
only its duration.

The whole suite (``bash scripts/test.sh`` without arguments) runs in two pytest sessions chosen by
``--ornitail-phase``, each on two xdist workers: ``no-rig`` beside the demo, then, once the demo has ended, ``rig``.
The script starts the demo itself and names its folder in ``ORNITAIL_TEST_DEMO_FOLDER`` (``stdout``, ``stderr`` and,
when it has ended, ``returncode``); the demo's test reads it there instead of starting one.

Why two rigs at once but no rig beside the rig-free tests. The rig tests mostly wait on their rigs' simulated time:
one process of them took 457 s of wall time and about 280 s of CPU time (stop 39), and two of them finish in 245 s,
each test as long as alone. The rig-free tests are CPU-bound (about 415 s of CPU time on two workers). Running the
rig tests beside those (the rig-free workers in the idle scheduling class) was tried at stops 37 and 38 and failed in
clean clones: an alignment estimate of 1.48 s, a strut's pty write timing out, and a sweep resumed after ``kill -9``
exiting 3. Until stop 38 the rig tests ran one at a time, and the suite took 13-17 minutes.
"""

from __future__ import annotations

import faulthandler
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

HARD_DEADLINE_S = 480.0
"""Setup, call and teardown of one test, s: well past pytest-timeout's 300 s and the slowest test (~60 s)."""
SHUTDOWN_DEADLINE_S = 120.0
"""From the end of the session to the end of the process, s."""

DEMO_TEST_FILE = "tests/test_demo.py"
RIG_BOUND_PATHS = (
    "tests/acquisition/",
    "tests/balance/test_portable_runs.py",
    "tests/balance/test_process_cli.py",
    "tests/gui/test_connect_failure.py",
    "tests/gui/test_sweeps_and_emergency_stop.py",
    "tests/gui/test_window_at_the_tunnel.py",
    "tests/gui/test_window_layout_and_faults.py",
    "tests/benchmarks/",
    "tests/gap/test_tunnel_recordings.py",
    DEMO_TEST_FILE,
)
"""Tests that drive a simulated rig or stream through a transport at rate (run after the others)."""
RIG_FIXTURES = {"simulated_rig", "simulated_daq", "simulated_netcanoem", "simulated_netft"}
LONGEST_FILES = (
    "tests/gap/test_flight_diagnosis.py",
    "tests/flight/test_campaign_coverage.py",
    "tests/flight/test_small_sample_sigma.py",
    "tests/gap/test_benchmark.py",
    "tests/balance/test_derivatives.py",
    "tests/gap/test_semi_real.py",
    "tests/flight/test_campaign_simulated.py",
    "tests/gap/test_lateral_model.py",
    "tests/gap/test_steady_state_diagnosis.py",
    "tests/gap/test_gap_pictures.py",
    "tests/flight/test_campaign_cli.py",
    "tests/design/test_design_pictures.py",
    "tests/gap/test_derivative_refit.py",
    "tests/design/test_proposal.py",
    "tests/flight/test_estimation_coverage.py",
)
"""The rig-free files that take longest (CPU time, longest first, as measured on two workers: the first
two about a minute each, the last about 10 s), run before the others. pytest-xdist's ``--dist loadfile``
hands out whole files in collection order once its ``--loadscope-reorder`` is off (:func:`pytest_configure`);
that default starts with the files that hold the most tests, which left these few-test, long files to the
end, one worker computing a campaign while the other had finished. Longest first leaves only short files to
even out the two workers' ends. A scheduling hint only: a file missing here runs all the same."""
PHASES = ("all", "no-rig", "rig")
"""``--ornitail-phase``: every test, those that drive no simulated rig, or those that do."""
EXTERNAL_DEMO_VARIABLE = "ORNITAIL_TEST_DEMO_FOLDER"
XDIST_WORKER_VARIABLE = "PYTEST_XDIST_WORKER"
"""Set by pytest-xdist in each of its worker processes."""
EXTERNAL_DEMO_POLL_S = 0.5
"""How often the demo's test looks for the externally started demo's return code, s (a deadline wait)."""

_terminal_fd: int | None = None


class BackgroundDemo:
    """`ornitail demo --json` in its own process and data folder, started once per session."""

    def __init__(self) -> None:
        self.folder = Path(tempfile.mkdtemp(prefix="ornitail-demo-"))
        self.process = subprocess.Popen(
            [
                str(Path(sys.executable).parent / "ornitail"),
                "demo",
                "--data-root",
                str(self.folder),
                "--json",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self._output: tuple[int, str, str] | None = None

    def result(self, timeout_s: float) -> tuple[int, str, str]:
        """Exit code, standard output and standard error, waiting up to ``timeout_s`` for the demo to end."""
        if self._output is None:
            stdout, stderr = self.process.communicate(timeout=timeout_s)
            self._output = (self.process.returncode, stdout, stderr)
        return self._output

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            self.process.communicate(timeout=60)
        shutil.rmtree(self.folder, ignore_errors=True)


class ExternalDemo:
    """`ornitail demo --json` started by scripts/test.sh before the first phase, read from its folder."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def result(self, timeout_s: float) -> tuple[int, str, str]:
        """Exit code, standard output and standard error, waiting up to ``timeout_s`` for the demo to end."""
        returncode_file = self.folder / "returncode"
        deadline = time.monotonic() + timeout_s
        while not returncode_file.exists():
            if time.monotonic() > deadline:
                stderr = (self.folder / "stderr").read_text(errors="replace").splitlines()
                raise TimeoutError(
                    f"the demo in {self.folder} did not end within {timeout_s:g} s; the end of its stderr:\n"
                    + "\n".join(stderr[-30:])
                )
            time.sleep(EXTERNAL_DEMO_POLL_S)
        returncode = returncode_file.read_text().strip()
        while not returncode:  # written but not yet flushed
            time.sleep(EXTERNAL_DEMO_POLL_S)
            returncode = returncode_file.read_text().strip()
        return (
            int(returncode),
            (self.folder / "stdout").read_text(),
            (self.folder / "stderr").read_text(),
        )

    def close(self) -> None:
        """scripts/test.sh removes the folder."""


_background_demo: BackgroundDemo | ExternalDemo | None = None


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--ornitail-phase",
        choices=PHASES,
        default="all",
        help="run every test (all), only those that drive no simulated rig (no-rig) or only those that do (rig)",
    )


def _drives_a_rig(item: pytest.Item) -> bool:
    return item.nodeid.startswith(RIG_BOUND_PATHS) or bool(
        RIG_FIXTURES & set(getattr(item, "fixturenames", ()))
    )


def _is_the_demo(item: pytest.Item) -> bool:
    return item.nodeid.startswith(DEMO_TEST_FILE)


def _length_rank(item: pytest.Item) -> int:
    """The item's file's place in :data:`LONGEST_FILES` (after them: the number of them)."""
    path = item.nodeid.split("::", 1)[0]
    return LONGEST_FILES.index(path) if path in LONGEST_FILES else len(LONGEST_FILES)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Only the phase's tests; those that drive no simulated rig first (the demo records meanwhile), the
    longest files among them first (:data:`LONGEST_FILES`), in their usual order otherwise; in the rig phase
    the demo's test first (it waits for the demo to end)."""
    phase = config.getoption("--ornitail-phase")
    if phase != "all":
        wanted = phase == "rig"
        deselected = [item for item in items if _drives_a_rig(item) != wanted]
        if deselected:
            config.hook.pytest_deselected(items=deselected)
            items[:] = [item for item in items if _drives_a_rig(item) == wanted]
    if phase == "rig":
        items.sort(key=lambda item: not _is_the_demo(item))
    else:
        items.sort(key=lambda item: (_drives_a_rig(item), _length_rank(item)))


def pytest_collection_finish(session: pytest.Session) -> None:
    global _background_demo
    if session.config.option.collectonly or not any(_is_the_demo(i) for i in session.items):
        return
    external = os.environ.get(EXTERNAL_DEMO_VARIABLE)
    if external:
        _background_demo = ExternalDemo(Path(external))
    elif XDIST_WORKER_VARIABLE not in os.environ:
        _background_demo = BackgroundDemo()
    # else: every xdist worker collects the demo's test; the one that runs it starts the demo (the fixture)


@pytest.fixture(scope="session")
def background_demo() -> BackgroundDemo | ExternalDemo:
    """The demo started when collection ended, or now in an xdist worker (see the module notes)."""
    global _background_demo
    if _background_demo is None:
        _background_demo = BackgroundDemo()
    return _background_demo


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    if _background_demo is not None:
        _background_demo.close()


def _terminal() -> int:
    """A duplicate of the standard output pytest reports on, taken before any test captured file descriptor 1."""
    global _terminal_fd
    if _terminal_fd is None:
        _terminal_fd = os.dup(sys.__stdout__.fileno())
    return _terminal_fd


def pytest_configure(config: pytest.Config) -> None:
    _terminal()
    if config.getoption("--ornitail-phase") != "rig" and hasattr(config.option, "loadscopereorder"):
        # pytest-xdist's --dist loadfile/loadscope would hand out the files with the most tests first
        # (--loadscope-reorder, its default), not the longest ones first (LONGEST_FILES)
        config.option.loadscopereorder = False


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    faulthandler.dump_traceback_later(HARD_DEADLINE_S, exit=True, file=_terminal())
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


def pytest_unconfigure(config: pytest.Config) -> None:
    faulthandler.dump_traceback_later(SHUTDOWN_DEADLINE_S, exit=True, file=_terminal())
