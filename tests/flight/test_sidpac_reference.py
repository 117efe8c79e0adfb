"""ornitail's output error against NASA SIDPAC on the real Twin Otter record.

Reference: tests/data/twin-otter/sidpac_twin_otter_019.csv, copied unchanged from
shared/reference/: SIDPAC 2.0 ``oe.m`` (Morelli) with the model of its ``Demos/tlonssd.m`` on the
record 020213f1_019 (tests/data/twin-otter/), run under GNU Octave 7.3 by someone outside the
project; Cramer-Rao and colored-residual (``m_colores.m``) sigmas. Its conventions: Zq there is
ornitail's Zq + 1; az_bias is in g (ornitail: m/s^2).
"""

from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.identify import identify
from ornitail.flight.model_file import load_model
from ornitail.flight.output_error import OutputErrorOptions
from ornitail.flight.residual_statistics import morelli_colored_covariance

DATA = Path(__file__).parents[1] / "data" / "twin-otter"
DERIVATIVES = ("Za", "Zq", "Zde", "Ma", "Mq", "Mde")


@cache
def sidpac() -> pd.DataFrame:
    table = pd.read_csv(DATA / "sidpac_twin_otter_019.csv", comment="#").set_index("parameter")
    table.loc["Zq", "value"] -= 1.0  # SIDPAC's A[0, 1] is 1 + ornitail's Zq
    return table


@cache
def estimate(hold: str | None = None, colored_sigma: str = "morelli"):
    model = load_model("twin_otter_short_period")
    if hold:
        model = model.with_input_hold(hold)
    log = read_flight_log(DATA / "twin_otter_020213f1_019.csv")
    return identify(model, log, options=OutputErrorOptions(colored_sigma=colored_sigma))


def test_default_options_reproduce_sidpac_within_half_its_colored_sigma():
    result = estimate()
    assert result.converged, result.message
    reference = sidpac()
    for name in DERIVATIVES:
        difference = result.parameters[name].value - reference.loc[name, "value"]
        assert abs(difference) <= 0.5 * reference.loc[name, "sigma_colored"], name


def test_default_options_reproduce_sidpac_colored_sigmas_within_15_percent():
    result = estimate()
    reference = sidpac()
    for name in DERIVATIVES:
        ratio = result.parameters[name].sigma_colored / reference.loc[name, "sigma_colored"]
        assert 0.85 <= ratio <= 1.15, (name, ratio)


def test_pitch_mode_eigenvalues_match_sidpac_within_one_percent():
    reference = complex(-2.52239, 3.01018)  # the CSV's closing comment
    pair = [value for value in estimate().modes if value.mode.eigenvalue.imag > 0]
    assert len(pair) == 1
    assert abs(pair[0].mode.eigenvalue - reference) <= 0.01 * abs(reference)


def test_a_zero_order_hold_on_the_measured_elevator_is_sigmas_away_from_sidpac():
    """The bias the first-order hold removes: Mq and Mde move by about 4 colored sigmas."""
    result = estimate("zero_order")
    reference = sidpac()
    for name in ("Mq", "Mde"):
        difference = result.parameters[name].value - reference.loc[name, "value"]
        assert abs(difference) > 3 * reference.loc[name, "sigma_colored"], name


def test_the_tapered_colored_sigma_differs_from_sidpacs_where_residuals_correlate_long():
    """The tapered, truncated autocorrelation (lags <= N/10) drops the long-lag correlation of
    the a_z and alpha residuals: it understates the Z-derivatives' sigmas by about 30 % against
    SIDPAC, while the full-lag formula agrees within 15 %.
    """
    tapered = estimate(colored_sigma="tapered")
    reference = sidpac()
    for name in ("Za", "Zq", "Zde"):
        ratio = tapered.parameters[name].sigma_colored / reference.loc[name, "sigma_colored"]
        assert ratio < 0.8, (name, ratio)


def literal_m_colores(weighted: np.ndarray, residuals: np.ndarray, information: np.ndarray):
    """SIDPAC's m_colores.m loops written out: R(l) from unbiased cross-correlations of every
    channel pair, the Toeplitz sum over every pair of samples.
    """
    count, channels, _ = weighted.shape
    correlation = np.zeros((count, channels, channels))
    for lag in range(count):
        for a in range(channels):
            for b in range(channels):
                correlation[lag, a, b] = np.dot(residuals[lag:, a], residuals[: count - lag, b]) / (
                    count - lag
                )
    middle = sum(
        weighted[i].T @ correlation[abs(j - i)] @ weighted[j]
        for i in range(count)
        for j in range(count)
    )
    inverse = np.linalg.inv(information)
    return inverse @ middle @ inverse  # not symmetric: R(l) is used for both signs of j - i


def test_the_colored_covariance_is_sidpacs_formula():
    generator = np.random.default_rng(38)  # a seed whose literal sum is indefinite
    count, channels, size = 60, 3, 4
    weighted = generator.standard_normal((count, channels, size))
    # Colored, cross-correlated residuals: a moving average of mixed white noise.
    white = generator.standard_normal((count + 5, channels)) @ generator.standard_normal((3, 3))
    residuals = np.array([white[k : k + 6].sum(axis=0) for k in range(count)])
    information = np.einsum("kci,kcj->ij", weighted, weighted) + np.eye(size)
    fast = morelli_colored_covariance(weighted, residuals, information)
    literal = literal_m_colores(weighted, residuals, information)
    # SIDPAC reports the diagonal of the literal sum; ornitail keeps its symmetric part raised to
    # at least the Cramer-Rao bound in every direction (eigenvalues of the whitened matrix >= 1).
    symmetric = 0.5 * (literal + literal.T)
    assert np.linalg.eigvalsh(symmetric).min() < 0  # indefinite: the raise is exercised
    factor = np.linalg.cholesky(information)
    values, vectors = np.linalg.eigh(factor.T @ symmetric @ factor)
    raised = (vectors * np.maximum(values, 1.0)) @ vectors.T
    expected = np.linalg.inv(factor).T @ raised @ np.linalg.inv(factor)
    np.testing.assert_allclose(fast, expected, rtol=1e-9, atol=1e-12)
    # Positive definite, and never below the Cramer-Rao bound.
    difference = fast - np.linalg.inv(information)
    assert np.linalg.eigvalsh(difference).min() >= -1e-10 * np.abs(fast).max()
