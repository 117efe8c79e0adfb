"""Progress on stderr: timestamped lines when stderr is not a terminal (a log), at most every 5 s (a fake clock)."""

from __future__ import annotations

import io
import re

from ornitail.app.progress import LINE_INTERVAL_S, PROGRESS_LINE, Progress

LINE = re.compile(
    r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ sweep p: (\d+)/4 set points(, eta \d+ s)?(, .+)?$"
)


class FakeClock:
    def __init__(self) -> None:
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def test_lines_every_interval_from_the_start_at_a_stage_and_at_the_end():
    stream, clock = io.StringIO(), FakeClock()
    progress = Progress("sweep p", 4, "set points", stream=stream, clock=clock)
    assert not progress.terminal
    progress.update(0, eta_s=95.0)  # at the start: none (a command refused at once stays one line)
    clock.now_s += 1.0
    progress.update(1, eta_s=80.0)  # within the first interval: none
    progress.stage("tail change")  # a stage: at once
    clock.now_s += LINE_INTERVAL_S
    progress.update(2, item="theta 28 deg")  # interval passed: a line, time left from the rate
    clock.now_s += 1.0
    progress.update(3)  # within the interval: none
    progress.update(4)  # the end: a line
    progress.close()
    lines = stream.getvalue().splitlines()
    assert all(LINE.match(line) and PROGRESS_LINE.match(line) for line in lines), lines
    assert [LINE.match(line).group(1) for line in lines] == ["1", "2", "4"]
    assert lines[0].endswith(
        "1/4 set points, tail change"
    )  # a stage line makes no estimate of its own
    assert lines[1].endswith("2/4 set points, eta 6 s, theta 28 deg")  # 6 s for 2 points
    assert lines[2].endswith("4/4 set points")


def test_a_warning_is_its_own_line():
    stream = io.StringIO()
    Progress("sweep p", 4, "set points", stream=stream).message("warning: set point 3 saturated")
    assert stream.getvalue() == "warning: set point 3 saturated\n"
    assert not PROGRESS_LINE.match("warning: set point 3 saturated")
