"""Operating-point changes stamped with rig time reach the samples taken at that time, however late the samples are
generated (the simulated instruments' shared signal source, ``simulated_instruments/shared_signal_source.py``).

A board thread held up by a busy host generates the samples it owes in one late block; before the stamps, the whole
block carried the state of the moment it was generated (on the rig: a wind-off tare recorded with the motor already
started again for the next point). The clock here is a plain variable: nothing depends on the host's speed.
"""

import numpy as np
import pytest

from ornitail.core.errors import UserInputError
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

RATE_HZ = 10_000.0
HALL = 8
"""Column of the Hall sensor's line, V: it toggles once per flap while the motor runs and stays put when stopped."""


class ManualClock:
    """Rig time, s, moved by the test."""

    def __init__(self) -> None:
        self.now_s = 0.0

    def __call__(self) -> float:
        return self.now_s


def hall_toggles(block: np.ndarray) -> int:
    """Edges of the Hall line in ``block``."""
    high = block[:, HALL] > 2.5
    return int(np.count_nonzero(high[1:] != high[:-1]))


@pytest.fixture
def clock_and_signals():
    clock = ManualClock()
    signals = SharedTunnelSignals.from_simulator(seed=3, sample_rate_hz=RATE_HZ, clock=clock)
    signals.set_operating_point(
        tunnel_velocity_m_s=0.8, flapping_frequency_hz=13.5
    )  # at rig time 0
    return clock, signals


def test_a_block_generated_late_holds_the_motor_stop_at_the_sample_of_its_time(clock_and_signals):
    clock, signals = clock_and_signals
    clock.now_s = 1.0
    signals.set_operating_point(flapping_frequency_hz=0.0)  # the motor stops at 1 s ...
    clock.now_s = 2.0
    assert (
        signals.operating_point()["flapping_frequency_hz"] == 0.0
    )  # ... as the instruments see it at once
    block = signals.next_block_at_rate(
        20_000, RATE_HZ, first_sample_time_s=0.0
    )  # ... generated only now
    running, stopped = block[:10_000], block[10_000:]
    # 13.5 flaps in the first second: two edges each (one or two fewer at the ends); none after the stop.
    assert 25 <= hall_toggles(running) <= 27
    assert hall_toggles(stopped) == 0


def test_a_change_not_yet_due_waits_for_the_samples_of_its_time(clock_and_signals):
    clock, signals = clock_and_signals
    clock.now_s = 0.5
    signals.set_operating_point(flapping_frequency_hz=0.0)
    before = signals.next_block_at_rate(
        2_000, RATE_HZ, first_sample_time_s=0.0
    )  # 0-0.2 s: still flapping
    assert hall_toggles(before) >= 4
    after = signals.next_block_at_rate(
        2_000, RATE_HZ / 2, first_sample_time_s=0.6
    )  # 0.6-1.0 s at 5 kHz
    assert hall_toggles(after) == 0


def test_samples_taken_by_time_follow_the_stamps_too(clock_and_signals):
    clock, signals = clock_and_signals
    clock.now_s = 1.0
    signals.set_operating_point(flapping_frequency_hz=0.0)
    clock.now_s = 2.0
    times = np.arange(20_000) / RATE_HZ
    block = signals.samples_at_times(times)
    assert 25 <= hall_toggles(block[:10_000]) <= 27
    assert hall_toggles(block[10_000:]) == 0


def test_without_a_clock_a_change_applies_to_the_next_sample_generated():
    signals = SharedTunnelSignals.from_simulator(seed=3, sample_rate_hz=RATE_HZ)
    signals.set_operating_point(tunnel_velocity_m_s=0.8, flapping_frequency_hz=13.5)
    assert hall_toggles(signals.next_block_at_rate(10_000, RATE_HZ, first_sample_time_s=5.0)) >= 25
    signals.set_operating_point(flapping_frequency_hz=0.0)
    assert hall_toggles(signals.next_block_at_rate(10_000, RATE_HZ, first_sample_time_s=0.0)) == 0


def test_a_value_out_of_range_is_refused_when_it_is_set(clock_and_signals):
    _, signals = clock_and_signals
    with pytest.raises(UserInputError, match="flapping_frequency_hz"):
        signals.set_operating_point(flapping_frequency_hz=45.0)
