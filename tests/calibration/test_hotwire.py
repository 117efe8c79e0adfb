"""Hot-wire laws: temperature correction, King's law and polynomial fits, law files."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from ornitail.calibration.data_files import EXAMPLE_HOTWIRE_POINTS_PATH
from ornitail.calibration.hotwire_fit import fit_kings_law, fit_polynomial_law
from ornitail.calibration.hotwire_laws import (
    KingsLaw,
    PolynomialHotwireLaw,
    load_hotwire_law,
    save_hotwire_law,
)
from ornitail.calibration.hotwire_points import (
    HotwireCalibrationPoints,
    read_hotwire_points,
    temperature_corrected_voltage,
)
from ornitail.core.errors import UserInputError
from ornitail.core.hashing import content_hash_of_file

TRUE_A_V2, TRUE_B, TRUE_N = 1.60, 0.95, 0.45
WIRE_K, REFERENCE_K = 523.15, 293.15
NOISE_V = 0.002


def synthetic_points(seed: int | None, exponent: float = TRUE_N, noise_v: float = NOISE_V):
    """King's-law points at drifting flow temperature, with Gaussian voltage noise."""
    velocity = np.arange(1, 16) * 0.2
    temperature_k = REFERENCE_K + np.linspace(-1.0, 2.0, velocity.size)
    voltage_at_reference = np.sqrt(TRUE_A_V2 + TRUE_B * velocity**exponent)
    voltage = voltage_at_reference * np.sqrt((WIRE_K - temperature_k) / (WIRE_K - REFERENCE_K))
    if seed is not None:
        voltage = voltage + np.random.default_rng(seed).normal(0.0, noise_v, velocity.size)
    return HotwireCalibrationPoints(velocity, voltage, temperature_k, "sha256:synthetic")


def test_temperature_correction_numbers():
    # T_w = 250 degC, T_ref = 20 degC, T_flow = 25 degC: factor sqrt(230 / 225) = 1.0110500...
    corrected = temperature_corrected_voltage(2.0, 298.15, 293.15, 523.15)
    assert corrected == pytest.approx(2.0 * np.sqrt(230.0 / 225.0), rel=1e-15)
    assert corrected == pytest.approx(2.0221, abs=1e-4)
    # Flow at the reference temperature: no change.
    assert temperature_corrected_voltage(1.7, 293.15, 293.15, 523.15) == 1.7


def test_temperature_correction_refuses_a_wire_colder_than_the_flow():
    with pytest.raises(UserInputError, match="wire"):
        temperature_corrected_voltage(2.0, 400.0, 293.15, 390.0)


def test_noise_free_fixed_exponent_fit_is_exact():
    fit = fit_kings_law(
        synthetic_points(None, exponent=0.5), WIRE_K, REFERENCE_K, free_exponent=False
    )
    # Linear least squares on exact data: only rounding (~1e-15 relative) remains.
    assert fit.law.a_v2 == pytest.approx(TRUE_A_V2, rel=1e-12)
    assert fit.law.b == pytest.approx(TRUE_B, rel=1e-12)
    assert fit.law.exponent_n == 0.5
    assert fit.report.max_abs_residual_m_s < 1e-12


def test_noise_free_free_exponent_fit_is_exact():
    fit = fit_kings_law(synthetic_points(None), WIRE_K, REFERENCE_K)
    # Solver tolerances 1e-12 on a well-conditioned 3-parameter problem.
    assert [fit.law.a_v2, fit.law.b, fit.law.exponent_n] == pytest.approx(
        [TRUE_A_V2, TRUE_B, TRUE_N], rel=1e-8
    )


@pytest.mark.parametrize("seed", [3, 17, 123])
def test_kings_law_fit_recovers_parameters_within_their_standard_errors(seed):
    fit = fit_kings_law(synthetic_points(seed), WIRE_K, REFERENCE_K)
    errors = fit.report.parameter_standard_errors
    # 4 standard errors: a correct fit fails this with probability < 1e-3 per parameter.
    assert abs(fit.law.a_v2 - TRUE_A_V2) < 4 * errors["a_v2"]
    assert abs(fit.law.b - TRUE_B) < 4 * errors["b"]
    assert abs(fit.law.exponent_n - TRUE_N) < 4 * errors["exponent_n"]
    # The standard errors themselves are small: 2 mV of noise pins n to a few hundredths.
    assert errors["exponent_n"] < 0.05


def test_kings_law_standard_errors_have_nominal_coverage():
    seeds = range(200)
    hits = 0
    for seed in seeds:
        fit = fit_kings_law(synthetic_points(seed), WIRE_K, REFERENCE_K)
        standard_error = fit.report.parameter_standard_errors["exponent_n"]
        hits += abs(fit.law.exponent_n - TRUE_N) < 1.96 * standard_error
    # With the noise variance estimated from 15 - 3 = 12 degrees of freedom the interval
    # +-1.96 se covers with probability P(|t_12| < 1.96) = 0.926; allow 4 binomial sd.
    expected = stats.t.cdf(1.96, 12) - stats.t.cdf(-1.96, 12)
    spread = np.sqrt(expected * (1 - expected) / len(seeds))
    assert abs(hits / len(seeds) - expected) < 4 * spread


def test_residual_report_matches_the_noise_level():
    fit = fit_kings_law(synthetic_points(5), WIRE_K, REFERENCE_K)
    # dU/dE = 2E / (B n U^(n-1)); 2 mV of voltage noise maps to this velocity noise per point.
    velocity = fit.report.velocity_m_s
    voltage = np.sqrt(TRUE_A_V2 + TRUE_B * velocity**TRUE_N)
    velocity_noise = NOISE_V * 2 * voltage / (TRUE_B * TRUE_N * velocity ** (TRUE_N - 1))
    expected_rms = np.sqrt(np.mean(velocity_noise**2))
    # The RMS of 15 residuals after fitting 3 parameters scatters by roughly +-30 %.
    assert 0.4 * expected_rms < fit.report.rms_residual_m_s < 1.6 * expected_rms
    np.testing.assert_allclose(
        fit.report.residual_m_s, fit.report.fitted_velocity_m_s - velocity, rtol=1e-15
    )
    assert fit.report.max_abs_residual_m_s == np.max(np.abs(fit.report.residual_m_s))


def test_velocity_from_voltage_is_vectorised_and_corrects_temperature():
    law = fit_kings_law(synthetic_points(None), WIRE_K, REFERENCE_K).law
    velocity = np.array([0.5, 1.0, 2.5])
    flow_k = np.array([290.0, 295.0, 300.0])
    voltage_at_flow = np.sqrt(TRUE_A_V2 + TRUE_B * velocity**TRUE_N) * np.sqrt(
        (WIRE_K - flow_k) / (WIRE_K - REFERENCE_K)
    )
    np.testing.assert_allclose(
        law.velocity_from_voltage(voltage_at_flow, flow_k), velocity, rtol=1e-8
    )
    # Below the zero-flow voltage the velocity is 0, not NaN.
    assert law.velocity_from_voltage(np.sqrt(TRUE_A_V2) - 0.01, REFERENCE_K) == 0.0


def test_polynomial_fit_reproduces_a_polynomial_exactly():
    velocity = np.linspace(0.2, 3.0, 12)
    voltage = 1.2 + 0.3 * velocity - 0.02 * velocity**2
    # Choose velocities as an exact polynomial of the voltages (order 4).
    coefficients = np.array([-3.0, 1.0, 2.0, -0.5, 0.1])
    velocity = np.polynomial.polynomial.polyval(voltage, coefficients)
    points = HotwireCalibrationPoints(velocity, voltage, np.full(12, REFERENCE_K), "sha256:x")
    fit = fit_polynomial_law(points, WIRE_K, 4, REFERENCE_K)
    np.testing.assert_allclose(fit.law.coefficients, coefficients, rtol=1e-6, atol=1e-7)
    assert fit.report.max_abs_residual_m_s < 1e-9


def test_polynomial_needs_more_points_than_its_order():
    points = synthetic_points(None)
    few = HotwireCalibrationPoints(
        points.velocity_m_s[:4], points.voltage_v[:4], points.temperature_k[:4], "sha256:x"
    )
    with pytest.raises(UserInputError, match="order 4 needs more than 4 points"):
        fit_polynomial_law(few, WIRE_K, 4)


def test_example_points_file_gives_back_its_generating_law():
    points = read_hotwire_points(EXAMPLE_HOTWIRE_POINTS_PATH)
    assert points.velocity_m_s.size == 15
    fit = fit_kings_law(points, WIRE_K, REFERENCE_K)
    errors = fit.report.parameter_standard_errors
    # The file was generated with A = 1.60, B = 0.95, n = 0.45 and 2 mV noise (see its header).
    assert abs(fit.law.a_v2 - TRUE_A_V2) < 4 * errors["a_v2"]
    assert abs(fit.law.b - TRUE_B) < 4 * errors["b"]
    assert abs(fit.law.exponent_n - TRUE_N) < 4 * errors["exponent_n"]
    assert fit.law.provenance.points_content_hash == content_hash_of_file(
        EXAMPLE_HOTWIRE_POINTS_PATH
    )


@pytest.mark.parametrize("suffix", [".toml", ".json"])
@pytest.mark.parametrize("law_name", ["king", "polynomial"])
def test_law_files_round_trip_with_the_file_hash(tmp_path, suffix, law_name):
    points = synthetic_points(9)
    fit = (
        fit_kings_law(points, WIRE_K) if law_name == "king" else fit_polynomial_law(points, WIRE_K)
    )
    path = tmp_path / f"law{suffix}"
    saved = save_hotwire_law(fit.law, path)
    loaded = load_hotwire_law(path)
    assert loaded.content_hash == saved.content_hash == content_hash_of_file(path)
    assert type(loaded) is (KingsLaw if law_name == "king" else PolynomialHotwireLaw)
    voltage = np.linspace(1.3, 1.8, 9)
    # Floats are written with repr, which round-trips exactly.
    np.testing.assert_array_equal(
        loaded.velocity_from_voltage(voltage, 295.0), fit.law.velocity_from_voltage(voltage, 295.0)
    )
    assert loaded.provenance.rms_residual_m_s == fit.report.rms_residual_m_s
    if suffix == ".json":
        # A freshly fitted law's hash is that of the JSON file it would be saved as.
        assert fit.law.content_hash == saved.content_hash


@pytest.mark.parametrize(
    ("content", "suffix", "words"),
    [
        ('law = "king"\n', ".toml", r"law\.toml: point_count: required key is missing"),
        ("{not json", ".json", "not valid JSON"),
        (
            json.dumps({"law": "cubic"}),
            ".json",
            r"law\.json: law: 'cubic' must be one of king, poly",
        ),
        ("[1, 2]", ".json", r"law\.json: top level must be a table of keys"),
        ("law = 3", ".yaml", "must end in .toml or .json"),
    ],
)
def test_bad_law_files_are_user_errors(tmp_path, content, suffix, words):
    path = tmp_path / f"law{suffix}"
    path.write_text(content)
    with pytest.raises(UserInputError, match=words):
        load_hotwire_law(path)


@pytest.mark.parametrize(
    ("law_name", "suffix", "old", "new", "message"),
    [
        ("king", ".toml", "\nb = ", "\nb = -", r"law\.toml: b: -[0-9.e-]+ must be > 0"),
        (
            "king",
            ".toml",
            "point_count = 15",
            "point_count = 1.5",
            r"point_count: 1\.5 must be a whole",
        ),
        (
            "king",
            ".toml",
            "\n",
            "\nnote = 1\n",
            r"law\.toml: note: unknown key; allowed keys are a_v2",
        ),
        (
            "king",
            ".json",
            '"wire_temperature_k": 523.15',
            '"wire_temperature_k": 200',
            r"law\.json: wire_temperature_k: 200 must be above reference_temperature_k",
        ),
        (
            "polynomial",
            ".json",
            '"coefficients": [',
            '"coefficients": ["x", ',
            r"law\.json: coefficients: \['x', .* must be 2 or more finite numbers",
        ),
        ("polynomial", ".toml", "law = ", "a_v2 = 1.0\nlaw = ", r"law\.toml: a_v2: unknown key"),
    ],
)
def test_law_file_fields_are_checked(tmp_path, law_name, suffix, old, new, message):
    points = synthetic_points(9)
    fit = (
        fit_kings_law(points, WIRE_K) if law_name == "king" else fit_polynomial_law(points, WIRE_K)
    )
    path = tmp_path / f"law{suffix}"
    save_hotwire_law(fit.law, path)
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(UserInputError, match=message):
        load_hotwire_law(path)
