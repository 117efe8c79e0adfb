"""Derivative-level re-identification (gap/derivative_refit.py) on manoeuvres flown by a known
linear model: it finds the derivative the baseline got wrong and closes the gap on other runs."""

import dataclasses

import numpy as np
import pytest

from ornitail.flight.model_file import load_model
from ornitail.gap.derivative_refit import refit_derivatives
from ornitail.gap.flight_candidates import baseline_flight_model
from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_diagnosis import residuals_of
from ornitail.gap.flight_model import simulate_runs
from ornitail.gap.model_spec import BaselineSpec


def _manoeuvres(truth, count: int, seed: int) -> list[FlightRun]:
    """6 s doublet manoeuvres (0.5 s run-in) flown by ``truth`` with white noise of 3 % of each
    channel's response."""
    time_s = np.arange(384) / 64.0
    elevator = 0.1 * (
        ((time_s >= 0.5) & (time_s < 0.83)) * 1.0 - ((time_s >= 0.83) & (time_s < 1.16))
    )
    zeros = np.zeros((384, 4))
    plain = FlightRun("t", time_s, zeros, elevator[:, None], zeros, zeros[0], 0.5)
    (response,) = simulate_runs(truth, [plain])
    noise = 0.03 * response.std(axis=0)
    generator = np.random.default_rng(seed)
    runs = []
    for index in range(count):
        measured = response + noise * generator.standard_normal((384, 4))
        runs.append(
            dataclasses.replace(
                plain, label=f"t#{index}", outputs=measured, states=measured, initial_state=zeros[0]
            )
        )
    return runs


def test_the_refit_moves_the_wrong_derivative_and_closes_the_gap_on_test_runs():
    spec = BaselineSpec("linear_model", model="delfly_longitudinal")
    model = load_model(spec.model)
    baseline = baseline_flight_model(spec)
    true_mq = 1.5 * model.start_values()["Mq"]  # the baseline's pitch damping 50 % too weak
    numeric = model.state_space({**model.start_values(), "Mq": true_mq}, model.constants)
    truth = baseline.with_matrices(numeric.a_matrix, numeric.b_matrix)
    runs = _manoeuvres(truth, 6, seed=3)
    scales = np.concatenate([run.outputs for run in runs]).std(axis=0)

    def sse(candidate, test_runs):
        return np.array([np.sum((r / scales) ** 2) for r in residuals_of(candidate, test_runs)])

    refit = refit_derivatives(model, model.constants, baseline, runs[:4], runs[4:], sse, seed=1)
    assert refit["method"] == "output error on the time-averaged training manoeuvres"
    mq = refit["derivatives"]["Mq"]
    assert "Mq" in refit["moved"]
    # the average of 4 runs at 3 % noise pins M_q to a few percent; 10 % leaves room for the
    # other 11 derivatives trading with it
    assert mq["refit"] == pytest.approx(true_mq, rel=0.1)
    assert mq["change_interval"][0] < true_mq - mq["baseline"] < mq["change_interval"][1]
    assert refit["closure_test"] > 0.8  # the residual left is the noise
