"""A hard deadline for every test and for the end of the session: a hang fails fast, with every thread's stack.

pytest-timeout (``timeout`` in pyproject.toml, signal method) fails a test that runs too long, but only when the
main thread gets back to Python bytecode: a test stuck in native code (a Qt call, a lock taken in C) or whose
timeout lands inside a Qt slot (where PySide swallows it) would hang CI until its own limit. ``faulthandler``'s
watchdog thread needs no GIL: past ``HARD_DEADLINE_S`` it writes every thread's stack to the report and ends
the process with exit status 1. The same watchdog covers interpreter shutdown (threads joined at exit).
"""

from __future__ import annotations

import faulthandler
import os
import sys

import pytest

HARD_DEADLINE_S = 480.0
"""Setup, call and teardown of one test, s: well past pytest-timeout's 300 s and the slowest test (~60 s)."""
SHUTDOWN_DEADLINE_S = 120.0
"""From the end of the session to the end of the process, s."""

_terminal_fd: int | None = None


def _terminal() -> int:
    """A duplicate of the standard output pytest reports on, taken before any test captured file descriptor 1."""
    global _terminal_fd
    if _terminal_fd is None:
        _terminal_fd = os.dup(sys.__stdout__.fileno())
    return _terminal_fd


def pytest_configure(config: pytest.Config) -> None:
    _terminal()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    faulthandler.dump_traceback_later(HARD_DEADLINE_S, exit=True, file=_terminal())
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


def pytest_unconfigure(config: pytest.Config) -> None:
    faulthandler.dump_traceback_later(SHUTDOWN_DEADLINE_S, exit=True, file=_terminal())
