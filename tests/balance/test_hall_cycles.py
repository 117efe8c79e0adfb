"""Hall edge detection and cycle averaging against signals whose truth is known by construction."""

import numpy as np
import pytest

from ornitail.balance.cycle_averages import cycle_means, phase_average
from ornitail.balance.hall_cycles import HallEdgeSettings, flap_cycles, rising_edge_times
from ornitail.core.errors import UserInputError

SAMPLE_RATE_HZ = 10_000.0


def hall_line(edge_times_s, duration_s, rise_s=2e-4, width_s=3e-3, high_v=3.3, noise_v=0.0, seed=0):
    """A Hall line with linear rising flanks starting at ``edge_times_s`` (mid-level crossing at +rise/2)."""
    time_s = np.arange(int(duration_s * SAMPLE_RATE_HZ)) / SAMPLE_RATE_HZ
    line = np.zeros_like(time_s)
    for edge in edge_times_s:
        rising = np.clip((time_s - edge) / rise_s, 0.0, 1.0)
        falling = np.clip((time_s - edge - width_s) / rise_s, 0.0, 1.0)
        line += high_v * (rising - falling)
    return line + np.random.default_rng(seed).normal(0.0, noise_v, time_s.size)


@pytest.mark.parametrize("frequency_hz", [10.0, 13.4, 17.0])
def test_edge_times_are_recovered_to_a_fraction_of_a_sample(frequency_hz):
    true_edges = 0.0123 + np.arange(0, 1.9, 1 / frequency_hz)
    line = hall_line(true_edges, 2.0)
    settings = HallEdgeSettings()
    found = rising_edge_times(line, SAMPLE_RATE_HZ, settings)
    # The mid level (1.5 V of 3.3 V) is crossed 1.5/3.3 of the way up a 0.2 ms linear flank; linear interpolation
    # between two samples on that flank is exact; when one sample sits on the foot of the flank the error is a
    # small fraction of the 0.1 ms sample interval (below 1 us for a 0.2 ms flank).
    expected = true_edges + 2e-4 * 1.5 / 3.3
    assert found.shape == expected.shape
    np.testing.assert_allclose(found, expected, atol=1e-6)


def test_glitch_inside_lockout_is_ignored_and_glitch_outside_it_splits_a_rejected_cycle():
    true_edges = np.arange(0.01, 1.99, 1 / 13.0)
    glitch_inside = true_edges[3] + 0.010  # 10 ms after an edge, inside the 20 ms lock-out
    glitch_outside = (
        true_edges[8] + 0.040
    )  # 40 ms after an edge: splits one 77 ms cycle into 40 + 37 ms
    line = hall_line(np.sort(np.r_[true_edges, glitch_inside, glitch_outside]), 2.0, width_s=1e-3)
    cycles = flap_cycles(line, SAMPLE_RATE_HZ)
    assert len(cycles.edge_times_s) == len(true_edges) + 1
    assert cycles.rejected_count == 2
    assert len(cycles) == len(true_edges) - 2
    # Each edge is timed to better than 1 us (see above), so a 77 ms period is good to ~3e-5 relative at worst.
    np.testing.assert_allclose(cycles.frequency_hz, 13.0, rtol=3e-5)


def test_missing_pulse_rejects_the_double_cycle():
    true_edges = np.arange(0.01, 1.99, 1 / 13.0)
    line = hall_line(np.delete(true_edges, 10), 2.0)
    cycles = flap_cycles(line, SAMPLE_RATE_HZ)
    assert cycles.rejected_count == 1
    assert (
        len(cycles) == len(true_edges) - 3
    )  # n edges - 1 pulse = n-1 edges -> n-2 cycles, one rejected
    assert np.all(np.abs(cycles.period_s - 1 / 13.0) < 1e-6)


def test_noise_below_the_hysteresis_band_makes_no_extra_edges():
    true_edges = np.arange(0.01, 1.99, 1 / 13.0)
    # Gaussian noise of 0.1 V: reaching the 1 V band from 0 V or falling to it from 3.3 V is a >10 sigma event.
    line = hall_line(true_edges, 2.0, noise_v=0.1, seed=3)
    assert len(rising_edge_times(line, SAMPLE_RATE_HZ, HallEdgeSettings())) == len(true_edges)


@pytest.mark.parametrize(
    ("duration_s", "message"), [(0.05, "Hall edge"), (0.35, "whole flapping cycle")]
)
def test_too_few_cycles_are_refused_with_a_clear_message(duration_s, message):
    line = hall_line(np.arange(0.01, duration_s, 1 / 13.0), duration_s)
    with pytest.raises(UserInputError, match=message):
        flap_cycles(line, SAMPLE_RATE_HZ)


def test_nan_in_hall_line_is_refused():
    line = hall_line(np.arange(0.01, 1.0, 1 / 13.0), 1.0)
    line[100] = np.nan
    with pytest.raises(UserInputError, match="NaN"):
        flap_cycles(line, SAMPLE_RATE_HZ)


def test_cycle_means_and_phase_average_of_a_known_periodic_signal():
    frequency_hz = (
        12.5  # 800 samples per cycle exactly, so whole-cycle means of harmonics vanish exactly
    )
    rise_s = 2e-4
    # Place each mid-level crossing half a sample after a sample instant: the cycle then holds samples at phases
    # (0.5 .. 799.5) / 800, and the 20 samples of each of 40 bins are centred on the bin centre.
    crossing_s = (np.arange(25) * 800 + 0.5) / SAMPLE_RATE_HZ
    line = hall_line(crossing_s - rise_s * 1.5 / 3.3, 2.0, rise_s=rise_s)
    phase = 2 * np.pi * frequency_hz * (np.arange(line.size) / SAMPLE_RATE_HZ - crossing_s[0])
    force = np.column_stack(
        [0.25 + 0.1 * np.sin(phase) + 0.05 * np.cos(3 * phase), -0.5 + 0 * phase]
    )
    cycles = flap_cycles(line, SAMPLE_RATE_HZ)
    means = cycle_means(force, cycles, SAMPLE_RATE_HZ)
    np.testing.assert_allclose(means, [[0.25, -0.5]] * len(cycles), atol=1e-12)
    averaged = phase_average(force, cycles, SAMPLE_RATE_HZ, n_bins=40)
    # A bin mean equals the signal at the bin centre up to the curvature term,
    # at most (1/24) (3 * 2 pi / 40)^2 * 0.05 + (1/24) (2 pi / 40)^2 * 0.1 < 6e-4.
    centre_phase = 2 * np.pi * averaged.phase
    expected = 0.25 + 0.1 * np.sin(centre_phase) + 0.05 * np.cos(3 * centre_phase)
    np.testing.assert_allclose(averaged.mean[:, 0], expected, atol=6e-4)
    np.testing.assert_allclose(averaged.spread, 0.0, atol=1e-9)
