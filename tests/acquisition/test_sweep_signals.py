"""How `ornitail sweep` answers signals: first Ctrl-C finishes the point, a second one, SIGTERM or SIGHUP stop at
once; a signal arriving while a stop record is written is held back, never lost; once closing, signals are noted."""

import os
import signal
import time

import pytest

from ornitail.acquisition.sweep import SweepStop
from ornitail.app import sweep_session
from ornitail.app.sweep_session import SweepInterrupted, SweepSignals


@pytest.fixture
def signals(monkeypatch):
    # SIGHUP points a terminal's stdin/stdout/stderr at /dev/null: not pytest's own terminal
    monkeypatch.setattr(sweep_session, "_detach_from_terminal", lambda: None)
    installed = SweepSignals(SweepStop()).install()
    yield installed
    installed.closing()
    installed.restore()


def send(signal_number):
    os.kill(os.getpid(), signal_number)
    for _ in range(10_000):  # the handler runs at the next bytecode boundaries, in here
        pass


def test_first_ctrl_c_only_asks_to_stop_after_the_point_the_second_stops_at_once(signals):
    send(signal.SIGINT)
    assert signals.stop.requested
    with pytest.raises(
        SweepInterrupted, match=r"stopped at once by SIGINT \(second Ctrl-C\)"
    ) as raised:
        send(signal.SIGINT)
    assert raised.value.exit_code == 130


@pytest.mark.parametrize(("number", "code"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_sigterm_and_sighup_stop_at_once(signals, number, code):
    with pytest.raises(SweepInterrupted) as raised:
        send(number)
    assert raised.value.exit_code == code
    assert str(raised.value) == f"stopped at once by {signal.Signals(number).name}"
    send(signal.SIGTERM)  # already stopping: noted, not raised again (the stop must complete)
    assert signals.late_signals == ["SIGTERM"]


def test_a_signal_while_a_stop_record_is_written_is_held_back_then_raised(signals):
    def writing_the_stop_record():
        send(signal.SIGTERM)
        return signals.pending_signal

    signals._protected = signals._protected | {writing_the_stop_record.__code__}
    assert writing_the_stop_record() == signal.SIGTERM  # not raised in there
    with pytest.raises(SweepInterrupted, match="SIGTERM"):
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # raised as soon as the redelivered signal lands outside
            time.sleep(0.01)


def test_once_closing_signals_are_only_noted(signals):
    signals.closing()
    send(signal.SIGTERM)
    send(signal.SIGINT)
    assert signals.late_signals == ["SIGTERM", "SIGINT"]
    assert signals.interrupt is None
