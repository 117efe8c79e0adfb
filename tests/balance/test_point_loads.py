"""Cycle-averaged body-frame loads from simulated balance signals, against the simulator's own truth."""

import math
from importlib.resources import files

import numpy as np
import pytest
from scipy.signal import lfilter

from ornitail.balance.point_loads import (
    cycle_averaged_loads,
    propagated_standard_error,
    tare_volts_and_covariance,
)
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.tool_transform import ToolTransform
from ornitail.sim.configuration import study_configuration
from ornitail.sim.effects import EffectSet
from ornitail.sim.tunnel import TunnelSignalSource, true_cycle_average

CALIBRATION_PATH = files("ornitail.calibration") / "data" / "FT8884.cal"
PITCH_RAD = math.radians(25.0)
CONFIGURATION = study_configuration("S3", 98.0)


def calibration_to_cg_of(configuration, tail_attached):
    """Tool transform from the sensor centre to the CG, body axes (docs/frames.md), from the sim's mounting."""
    truth = true_cycle_average(configuration, EffectSet.none(), PITCH_RAD, 0.8, 13.5, tail_attached)
    mounting = configuration.mounting
    cg_from_sensor_body = np.array(
        [-mounting.sensor_origin_x_m, 0.0, truth.cg_station_m - mounting.sensor_origin_station_m]
    )
    rotation = (
        mounting.rotation_matrix()
    )  # rows: sensor axes in body axes; here a half turn about x
    assert np.allclose(rotation, np.diag([1.0, -1.0, -1.0]))
    transform = ToolTransform.from_si(rotation @ cg_from_sensor_body, np.array([math.pi, 0.0, 0.0]))
    return AtiCalibration.from_file(CALIBRATION_PATH).with_tool_transform(transform)


def tare_then_record(effects, tail_attached, seed):
    source = TunnelSignalSource(CONFIGURATION, effects, seed=seed)
    source.set_operating_point(
        pitch_rad=PITCH_RAD,
        tunnel_velocity_m_s=0.0,
        flapping_frequency_hz=0.0,
        tail_attached=tail_attached,
    )
    tare_volts = source.next_block(10_000)[:, :6].mean(axis=0)
    source.set_operating_point(tunnel_velocity_m_s=0.8, flapping_frequency_hz=13.5)
    source.next_block(5_000)
    return tare_volts, source.next_block(20_000)


@pytest.mark.parametrize("tail_attached", [True, False])
def test_noise_free_signals_give_the_true_loads_about_the_cg(tail_attached):
    tare_volts, record = tare_then_record(EffectSet.none(), tail_attached, seed=1)
    calibration = calibration_to_cg_of(CONFIGURATION, tail_attached)
    loads = cycle_averaged_loads(record[:, :6], record[:, 8], 10_000.0, tare_volts, calibration)
    truth = true_cycle_average(CONFIGURATION, EffectSet.none(), PITCH_RAD, 0.8, 13.5, tail_attached)
    # Without noise the only error is the flap ripple left over where a cycle boundary falls between samples:
    # ripple amplitude (< 0.1 N) x one sample of ~740 per cycle, averaged over 26 cycles: well below 1e-4 N.
    assert loads.mean[0] == pytest.approx(truth.aero_x_n, abs=1e-4)
    assert loads.mean[2] == pytest.approx(truth.aero_z_n, abs=1e-4)
    # The same for the moment with a ~2 cm lever: 2e-6 N m.
    assert loads.mean[4] == pytest.approx(truth.aero_m_n_m, abs=2e-6)
    assert abs(loads.mean[1]) < 1e-4 and abs(loads.mean[3]) < 2e-6 and abs(loads.mean[5]) < 2e-6
    assert loads.cycle_count >= 25
    assert loads.flapping_frequency_hz == pytest.approx(13.5, rel=1e-3)


def test_two_sigma_intervals_of_the_mean_cover_the_truth_under_balance_noise():
    """With gauge noise at the Nano-17's resolution, mean +- 2 SE covers the truth in ~95 % of records."""
    effects = EffectSet.none().with_enabled("balance_resolution")
    calibration = calibration_to_cg_of(CONFIGURATION, True)
    truth = true_cycle_average(CONFIGURATION, effects, PITCH_RAD, 0.8, 13.5, True)
    covered, errors, sigmas = [], [], []
    for seed in range(40):
        tare_volts, record = tare_then_record(effects, True, seed)
        loads = cycle_averaged_loads(record[:, :6], record[:, 8], 10_000.0, tare_volts, calibration)
        # The tare mean of 10 000 samples carries noise too: add its standard error to that of the cycles.
        tare_standard_error = effects.balance_resolution.force_noise_n / math.sqrt(10_000)
        sigma = math.hypot(loads.standard_error[0], tare_standard_error)
        covered.append(abs(loads.mean[0] - truth.aero_x_n) <= 2 * sigma)
        errors.append(loads.mean[0] - truth.aero_x_n)
        sigmas.append(sigma)
    # Expected coverage 0.954 (+-0.033 binomial sd over 40 records): 0.85 is three sd below it.
    assert np.mean(covered) >= 0.85
    # And the stated sigma is neither too small nor too large: the scatter of the errors over 40 records
    # matches it, within about three standard deviations of the ratio (sd ~ 1/sqrt(2 * 39) = 0.11).
    assert 0.7 <= np.std(errors, ddof=1) / np.mean(sigmas) <= 1.4


def test_the_tare_error_counts_noise_the_gauges_share_and_noise_correlated_in_time():
    """Load-space noise seen through the inverse calibration (correlated gauges) and AR(1) noise (correlated in
    time) both give a tare error whose stated size matches the scatter of tare means over many records."""
    calibration = AtiCalibration.from_file(CALIBRATION_PATH)
    to_volts = np.linalg.inv(calibration.matrix_si)
    generator = np.random.default_rng(3)
    means, stated = [], []
    for _ in range(200):
        white = generator.normal(size=(8_000, 6)) * np.array([3e-3] * 3 + [1.5e-5] * 3)
        # AR(1) with coefficient 0.9: the variance of a long mean is (1 + 0.9) / (1 - 0.9) = 19 times the
        # independent-sample value, which a plain std / sqrt(n) would miss. Batches of 200 samples see about
        # 1 - 2 * 0.9 / (200 * 0.1) = 91 % of it (ratio below ~1.05).
        correlated = lfilter([1.0], [1.0, -0.9], white, axis=0)
        volts, covariance = tare_volts_and_covariance(correlated @ to_volts.T)
        means.append(calibration.matrix_si @ volts)
        stated.append(propagated_standard_error(calibration, covariance))
    ratio = np.std(means, axis=0, ddof=1) / np.sqrt(np.mean(np.square(stated), axis=0))
    # 200 records: the sd of a scatter-to-stated ratio is about 1 / sqrt(2 * 200) = 0.05 from the scatter and
    # about 0.02 from the 39 batch degrees of freedom; expected about 1.05 (the batches), so 0.8..1.3 is over
    # 4 sd either way. Independent gauges
    # would state up to 3x too much here, independent samples sqrt(19) = 4.4x too little.
    np.testing.assert_array_less(0.8, ratio)
    np.testing.assert_array_less(ratio, 1.3)
