"""Model files: the presets load; every mistake names the file and the field."""

import math
from pathlib import Path

import numpy as np
import pytest

from ornitail.core.errors import UserInputError
from ornitail.flight.model_file import PRESET_DIRECTORY, load_model, preset_names
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import linearise
from ornitail.vehicle.constants import STANDARD_GRAVITY_M_S2

MINIMAL = """
[model]
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[constants]
k = 2.0

[parameters]
a = { start = -1.0, lower = -10.0, upper = 0.0 }
b = 0.5

[matrices]
A = [["a"]]
B = [["b*k"]]
C = [[1]]

[data]
time_column = "t"

[columns]
x = "x_col"
y = "x_col"
u = { column = "u_deg", scale = 0.0174533 }
"""


def write_model(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_presets_load_by_name():
    assert set(preset_names()) >= {"delfly_longitudinal", "twin_otter_short_period"}
    delfly = load_model("delfly_longitudinal")
    assert delfly.states == ("q", "u", "w", "theta") and delfly.inputs == ("elevator",)
    assert len(delfly.free_parameter_names) == 12
    otter = load_model("twin_otter_short_period")
    assert otter.outputs == ("alpha", "q", "a_z") and otter.columns["bias"].constant == 1.0


def test_the_bias_preset_is_the_study_model_plus_nuisance_biases():
    """Same derivatives, constants and A; B gains a bias column; the biases are nuisance."""
    study, biased = load_model("delfly_longitudinal"), load_model("delfly_longitudinal_bias")
    assert biased.inputs == ("elevator", "bias") and biased.columns["bias"].constant == 1.0
    assert biased.derivative_names == study.free_parameter_names == study.derivative_names
    nuisance = [p.name for p in biased.parameters if p.nuisance]
    assert nuisance == ["bq", "bu", "bw", "btheta"]
    assert biased.constants == study.constants
    values = {**study.start_values(), "bq": 0.3, "bu": -0.05, "bw": 0.04, "btheta": 0.02}
    with_biases = biased.state_space(values, biased.constants)
    without = study.state_space(study.start_values(), study.constants)
    np.testing.assert_array_equal(with_biases.a_matrix, without.a_matrix)
    np.testing.assert_array_equal(with_biases.b_matrix[:, :1], without.b_matrix)
    np.testing.assert_array_equal(with_biases.b_matrix[:, 1], [0.3, -0.05, 0.04, 0.02])


def test_nuisance_must_be_a_boolean_and_not_every_free_parameter(tmp_path):
    text = MINIMAL.replace("upper = 0.0 }", 'upper = 0.0, nuisance = "yes" }')
    with pytest.raises(UserInputError, match=r"\[parameters\.a\]\.nuisance: 'yes' must be true or"):
        load_model(write_model(tmp_path, text))
    text = MINIMAL.replace("upper = 0.0 }", "upper = 0.0, nuisance = true }")
    text = text.replace("b = 0.5", "b = { start = 0.5, nuisance = true }")
    with pytest.raises(UserInputError, match=r"every free parameter is a nuisance parameter"):
        load_model(write_model(tmp_path, text))
    text = MINIMAL.replace("upper = 0.0 }", "upper = 0.0, nuisance = true }")
    model = load_model(write_model(tmp_path, text))
    assert model.derivative_names == ("b",) and model.free_parameter_names == ("a", "b")


def test_the_delfly_preset_is_the_simulators_linear_model():
    """With the simulator's derivatives and trim, the preset's A and B equal linearise()'s."""
    linear = linearise(study_configuration("S3", 98))
    model = load_model("delfly_longitudinal")
    constants = {
        "m": linear.mass_kg,
        "Iyy": linear.iyy_kg_m2,
        "g": STANDARD_GRAVITY_M_S2,
        "theta0": linear.trim.theta_rad,
        "u0": linear.trim.u0_m_s,
        "w0": linear.trim.w0_m_s,
    }
    numeric = model.with_constants(constants).state_space(linear.derivatives, constants)
    # linearise() is a central difference of the nonlinear model (steps 1e-3): agreement to 1e-4
    # relative of the largest entry.
    scale = np.abs(linear.a_matrix).max()
    np.testing.assert_allclose(numeric.a_matrix, linear.a_matrix, atol=1e-4 * scale)
    np.testing.assert_allclose(numeric.b_matrix, linear.b_matrix, atol=1e-4 * scale)
    np.testing.assert_array_equal(numeric.c_matrix, np.eye(4))


def test_a_file_path_loads_and_builds_numeric_matrices(tmp_path):
    model = load_model(write_model(tmp_path, MINIMAL))
    numeric = model.state_space({"a": -3.0, "b": 0.25}, model.constants)
    assert numeric.a_matrix.tolist() == [[-3.0]] and numeric.b_matrix.tolist() == [[0.5]]
    assert numeric.d_matrix.tolist() == [[0.0]]
    assert model.parameter("a").lower == -10.0 and math.isinf(model.parameter("b").upper)
    assert model.columns["u"].scale == pytest.approx(0.0174533)


@pytest.mark.parametrize(
    ("old", "new", "where", "problem"),
    [
        ('A = [["a"]]', 'A = [["a*zeta"]]', "[matrices].A[1][1]", "unknown name 'zeta'"),
        ('B = [["b*k"]]', 'B = [["b", "k"]]', "[matrices].B", "must be 1x1, found 1x2"),
        ("C = [[1]]", 'C = [["__import__(1)"]]', "[matrices].C[1][1]", "only the functions"),
        ("C = [[1]]\n", "", "[matrices].C", "required key is missing"),
        ("upper = 0.0 }", "upper = -20.0 }", "[parameters.a].lower", "-10 must be below upper -20"),
        ("lower = -10.0", "lower = -0.5", "[parameters.a].start", "-1 must lie within the bounds"),
        ("lower = -10.0", "lower = nan", "[parameters.a].lower", "nan must be a finite number"),
        ("b = 0.5", 'b = "half"', "[parameters].b", "'half' must be a finite number"),
        ("b = 0.5", "b = { lower = 0.5 }", "[parameters.b].start", "required key is missing"),
        ("b = 0.5", "b = { start = 0.5, fixd = true }", "[parameters.b].fixd", "unknown key"),
        ("b = 0.5", "k = 0.5", "[parameters].k", "'k' is also defined as a constant"),
        ("b = 0.5", "sin = 0.5", "[parameters].sin", "'sin' is a function name"),
        ("k = 2.0", "k = nan", "[constants].k", "nan must be a finite number"),
        ("k = 2.0", 'k = "two"', "[constants].k", "'two' must be a finite number"),
        ("k = 2.0", "2k = 2.0", "[constants].2k", "'2k' is not a valid name"),
        (
            "k = 2.0",
            'k = { column = "k_col", statistic = "max" }',
            "[constants.k].statistic",
            "'max' must be one of mean, median, first",
        ),
        ("k = 2.0", 'k = { colum = "k_col" }', "[constants.k].colum", "unknown key"),
        ('y = "x_col"\n', "", "[columns].y", "required key is missing"),
        ('y = "x_col"', 'y = ""', "[columns].y", "'' must be a non-empty string"),
        ('y = "x_col"', "y = 3", "[columns].y", "3 must be a column name or a table"),
        ('y = "x_col"', "y = { constant = 1.0 }", "[columns].y", "only an input may be a constant"),
        ("scale = 0.0174533", "scale = 0", "[columns.u].scale", "0 must be nonzero"),
        ("scale = 0.0174533", "constant = 1.0", "[columns.u]", "exactly one of the keys column"),
        (
            'u = { column = "u_deg", scale = 0.0174533 }',
            "u = { constant = 1.0, offset = 2.0 }",
            "[columns.u].offset",
            "a constant signal takes no scale",
        ),
        (
            "scale = 0.0174533",
            "remove_start_mean_s = -1",
            "[columns.u].remove_start_mean_s",
            "-1 must be > 0",
        ),
        ('x = "x_col"', 'z = "x_col"', "[columns].z", "unknown key; allowed keys are u, x, y"),
        ('time_column = "t"', 'time_colum = "t"', "[data].time_colum", "unknown key"),
        (
            'time_column = "t"',
            'time_column = "t"\ntime_scale = 0',
            "[data].time_scale",
            "0 must be > 0",
        ),
        ("[data]", "[dataz]", "dataz", "unknown key; allowed keys are columns, constants"),
        ('outputs = ["y"]', 'outputs = ["y", "y"]', "[model].outputs", "must be unique names"),
        ('outputs = ["y"]', 'outputs = "y"', "[model].outputs", "'y' must be a list of 1 or more"),
        ('outputs = ["y"]', "outputs = []", "[model].outputs", "[] must be a list of 1 or more"),
        ('inputs = ["u"]', 'inputs = ["x"]', "[model].inputs", "'x' is also a state"),
        ('outputs = ["y"]', 'outputs = ["u"]', "[model].outputs", "'u' is also an input"),
        (
            'states = ["x"]',
            'states = ["x"]\ninitial_state = "guess"',
            "[model].initial_state",
            "'guess' must be one of estimate, data, zero",
        ),
        ('states = ["x"]', 'states = ["x"]\nname = 3', "[model].name", "3 must be a"),
        ('states = ["x"]', 'states = ["x"]\nstate = ["x"]', "[model].state", "unknown key"),
    ],
)
def test_mistakes_name_file_and_field(tmp_path, old, new, where, problem):
    assert old in MINIMAL
    path = write_model(tmp_path, MINIMAL.replace(old, new))
    with pytest.raises(UserInputError) as error:
        load_model(path)
    assert error.value.where == f"{path}: {where}"
    assert problem in error.value.problem and "\n" not in str(error.value)


def test_missing_and_wrong_tables_are_named(tmp_path):
    text = MINIMAL.replace("[model]", "[modell]")
    with pytest.raises(UserInputError, match=r"modell: unknown key; allowed keys are"):
        load_model(write_model(tmp_path, text))
    parameters = MINIMAL[MINIMAL.index("[parameters]") : MINIMAL.index("[matrices]")]
    with pytest.raises(UserInputError, match=r"model\.toml: parameters: required key is missing"):
        load_model(write_model(tmp_path, MINIMAL.replace(parameters, "")))
    text = MINIMAL.replace(parameters, "[parameters]\n")
    with pytest.raises(UserInputError, match=r"\[parameters\]: the model has no parameters"):
        load_model(write_model(tmp_path, text))
    text = MINIMAL.replace(parameters, "[parameters]\na = { start = 1.0, fixed = true }\n")
    with pytest.raises(UserInputError, match=r"\[parameters\]: every parameter is fixed"):
        load_model(write_model(tmp_path, text))
    text = MINIMAL.replace('states = ["x"]', 'states = ["x"]\ninitial_state = "data"')
    text = text.replace('x = "x_col"\n', "")
    with pytest.raises(UserInputError, match=r"\[columns\]\.x: required key is missing"):
        load_model(write_model(tmp_path, text))
    text = MINIMAL.replace('time_column = "t"', 'time_column = "t"\n[model2]\na = 1')
    with pytest.raises(UserInputError, match=r"model2: unknown key"):
        load_model(write_model(tmp_path, text))
    text = "data = 3\n" + MINIMAL.replace('[data]\ntime_column = "t"', "")
    with pytest.raises(UserInputError, match=r"model\.toml: \[data\]: must be a table"):
        load_model(write_model(tmp_path, text))


def test_missing_file_and_bad_toml_are_user_errors(tmp_path):
    with pytest.raises(UserInputError, match="not a preset name"):
        load_model(tmp_path / "nothing.toml")
    with pytest.raises(UserInputError, match="not valid TOML"):
        load_model(write_model(tmp_path, "[model\nstates = 1"))


def test_with_constants_refuses_unknown_names_and_nan():
    model = load_model("delfly_longitudinal")
    assert model.with_constants({"m": 0.03}).constants["m"] == 0.03
    with pytest.raises(UserInputError):
        model.with_constants({"mass": 0.03})
    with pytest.raises(UserInputError):
        model.with_constants({"m": math.nan})


def test_preset_files_are_shipped_in_the_package_folder():
    assert (PRESET_DIRECTORY / "delfly_longitudinal.toml").is_file()
