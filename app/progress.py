"""Progress of a long command on stderr: a bar in a terminal, timestamped lines in a log.

In a terminal the user watches a click progress bar. When stderr is a file or a pipe (a log, ``nohup``, a CI job),
a bar would be one unreadable line, so progress is printed as lines instead, e.g.::

    2026-11-24T07:10:03Z sweep cli-short: 12/48 set points, eta 95 s

every :data:`LINE_INTERVAL_S` at most (the first one interval after the start, so that a command refused at once
still says so in one line), at each stage change and at the end.
"""

from __future__ import annotations

import contextlib
import re
import sys
import time
from collections.abc import Callable
from datetime import UTC, datetime
from typing import Any, TextIO

import click

LINE_INTERVAL_S = 5.0
"""Least time between two progress lines of one stage when stderr is not a terminal, s."""

PROGRESS_LINE = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ [^:]+: \d+/\d+ ")
"""Matches a progress line (UTC time, label, done/total), e.g. to tell them from warnings in a log."""


def _utc_now_text() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


class Progress:
    """A progress bar (terminal) or timestamped progress lines (anything else) on ``stream``.

    Parameters
    ----------
    label : str
        What is going on, e.g. ``"sweep cli-short"``; starts every line.
    total : int
        Items in all, e.g. set points.
    unit : str
        The items' name in the lines, e.g. ``"set points"``.
    stream : TextIO, optional
        Where to write (default: ``sys.stderr`` at construction).
    bar_delay_s : float
        The bar appears only once this much time has passed (quick commands show none), s. Lines are not delayed.
    clock : callable
        Monotonic time in s (for the line interval and the estimate of the time left).
    """

    def __init__(
        self,
        label: str,
        total: int,
        unit: str = "items",
        stream: TextIO | None = None,
        bar_delay_s: float = 0.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.label, self.total, self.unit = label, total, unit
        self.stream = stream if stream is not None else sys.stderr
        self.terminal = _is_terminal(self.stream)
        self.bar_delay_s = bar_delay_s
        self.clock = clock
        self.started_s = clock()
        self.done = 0
        self.last_line_s: float | None = None
        self.bar: Any = None

    def update(
        self, done: int, eta_s: float | None = None, item: str = "", total: int | None = None
    ) -> None:
        """``done`` of ``total`` items are finished; ``eta_s`` is the time left if the caller knows it (s); ``item``
        says what is going on (shown beside the bar, and ending a progress line).

        ``total`` replaces the total given at construction (for work whose size is known only once it runs).
        """
        self.done = done
        if total is not None and self.bar is None:
            self.total = total
        if self.terminal:
            self._update_bar(item)
            return
        now = self.clock()
        since_s = now - (self.started_s if self.last_line_s is None else self.last_line_s)
        if since_s >= LINE_INTERVAL_S or done >= self.total:
            self._line(now, eta_s, item)

    def stage(self, name: str) -> None:
        """A new stage (e.g. ``"tail change"``): a line naming it at once when stderr is not a terminal."""
        if (
            not self.terminal
        ):  # no estimate of the time left: the caller's own estimate comes with updates
            self._line(self.clock(), None, name, estimate=False)

    def message(self, text: str) -> None:
        """A line the user must see (a warning), below the bar or among the progress lines."""
        with contextlib.suppress(OSError):  # a closed terminal must not stop the work
            click.echo(f"\n{text}" if self.bar is not None else text, file=self.stream)

    def close(self) -> None:
        """End the bar (a terminal); nothing more to print otherwise."""
        if self.bar is not None:
            with contextlib.suppress(OSError):
                self.bar.__exit__(None, None, None)
            self.bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _update_bar(self, item: str) -> None:
        if self.bar is None:
            if self.clock() - self.started_s < self.bar_delay_s:
                return
            self.bar = click.progressbar(
                length=self.total,
                label=self.label,
                file=self.stream,
                show_eta=True,
                show_pos=True,
                item_show_func=lambda shown: shown or "",
            )
            self.bar.__enter__()
        with contextlib.suppress(OSError):
            self.bar.update(max(self.done - self.bar.pos, 0), item or None)

    def _line(self, now: float, eta_s: float | None, note: str = "", estimate: bool = True) -> None:
        self.last_line_s = now
        if estimate and eta_s is None and 0 < self.done < self.total:
            eta_s = (now - self.started_s) / self.done * (self.total - self.done)
        parts = [f"{_utc_now_text()} {self.label}: {self.done}/{self.total} {self.unit}"]
        if eta_s is not None and self.done < self.total:
            parts.append(f"eta {eta_s:.0f} s")
        if note:
            parts.append(note)
        with contextlib.suppress(OSError):
            click.echo(", ".join(parts), file=self.stream)


def _is_terminal(stream: TextIO) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False
