"""Output error and equation error on data simulated by the DelFly preset model itself.

The data generator is independent of the estimator's code: scipy's zero-order-hold discretisation
(cont2discrete) and dlsim, with the simulator's derivatives of the S3 tail at x_h = 98 mm as the
truth, a 65 % elevator doublet and white noise at the simulated log's sensor levels.
"""

from functools import cache

import numpy as np
import pandas as pd
import pytest
from scipy.signal import cont2discrete, dlsim

from ornitail.flight.identify import identify
from ornitail.flight.model_file import PRESET_DIRECTORY, load_model
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import linearise

RATE_HZ = 512.0
DURATION_S = 4.5
NOISE = np.array([0.03, 0.02, 0.02, 0.003])  # q rad/s, u and w m/s, theta rad (FlightPlan's)
SEEDS = range(40)


@cache
def truth():
    linear = linearise(study_configuration("S3", 98))
    constants = {
        "m": linear.mass_kg,
        "Iyy": linear.iyy_kg_m2,
        "theta0": linear.trim.theta_rad,
        "u0": linear.trim.u0_m_s,
        "w0": linear.trim.w0_m_s,
    }
    return linear.derivatives, constants


@cache
def model_without_mean_removal(tmp_root: str):
    """The preset with deviation columns (no start-mean removal: the data are deviations) and a
    zero-order hold: the data come from a held digital doublet, discretised with a zero-order hold.
    """
    text = (PRESET_DIRECTORY / "delfly_longitudinal.toml").read_text()
    text = text.replace(", remove_start_mean_s = 0.4", "")
    path = f"{tmp_root}/delfly_deviations.toml"
    with open(path, "w") as handle:
        handle.write(text)
    return load_model(path).with_constants(truth()[1]).with_input_hold("zero_order")


def simulated_manoeuvre(model, seed: int, noise_scale: float = 1.0) -> pd.DataFrame:
    derivatives, constants = truth()
    numeric = model.state_space(derivatives, {**model.constants, **constants})
    time_s = np.arange(int(DURATION_S * RATE_HZ)) / RATE_HZ
    elevator = np.where((time_s >= 0.5) & (time_s < 0.83), 0.227, 0.0)
    elevator = np.where((time_s >= 0.83) & (time_s < 1.16), -0.227, elevator)
    discrete = cont2discrete(
        (numeric.a_matrix, numeric.b_matrix, numeric.c_matrix, numeric.d_matrix), 1 / RATE_HZ
    )
    _, outputs, _ = dlsim(discrete[:4] + (1 / RATE_HZ,), elevator[:, None])
    noisy = outputs + noise_scale * NOISE * np.random.default_rng(seed).standard_normal(
        outputs.shape
    )
    return pd.DataFrame(
        {
            "time_s": time_s,
            "q_rad_s": noisy[:, 0],
            "u_m_s": noisy[:, 1],
            "w_m_s": noisy[:, 2],
            "theta_rad": noisy[:, 3],
            "elevator_rad": elevator,
        }
    )


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    return model_without_mean_removal(str(tmp_path_factory.mktemp("models")))


@pytest.fixture(scope="module")
def monte_carlo(model):
    results = {"output_error": [], "equation_error": []}
    for seed in SEEDS:
        data = simulated_manoeuvre(model, seed)
        for method in results:
            results[method].append(identify(model, data, method=method))
    return results


def test_nearly_noise_free_data_give_the_true_parameters(model):
    """With noise 1e-4 of the sensor levels, the estimates sit within their (tiny) sigmas."""
    derivatives, _ = truth()
    result = identify(model, simulated_manoeuvre(model, 0, noise_scale=1e-4))
    assert result.converged, result.message
    for name in model.free_parameter_names:
        estimate = result.parameters[name]
        assert abs(estimate.value - derivatives[name]) <= 4 * estimate.sigma
        assert estimate.sigma < 1e-3 * max(abs(derivatives[name]), 1e-3)
    # Fit is limited by the remaining noise, 1e-4 of the spread: 0.999 leaves margin.
    assert min(result.fit.values()) > 0.999


def test_output_error_intervals_cover_the_truth(monte_carlo, model):
    """+-2 sigma (Cramer-Rao) covers the true value ~95 % of the time, and the scatter of the
    errors matches the stated sigma, parameter by parameter.
    """
    derivatives, _ = truth()
    results = monte_carlo["output_error"]
    assert all(result.converged for result in results), [r.message for r in results]
    errors = np.array(
        [
            [r.parameters[n].value - derivatives[n] for n in model.free_parameter_names]
            for r in results
        ]
    )
    sigmas = np.array(
        [[r.parameters[n].sigma for n in model.free_parameter_names] for r in results]
    )
    covered = np.abs(errors) <= 2 * sigmas
    # Expected 0.954; over 40 x 12 correlated checks a pooled 0.90 is ~3 standard deviations of
    # 40 independent draws (sd 0.033) below it.
    assert covered.mean() >= 0.90
    # Per parameter, 40 draws: 0.80 is about four sd below 0.954.
    assert covered.mean(axis=0).min() >= 0.80
    # Calibration: error scatter / mean sigma, sd of the ratio ~ 1/sqrt(2 x 39) = 0.11 -> 3 sd.
    ratio = errors.std(axis=0, ddof=1) / sigmas.mean(axis=0)
    assert np.all((ratio > 0.65) & (ratio < 1.35)), dict(
        zip(model.free_parameter_names, ratio, strict=True)
    )
    # White noise: the colored-residual correction should change little (its own estimate
    # scatters; 0.8-1.25 on the mean over 40 runs).
    colored = np.array(
        [[r.parameters[n].sigma_colored for n in model.free_parameter_names] for r in results]
    )
    assert 0.8 < np.mean(colored / sigmas) < 1.25


def test_output_error_beats_equation_error_on_the_same_data(monte_carlo, model):
    """Equation error is biased by noisy regressors and smoothed derivatives; output error is not:
    its errors in units of its own sigma are smaller, and its likelihood is higher.
    """
    derivatives, _ = truth()
    names = model.free_parameter_names
    normalised = {
        method: np.mean(
            [
                abs(result.parameters[name].value - derivatives[name])
                / reference.parameters[name].sigma
                for result, reference in zip(results, monte_carlo["output_error"], strict=True)
                for name in names
            ]
        )
        for method, results in monte_carlo.items()
    }
    assert normalised["output_error"] < normalised["equation_error"]
    # Equation error still lands in the right place (it is the start of output error): within
    # 10 output-error sigmas on average.
    assert normalised["equation_error"] < 10
    fits = {m: np.mean([min(r.fit.values()) for r in rs]) for m, rs in monte_carlo.items()}
    assert fits["output_error"] >= fits["equation_error"]


def test_modes_of_the_estimate_are_near_the_truth(monte_carlo, model):
    derivatives, constants = truth()
    true_pair = [
        value
        for value in model.state_space(derivatives, {**model.constants, **constants}).eigenvalues()
        if value.imag > 0
    ][0]
    pulls = []
    for result in monte_carlo["output_error"]:
        mode = next(m for m in result.modes if m.mode.oscillatory)
        pulls.append((mode.mode.eigenvalue.real - true_pair.real) / mode.sigma_real)
    # Delta-method sigma of the eigenvalue's real part: pulls scatter about 1 (0.6-1.5 for 40).
    assert 0.6 < np.std(pulls) < 1.5 and abs(np.mean(pulls)) < 0.6
