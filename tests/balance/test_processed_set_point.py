"""One processed set point: phase averages, Hall glitches and missing pulses, too few cycles, rpm cross-check."""

import math

import numpy as np
import pytest

from ornitail.balance.cycle_averages import segment_sums
from ornitail.balance.phase_loads import phase_averaged_loads
from ornitail.balance.point_loads import cycle_averaged_loads, tare_volts_and_covariance
from ornitail.balance.sweep_table import frequency_check_warnings, frequency_cross_check_record
from ornitail.core.errors import UserInputError
from ornitail.sim.effects import EffectSet
from ornitail.sim.tunnel import TunnelSignalSource
from ornitail.vehicle.constants import DELFLY_GEAR_RATIO

SAMPLE_RATE_HZ = 10_000.0
PITCH_RAD, VELOCITY_M_S, FREQUENCY_HZ = math.radians(25.0), 0.8, 13.5


def tare_and_record(sweep, seconds, seed=0):
    """Wind-off tare volts and a record (n, 9) at the steady state, straight from the simulator."""
    source = TunnelSignalSource(sweep.configuration, sweep.effects, seed=seed)
    source.set_operating_point(
        pitch_rad=PITCH_RAD, tunnel_velocity_m_s=0.0, flapping_frequency_hz=0.0
    )
    tare = tare_volts_and_covariance(source.next_block(10_000)[:, :6])
    source.set_operating_point(tunnel_velocity_m_s=VELOCITY_M_S, flapping_frequency_hz=FREQUENCY_HZ)
    source.next_block(2_000)
    return tare, source.next_block(int(seconds * SAMPLE_RATE_HZ))


def test_phase_averaged_loads_recover_a_known_flap_cycle(make_simulated_sweep):
    """Voltages made from known body loads through the calibration come back as those loads per phase bin."""
    calibration = make_simulated_sweep().calibration
    cycle_samples, n_cycles, n_bins = 800, 20, 40  # 12.5 Hz, 20 samples per bin
    # The record starts half-way through a cycle, so the first Hall edge is a clean rising edge.
    phase = ((np.arange(cycle_samples * n_cycles) + 0.5) / cycle_samples + 0.5) % 1.0
    angle = 2 * np.pi * phase
    body = np.zeros((phase.size, 6))
    body[:, 0] = 0.07 + 0.08 * np.cos(2 * angle)
    body[:, 2] = -0.2 + 0.9 * np.sin(2 * angle + 0.3)
    body[:, 4] = 4e-4 + 0.02 * np.sin(4 * angle)
    bias = np.linspace(-0.05, 0.05, 6)
    volts = calibration.voltages_from_forces(body, bias)
    hall = np.where(phase < 0.05, 3.3, 0.0)
    result = phase_averaged_loads(volts, hall, SAMPLE_RATE_HZ, bias, calibration, n_bins=n_bins)

    # The step Hall line's mid-level crossing lies 0.045 sample from the true cycle start (negligible), so a bin
    # mean differs from the load at the bin centre by the curvature term only: a harmonic k of amplitude A
    # averaged over a bin of 2 pi / 40 differs from its centre value by at most (1/24) (2 pi k / 40)^2 A.
    def bound(k, amplitude):
        return 1.05 * (2 * np.pi * k / n_bins) ** 2 / 24 * amplitude

    centre = 2 * np.pi * result.phase
    assert result.cycle_count == n_cycles - 1
    np.testing.assert_allclose(
        result.load("x_n")[0], 0.07 + 0.08 * np.cos(2 * centre), atol=bound(2, 0.08)
    )
    np.testing.assert_allclose(
        result.load("z_n")[0], -0.2 + 0.9 * np.sin(2 * centre + 0.3), atol=bound(2, 0.9)
    )
    np.testing.assert_allclose(
        result.load("m_n_m")[0], 4e-4 + 0.02 * np.sin(4 * centre), atol=bound(4, 0.02)
    )
    np.testing.assert_allclose(result.spread, 0.0, atol=1e-9)  # identical cycles


def hall_with_faults(hall_v, glitch_after_edge_s, missing_edge):
    """The Hall line with one pulse removed and one short spike (a glitch) added after another edge."""
    high = hall_v > 1.5
    rising = np.flatnonzero(high[1:] & ~high[:-1]) + 1
    faulty = hall_v.copy()
    pulse = rising[missing_edge]
    faulty[pulse : pulse + 60] = 0.0  # the 5 % pulse is ~37 samples long at 13.5 Hz
    spike = rising[missing_edge + 6] + int(glitch_after_edge_s * SAMPLE_RATE_HZ)
    faulty[spike : spike + 3] = 3.3
    return faulty


def test_hall_glitch_and_missing_pulse_are_rejected_and_the_loads_stay_true(make_simulated_sweep):
    sweep = make_simulated_sweep(effects=EffectSet.none())
    (tare, tare_error), record = tare_and_record(sweep, 2.0)
    clean = cycle_averaged_loads(
        record[:, :6], record[:, 8], SAMPLE_RATE_HZ, tare, sweep.calibration
    )
    faulty_hall = hall_with_faults(record[:, 8], glitch_after_edge_s=0.040, missing_edge=5)
    faulty = cycle_averaged_loads(
        record[:, :6], faulty_hall, SAMPLE_RATE_HZ, tare, sweep.calibration
    )
    # A glitch 40 ms into a 74 ms cycle (outside the 20 ms lock-out) splits it in two short cycles; a missing
    # pulse merges two into one double cycle: both fail the +-20 % period check, 3 cycles rejected, 3 fewer kept.
    assert clean.rejected_cycles == 0
    assert faulty.rejected_cycles == 3
    assert faulty.cycle_count == clean.cycle_count - 3
    assert faulty.flapping_frequency_hz == pytest.approx(
        FREQUENCY_HZ, rel=5e-3
    )  # 0.2 % speed wander
    truth = sweep.truth(PITCH_RAD, VELOCITY_M_S, FREQUENCY_HZ)
    # Noise-free: only the flap ripple cut at cycle boundaries between samples remains, < 1e-4 N (see
    # test_point_loads) and 2e-6 N m.
    assert faulty.mean[[0, 2]] == pytest.approx(truth[:2], abs=1e-4)
    assert faulty.mean[4] == pytest.approx(truth[2], abs=2e-6)


def test_a_record_with_too_few_cycles_is_refused_with_a_clear_message(make_simulated_sweep):
    sweep = make_simulated_sweep(effects=EffectSet.none().with_enabled("balance_resolution"))
    (tare, _), record = tare_and_record(sweep, 0.35)  # 4.7 cycles at 13.5 Hz: at most 4 whole ones
    with pytest.raises(
        UserInputError, match=r"only \d whole flapping cycle\(s\) accepted, at least 5"
    ):
        cycle_averaged_loads(record[:, :6], record[:, 8], SAMPLE_RATE_HZ, tare, sweep.calibration)


def test_standard_error_is_honest_over_seeds_with_the_tare_noise_included(make_simulated_sweep):
    """Mean +- 2 sigma (cycle scatter with neighbour correlation, and tare noise) covers the truth ~95 %."""
    sweep = make_simulated_sweep(effects=EffectSet.none().with_enabled("balance_resolution"))
    truth = sweep.truth(PITCH_RAD, VELOCITY_M_S, FREQUENCY_HZ)
    scores = []
    for seed in range(25):
        (tare, tare_covariance), record = tare_and_record(sweep, 1.0, seed=seed)
        loads = cycle_averaged_loads(
            record[:, :6], record[:, 8], SAMPLE_RATE_HZ, tare, sweep.calibration,
            tare_volts_covariance=tare_covariance,
        )  # fmt: skip
        scores.append((loads.mean[[0, 2, 4]] - truth) / loads.total_standard_error[[0, 2, 4]])
    scores = np.array(scores)
    # 75 intervals at 95 %: >= 66 covered (binomial: fewer has probability < 1 %); rms z within 0.5..1.5
    # (sd of an rms of 75 unit normals ~0.08; the lower bound allows for the conservative tare term).
    assert (np.abs(scores) <= 2).sum() >= 66
    assert 0.5 <= np.sqrt((scores**2).mean()) <= 1.5


def test_segment_sums_match_a_plain_loop_for_any_spans():
    generator = np.random.default_rng(7)
    # The last size reaches the threaded block sums (at least 16 384 blocks of 64 rows).
    for rows in (5, 63, 64, 65, 130, 1000, 4099, 64 * 16_384 + 37):
        data = generator.normal(size=(rows, 3)).astype(np.float32)
        edges = np.sort(generator.integers(0, rows + 1, size=(40, 2)), axis=1)
        spans = edges[edges[:, 1] > edges[:, 0]]
        expected = np.array([data[a:b].sum(axis=0, dtype=np.float64) for a, b in spans])
        # float32 block sums of 64 unit-size values round by < 64 x 6e-8 each; a span of up to 1e6 rows
        # adds up to 16 384 such errors, randomly signed: ~1e-4 rms, 1e-3 is a bound with margin.
        np.testing.assert_allclose(segment_sums(data, spans), expected, atol=1e-3)


@pytest.mark.parametrize(
    ("rpm_factor", "flagged"), [(1.0, False), (1.015, False), (0.95, True), (1.05, True)]
)
def test_hall_frequency_is_cross_checked_against_motor_rpm(rpm_factor, flagged):
    rpm = FREQUENCY_HZ * 60 * DELFLY_GEAR_RATIO * rpm_factor
    record = frequency_cross_check_record(FREQUENCY_HZ, rpm)
    assert record["f_motor_hz"] == pytest.approx(FREQUENCY_HZ * rpm_factor)
    assert record["f_disagreement"] == pytest.approx(1 / rpm_factor - 1)
    assert record["f_disagrees"] is flagged


def test_missing_rpm_is_not_flagged_and_disagreements_give_one_warning_line_each():
    assert frequency_cross_check_record(13.5, None)["f_disagrees"] is False
    assert math.isnan(frequency_cross_check_record(13.5, float("nan"))["f_motor_hz"])
    import pandas as pd

    rows = [
        {"run_id": "r1", "plan_point_index": index, "sweep": "frequency", "f_hall_hz": 13.5,
         **frequency_cross_check_record(13.5, 13.5 * 60 * DELFLY_GEAR_RATIO * factor)}
        for index, factor in enumerate((1.0, 0.9, 1.2))
    ]  # fmt: skip
    warnings = frequency_check_warnings(pd.DataFrame(rows))
    assert len(warnings) == 2
    assert "r1 set point 1" in warnings[0] and "+11.1 %" in warnings[0]
    assert all(line.startswith("warning:") and "\n" not in line for line in warnings)


def test_the_cross_check_uses_the_gear_ratio_the_run_was_recorded_with():
    """A rig whose motor turns 10 times per flap: 8100 rpm is 13.5 Hz, not 6.33 Hz as 21.33 would make it."""
    record = frequency_cross_check_record(13.5, 8100.0, gear_ratio=10.0)
    assert record["gear_ratio"] == 10.0
    assert record["f_motor_hz"] == pytest.approx(13.5)
    assert record["f_disagrees"] is False
    import pandas as pd

    warning = frequency_check_warnings(
        pd.DataFrame(
            [{"run_id": "r", "plan_point_index": 0, "sweep": "frequency", "f_hall_hz": 12.0,
              **frequency_cross_check_record(12.0, 8100.0, gear_ratio=10.0)}]
        )
    )  # fmt: skip
    assert "rpm / 60 / 10)" in warning[0]
