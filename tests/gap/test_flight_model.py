"""Simulating the linear flight model on a manoeuvre: zero-order hold, delay, theta drift; the
detection rule's null directions on synthetic manoeuvres, plain and stripped of an effect's response."""

import dataclasses

import numpy as np
import pytest

from ornitail.gap.detection import random_matrix_directions
from ornitail.gap.flight_candidates import baseline_flight_model
from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_diagnosis import null_energies, rule_from_energies
from ornitail.gap.flight_model import LinearFlightModel, simulate_runs
from ornitail.gap.model_spec import BaselineSpec
from ornitail.gap.null_response import response_gradients


def _run(elevator: np.ndarray, step: float = 1 / 64, start_s: float = 0.5) -> FlightRun:
    time_s = np.arange(len(elevator)) * step
    states = np.zeros((len(elevator), 4))
    return FlightRun("t#1", time_s, states, elevator[:, None], states, states[0], start_s, 0.3, 0.7)


def _integrator() -> LinearFlightModel:
    # q' = 2 delta_e, theta' = q: exact under a zero-order hold for a piecewise-constant input
    a_matrix = np.zeros((4, 4))
    a_matrix[3, 0] = 1.0
    b_matrix = np.array([[2.0], [0.0], [0.0], [0.0]])
    return LinearFlightModel(a_matrix, b_matrix, 1e-4, 0.3, 0.7)


def test_zero_order_hold_integrates_a_step_exactly():
    elevator = np.where(np.arange(200) >= 40, 0.1, 0.0)
    run = _run(elevator)
    held = dataclasses.replace(_integrator(), input_hold="zero_order")
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
    delayed_model = _integrator().with_input_change(0, delay_s=5 / 64)
    (plain,) = simulate_runs(_integrator(), [run])
    (delayed,) = simulate_runs(delayed_model, [run])
    np.testing.assert_allclose(delayed[5:, 0], plain[:-5, 0], atol=1e-12)


def test_theta_drift_adds_a_ramp_from_the_run_in_middle():
    run = _run(np.zeros(100))
    drifting = _integrator().with_output_change(3, drift_per_s=0.01)
    (predicted,) = simulate_runs(drifting, [run])
    # the measured first theta (0) holds drift 0.01 * (0 - 0.25); the true attitude is 0.0025 and
    # stays (q = 0), so the measured prediction is 0.0025 + 0.01 (t - 0.25) = 0.01 t
    np.testing.assert_allclose(predicted[:, 3], 0.01 * run.time_s, atol=1e-12)
    assert predicted[:, :3] == pytest.approx(np.zeros((100, 3)))


def _doublet_runs(model: LinearFlightModel, count: int, seed: int) -> list[FlightRun]:
    """``count`` 6 s doublet manoeuvres flown by ``model`` with white measurement noise of about
    5 % of each channel's response."""
    time_s = np.arange(384) / 64.0
    elevator = 0.05 * (
        ((time_s >= 1.0) & (time_s < 1.5)) * 1.0 - ((time_s >= 1.5) & (time_s < 2.0))
    )
    zeros = np.zeros((384, 4))
    plain = [
        FlightRun(f"t#{i}", time_s, zeros, elevator[:, None], zeros, zeros[0], 1.0, 0.3, 0.7)
        for i in range(count)
    ]
    responses = simulate_runs(model, plain)
    noise = 0.05 * np.concatenate(responses).std(axis=0)
    generator = np.random.default_rng(seed)
    return [
        dataclasses.replace(run, outputs=response + noise * generator.standard_normal((384, 4)))
        for run, response in zip(plain, responses, strict=True)
    ]


def test_the_detection_threshold_rises_when_the_baseline_leaves_a_systematic_error():
    """The null distribution is what a meaningless extra parameter closes on these runs: on data
    the baseline explains up to noise it is near zero; when the baseline misses several of the
    model's entries, random directions absorb part of that error and the threshold rises."""
    spec = BaselineSpec("simulator", "S3", 98.0)
    truth = baseline_flight_model(spec)
    runs = _doublet_runs(truth, 12, seed=2)
    wrong_a = truth.a_matrix.copy()
    wrong_a[0, :3] *= np.array([1.6, 0.7, 1.4])  # M_q, M_u, M_w off by tens of percent
    wrong = truth.with_matrices(wrong_a, truth.b_matrix * 1.2)
    scales = np.concatenate([run.outputs for run in runs]).std(axis=0)

    def rule(baseline: LinearFlightModel):
        return rule_from_energies(
            *null_energies(baseline, runs[:6], runs[6:9], scales, seed=4, draws=8)
        )

    exact, missing = rule(truth), rule(wrong)
    assert exact.null_quantile < 0.05
    assert missing.null_quantile > exact.null_quantile + 0.1


def test_the_filter_candidate_undoes_a_logged_first_order_filter():
    """The surface steps by 0.1 rad at 0.5 s; the log holds it through a 0.1 s first-order
    low-pass. With the filter's time constant the model's q is the integrator's exact ramp
    0.2 (t - 0.5); the log's exponential is held linear between samples, which leaves an error of
    order h^2 / tau (h = 1/64 s) in q's ramp, below 1e-3 rad/s."""
    time_s = np.arange(200) / 64.0
    elapsed = np.clip(time_s - 0.5, 0.0, None)
    logged = 0.1 * (1.0 - np.exp(-elapsed / 0.1))
    run = _run(logged)
    (plain,) = simulate_runs(_integrator(), [run])
    (unfiltered,) = simulate_runs(_integrator().with_input_change(0, filter_s=0.1), [run])
    np.testing.assert_allclose(unfiltered[:, 0], 0.2 * elapsed, atol=1e-3)
    assert np.max(np.abs(plain[:, 0] - 0.2 * elapsed)) > 0.015  # the log's lag: 0.2 x 0.1 s


def test_a_segment_delays_its_input_from_the_samples_logged_before_it():
    """A step logged between 4 and 3 samples before the run, delayed by 5 samples, ramps in (first-
    order hold) between the run's samples 1 and 2; a run that knows nothing before it holds its
    first (already stepped) sample."""
    elevator = np.full(100, 0.1)
    with_history = dataclasses.replace(
        _run(elevator, start_s=0.0), inputs_before=np.array([[0.0], [0.0], [0.1], [0.1], [0.1]])
    )
    delayed = _integrator().with_input_change(0, delay_s=5 / 64)
    (from_history,) = simulate_runs(delayed, [with_history])
    (held,) = simulate_runs(delayed, [_run(elevator, start_s=0.0)])
    np.testing.assert_allclose(held[:, 0], 0.2 * np.arange(100) / 64, atol=1e-12)
    np.testing.assert_allclose(from_history[:2, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(
        from_history[2:, 0], 0.2 * (np.arange(2, 100) - 1.5) / 64, atol=1e-12
    )


def _inertia_family(model: LinearFlightModel):
    """A pitch-inertia change of fraction k: the q row of A and B divided by 1 + k."""

    def family(k: float) -> LinearFlightModel:
        a_matrix, b_matrix = model.a_matrix.copy(), model.b_matrix.copy()
        a_matrix[0] /= 1.0 + k
        b_matrix[0] /= 1.0 + k
        return model.with_matrices(a_matrix, b_matrix)

    return family


def test_directions_stripped_of_an_effects_response_cannot_absorb_the_effect():
    """Data with a 30 % pitch-inertia change the baseline lacks: random directions of A and B absorb
    much of it (some lie near the q row), so the plain null rises with the effect it should judge;
    directions whose first-order output response is orthogonal to the inertia change's close only
    the second-order remainder and the noise (without the change they close nothing: 5 % noise)."""
    baseline = baseline_flight_model(BaselineSpec("simulator", "S3", 98.0))
    family = _inertia_family(baseline)
    runs = _doublet_runs(family(0.3), 12, seed=3)
    scales = np.concatenate([run.outputs for run in runs]).std(axis=0)
    training, validation = runs[:6], runs[6:9]
    gradients = response_gradients(baseline, [(family, 1.0)], training, scales)
    assert not gradients[0][3].any()  # the kinematic row is never a direction's
    plain = rule_from_energies(
        *null_energies(baseline, training, validation, scales, seed=4, draws=12)
    )
    stripped = rule_from_energies(
        *null_energies(
            baseline, training, validation, scales, seed=4, draws=12, response_gradients=gradients
        )
    )
    assert plain.null_quantile > 0.2
    assert stripped.null_quantile < 0.1
    # first-order orthogonality: each stripped direction's response has no part along the change's
    reference = np.concatenate(simulate_runs(baseline, training)) / scales
    change = (np.concatenate(simulate_runs(family(1e-3), training)) / scales - reference) / 1e-3
    for a_step, b_step in random_matrix_directions(
        baseline.a_matrix,
        baseline.b_matrix,
        4,
        seed=4,
        dynamic_rows=baseline.dynamic_rows,
        response_gradients=gradients,
    ):
        moved = baseline.with_matrices(
            baseline.a_matrix + 1e-4 * a_step, baseline.b_matrix + 1e-4 * b_step
        )
        response = (np.concatenate(simulate_runs(moved, training)) / scales - reference) / 1e-4
        cosine = np.sum(response * change) / np.sqrt(np.sum(response**2) * np.sum(change**2))
        assert abs(cosine) < 0.02
