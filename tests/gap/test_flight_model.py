"""Simulating the linear flight model on a manoeuvre: zero-order hold, delay, theta drift."""

import numpy as np
import pytest

from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_model import LinearFlightModel, simulate_runs


def _run(elevator: np.ndarray, step: float = 1 / 64) -> FlightRun:
    time_s = np.arange(len(elevator)) * step
    return FlightRun("t#1", time_s, np.zeros((len(elevator), 4)), elevator, 0.5, 0.3, 0.7)


def _integrator() -> LinearFlightModel:
    # q' = 2 delta_e, theta' = q: exact under a zero-order hold for a piecewise-constant input
    a_matrix = np.zeros((4, 4))
    a_matrix[3, 0] = 1.0
    b_matrix = np.array([[2.0], [0.0], [0.0], [0.0]])
    return LinearFlightModel(a_matrix, b_matrix, 1e-4, 0.3, 0.7)


def test_zero_order_hold_integrates_a_step_exactly():
    elevator = np.where(np.arange(200) >= 40, 0.1, 0.0)
    run = _run(elevator)
    held = LinearFlightModel(**{**_integrator().__dict__, "input_hold": "zero_order"})
    (predicted,) = simulate_runs(held, [run])
    elapsed = np.clip(run.time_s - run.time_s[40], 0.0, None)
    np.testing.assert_allclose(predicted[:, 0], 0.2 * elapsed, atol=1e-12)
    np.testing.assert_allclose(predicted[:, 3], 0.1 * elapsed**2, atol=1e-12)


def test_first_order_hold_integrates_the_sampled_step_as_a_ramp_between_samples():
    """The default: the step sampled at 39 -> 40 is a ramp over that interval, so the integral
    leads the zero-order hold's by half a sample.
    """
    elevator = np.where(np.arange(200) >= 40, 0.1, 0.0)
    run = _run(elevator)
    (predicted,) = simulate_runs(_integrator(), [run])
    step = run.time_s[1] - run.time_s[0]
    elapsed = np.clip(run.time_s - run.time_s[40] + step / 2, 0.0, None)
    elapsed[:40] = 0.0
    np.testing.assert_allclose(predicted[:, 0], 0.2 * elapsed, atol=1e-12)


def test_delay_shifts_the_response_by_the_delay():
    elevator = np.where(np.arange(200) >= 40, 0.1, 0.0)
    run = _run(elevator)
    delayed_model = LinearFlightModel(**{**_integrator().__dict__, "delay_s": 5 / 64})
    (plain,) = simulate_runs(_integrator(), [run])
    (delayed,) = simulate_runs(delayed_model, [run])
    np.testing.assert_allclose(delayed[5:, 0], plain[:-5, 0], atol=1e-12)


def test_theta_drift_adds_a_ramp_from_the_run_in_middle():
    run = _run(np.zeros(100))
    drifting = LinearFlightModel(**{**_integrator().__dict__, "theta_drift_rad_s": 0.01})
    (predicted,) = simulate_runs(drifting, [run])
    # the measured first theta (0) holds drift 0.01 * (0 - 0.25); the true attitude is 0.0025 and
    # stays (q = 0), so the measured prediction is 0.0025 + 0.01 (t - 0.25) = 0.01 t
    np.testing.assert_allclose(predicted[:, 3], 0.01 * run.time_s, atol=1e-12)
    assert predicted[:, :3] == pytest.approx(np.zeros((100, 3)))
