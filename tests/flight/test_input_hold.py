"""The input hold: exact discretisation under a zero- and a first-order hold, exact sensitivities.

References independent of ornitail's code: scipy.signal.lsim, which simulates a continuous
system exactly for an input held constant (``interp=False``) or linear (``interp=True``) between
samples, and central finite differences for the sensitivities.
"""

import numpy as np
import pytest
from scipy.signal import lsim

from ornitail.core.errors import UserInputError
from ornitail.flight.discretisation import discretise, numeric_hold
from ornitail.flight.linear_simulation import output_sensitivities, simulate_outputs
from ornitail.flight.model_file import load_model, model_from_document

# Twin Otter short period near its estimate (SIDPAC's numbers; Zq in ornitail's convention).
VALUES = {
    "Za": -1.97,
    "Zq": -0.0073,
    "Zde": -0.094,
    "Zbias": 0.0042,
    "Ma": -9.44,
    "Mq": -3.08,
    "Mde": -12.1,
    "Mbias": -0.034,
    "az_bias": -9.49,
}
CONSTANTS = np.array([55.0])  # V, m/s
TIME_STEP_S = 0.02


def model_and_vectors(hold: str):
    model = load_model("twin_otter_short_period").with_input_hold(hold)
    parameters = np.array([VALUES[name] for name in model.parameter_names])
    return model, parameters


def doublet_inputs(count: int = 300) -> np.ndarray:
    """A measured-looking elevator (a rounded doublet with a ramp) and the constant bias input."""
    time_s = np.arange(count) * TIME_STEP_S
    elevator = 0.05 * np.sin(2 * np.pi * 0.7 * time_s) * np.exp(-0.3 * time_s) + 0.01 * time_s
    return np.column_stack([elevator, np.ones(count)])


@pytest.mark.parametrize(("hold", "interpolate"), [("zero_order", False), ("first_order", True)])
def test_simulation_is_exact_for_its_hold(hold, interpolate):
    model, parameters = model_and_vectors(hold)
    inputs = doublet_inputs()
    discrete = discretise(model, parameters, CONSTANTS, TIME_STEP_S)
    initial_state = np.array([0.02, -0.01])
    outputs, _ = simulate_outputs(discrete, initial_state, inputs)
    numeric = model.state_space(VALUES, {"V": CONSTANTS[0]})
    time_s = np.arange(len(inputs)) * TIME_STEP_S
    system = (numeric.a_matrix, numeric.b_matrix, numeric.c_matrix, numeric.d_matrix)
    _, expected, _ = lsim(system, inputs, time_s, X0=initial_state, interp=interpolate)
    # Both are exact up to the matrix exponential's truncation (1e-13 relative) and rounding.
    np.testing.assert_allclose(outputs, expected, rtol=1e-9, atol=1e-11)


def test_a_zero_order_hold_on_a_ramp_lags_the_first_order_hold_by_half_a_sample():
    """On a sampled continuous input, ZOH responds as if the input came dt/2 later."""
    model_zoh, parameters = model_and_vectors("zero_order")
    model_foh, _ = model_and_vectors("first_order")
    inputs = doublet_inputs(600)
    zoh, _ = simulate_outputs(
        discretise(model_zoh, parameters, CONSTANTS, TIME_STEP_S), np.zeros(2), inputs
    )
    foh, _ = simulate_outputs(
        discretise(model_foh, parameters, CONSTANTS, TIME_STEP_S), np.zeros(2), inputs
    )
    # FOH's response shifted by half a sample (linear interpolation) matches ZOH to second
    # order in dt, far better than the unshifted responses match each other.
    shifted = 0.5 * (foh[1:, 1] + foh[:-1, 1])
    assert np.max(np.abs(shifted - zoh[1:, 1])) < 0.1 * np.max(np.abs(foh[1:, 1] - zoh[1:, 1]))


@pytest.mark.parametrize("hold", ["zero_order", "first_order"])
def test_output_sensitivities_equal_finite_differences(hold):
    model, parameters = model_and_vectors(hold)
    inputs = doublet_inputs(200)
    initial_state = np.array([0.02, -0.01])
    discrete = discretise(model, parameters, CONSTANTS, TIME_STEP_S)
    _, states = simulate_outputs(discrete, initial_state, inputs)
    indices = np.arange(len(parameters))
    exact = output_sensitivities(discrete, states, inputs, indices, True)
    for index in indices:
        step = 1e-6 * max(abs(parameters[index]), 1e-3)
        shifted = []
        for sign in (1, -1):
            trial = parameters.copy()
            trial[index] += sign * step
            shifted.append(
                simulate_outputs(
                    discretise(model, trial, CONSTANTS, TIME_STEP_S), initial_state, inputs
                )[0]
            )
        numeric = (shifted[0] - shifted[1]) / (2 * step)
        scale = np.max(np.abs(numeric)) + 1e-12
        # Central differences: error O(step^2) plus rounding ~1e-16/step relative.
        np.testing.assert_allclose(exact[:, :, index], numeric, atol=1e-6 * scale)
    # The initial-state columns: dy/dx0 = C Ad^k.
    np.testing.assert_allclose(exact[1, :, len(parameters)], discrete.c @ discrete.ad[:, 0])


def test_the_hold_is_read_from_the_model_file_and_checked():
    assert load_model("twin_otter_short_period").input_hold == "first_order"
    document = {
        "model": {"states": ["x"], "inputs": ["u"], "outputs": ["x"], "input_hold": "cubic"},
        "parameters": {"a": -1.0},
        "matrices": {"A": [["a"]], "B": [[1]], "C": [[1]]},
        "data": {"time_column": "t"},
        "columns": {"x": "x", "u": "u"},
    }
    with pytest.raises(UserInputError, match=r"\[model\]\.input_hold.*first_order, zero_order"):
        model_from_document(document, "bad.toml")
    document["model"].pop("input_hold")
    assert model_from_document(document, "ok.toml").input_hold == "first_order"
    with pytest.raises(UserInputError, match="input_hold"):
        model_from_document(document, "ok.toml").with_input_hold("linear")


@pytest.mark.parametrize("hold", ["zero_order", "first_order"])
def test_the_numeric_hold_equals_the_differentiable_one(hold):
    """Models without parameters (the gap diagnosis's) are held exactly as the estimator's."""
    model, parameters = model_and_vectors(hold)
    discrete = discretise(model, parameters, CONSTANTS, TIME_STEP_S)
    numeric = model.state_space(VALUES, {"V": CONSTANTS[0]})
    held = numeric_hold(numeric.a_matrix, numeric.b_matrix, TIME_STEP_S, hold)
    for mine, theirs in zip(held, (discrete.ad, discrete.bd, discrete.bd_next), strict=True):
        np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-15)
