"""Derivative-level re-identification (gap/derivative_refit.py) on manoeuvres flown by a known
linear model: it finds the derivative the baseline got wrong and closes the gap on other runs."""

import numpy as np
import pytest

from ornitail.flight.model_file import load_model
from ornitail.gap.derivative_refit import refit_derivatives
from ornitail.gap.flight_candidates import baseline_flight_model
from ornitail.gap.flight_diagnosis import residuals_of
from ornitail.gap.model_spec import BaselineSpec
from ornitail.gap.report_text import derivative_refit_lines


def test_the_refit_moves_the_wrong_derivative_and_closes_the_gap_on_test_runs(
    fly_linear_manoeuvres,
):
    spec = BaselineSpec("linear_model", model="delfly_longitudinal")
    model = load_model(spec.model)
    baseline = baseline_flight_model(spec)
    true_mq = 1.5 * model.start_values()["Mq"]  # the baseline's pitch damping 50 % too weak
    numeric = model.state_space({**model.start_values(), "Mq": true_mq}, model.constants)
    truth = baseline.with_matrices(numeric.a_matrix, numeric.b_matrix)
    runs = fly_linear_manoeuvres(truth, 6, seed=3)
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
    assert refit["supported_by_test_runs"] is True


def test_a_refit_that_does_not_predict_the_test_runs_says_its_moves_are_not_supported(
    fly_linear_manoeuvres,
):
    """Training runs flown with M_q 50 % stronger, test runs flown by the baseline itself: the re-fit
    moves M_q on the training runs and predicts the test runs worse than the baseline, so its moves
    fit the training runs only (the report says so; the text report above the list of moves)."""
    spec = BaselineSpec("linear_model", model="delfly_longitudinal")
    model = load_model(spec.model)
    baseline = baseline_flight_model(spec)
    numeric = model.state_space(
        {**model.start_values(), "Mq": 1.5 * model.start_values()["Mq"]}, model.constants
    )
    training = fly_linear_manoeuvres(
        baseline.with_matrices(numeric.a_matrix, numeric.b_matrix), 4, seed=3
    )
    test = fly_linear_manoeuvres(baseline, 2, seed=4)
    scales = np.concatenate([run.outputs for run in training]).std(axis=0)

    def sse(candidate, runs):
        return np.array([np.sum((r / scales) ** 2) for r in residuals_of(candidate, runs)])

    refit = refit_derivatives(model, model.constants, baseline, training, test, sse, seed=1)
    assert "Mq" in refit["moved"]
    assert refit["closure_interval"][1] < 0  # the baseline is the truth on the test runs
    assert refit["supported_by_test_runs"] is False
    text = "\n".join(derivative_refit_lines(refit))
    assert "not supported by the test runs" in text
