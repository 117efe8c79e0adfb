"""Residual analysis: fit, whiteness, residual-input correlation, colored-residual covariance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.core.normal_quantiles import NORMAL_QUANTILE_99

CORRELATION_LAGS = 25  # lags tested, as MATLAB's resid
CONFIDENCE_Z = NORMAL_QUANTILE_99  # MATLAB's resid draws 99 % bounds


@dataclass(frozen=True)
class ResidualTests:
    """Whiteness and residual-input independence at 99 % confidence over lags 1..25 (whiteness)
    and -25..25 (cross-correlation). ``bound`` is 2.5758/sqrt(N) (99 % normal quantile) on the normalised correlation;
    a signal fails when more than 1 % of its tested lags exceed it.
    """

    bound: float
    max_autocorrelation: dict[str, float]
    white: dict[str, bool]
    max_input_correlation: dict[str, dict[str, float]]
    independent_of_inputs: dict[str, bool]


def fit_per_output(measured: np.ndarray, simulated: np.ndarray) -> np.ndarray:
    """1 - NRMSE per column: 1 - ||z - y|| / ||z - mean(z)|| (MATLAB ``compare``, as a fraction)."""
    spread = np.linalg.norm(measured - measured.mean(axis=0), axis=0)
    error = np.linalg.norm(measured - simulated, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(spread > 0, 1.0 - error / spread, np.nan)


def _normalised_correlation(first: np.ndarray, second: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """sum_k a[k] b[k+lag] / (N std(a) std(b)) for each lag (biased estimate)."""
    first = first - first.mean()
    second = second - second.mean()
    scale = np.sqrt(np.sum(first**2) * np.sum(second**2))
    count = len(first)
    values = np.array(
        [
            np.dot(first[: count - lag], second[lag:])
            if lag >= 0
            else np.dot(first[-lag:], second[: count + lag])
            for lag in lags
        ]
    )
    return values / scale if scale > 0 else np.zeros(len(lags))


def residual_tests(
    residuals: np.ndarray,
    inputs: np.ndarray,
    output_names: tuple[str, ...],
    input_names: tuple[str, ...],
) -> ResidualTests:
    """Whiteness and residual-input correlation tests (constant inputs are skipped)."""
    count = len(residuals)
    lag_count = min(CORRELATION_LAGS, count // 4)
    bound = CONFIDENCE_Z / np.sqrt(count)
    allowed_exceedances = int(0.01 * lag_count)
    auto_lags = np.arange(1, lag_count + 1)
    cross_lags = np.arange(-lag_count, lag_count + 1)
    max_auto, white, max_cross, independent = {}, {}, {}, {}
    for index, output in enumerate(output_names):
        auto = np.abs(_normalised_correlation(residuals[:, index], residuals[:, index], auto_lags))
        max_auto[output] = float(auto.max())
        white[output] = bool(np.sum(auto > bound) <= allowed_exceedances)
        max_cross[output] = {}
        exceed = 0
        tested = 0
        for input_index, name in enumerate(input_names):
            if np.ptp(inputs[:, input_index]) == 0:
                continue
            cross = np.abs(
                _normalised_correlation(inputs[:, input_index], residuals[:, index], cross_lags)
            )
            max_cross[output][name] = float(cross.max())
            exceed += int(np.sum(cross > bound))
            tested += len(cross_lags)
        independent[output] = bool(exceed <= int(0.01 * tested))
    return ResidualTests(bound, max_auto, white, max_cross, independent)


COLORED_SIGMA_METHODS = ("morelli", "tapered", "morelli_small_sample")


def colored_residual_covariance(
    weighted_sensitivities: np.ndarray,
    residuals: np.ndarray,
    information: np.ndarray,
    method: str = "morelli",
) -> np.ndarray:
    """Parameter covariance corrected for colored residuals by ``method`` (see
    :func:`morelli_colored_covariance`, :func:`tapered_colored_covariance` and, for
    ``morelli_small_sample``, :func:`small_sample_factor`).
    """
    if method == "morelli":
        return morelli_colored_covariance(weighted_sensitivities, residuals, information)
    if method == "morelli_small_sample":
        covariance = morelli_colored_covariance(weighted_sensitivities, residuals, information)
        return covariance * small_sample_factor(residuals, information.shape[0])
    if method == "tapered":
        return tapered_colored_covariance(weighted_sensitivities, residuals, information)
    raise ValueError(f"unknown colored-residual method {method!r}")


def residual_correlations(residuals: np.ndarray, unbiased: bool = True) -> np.ndarray:
    """R[l, a, b] = sum_k v_a[k + l] v_b[k] / (N - l) (or / N when not ``unbiased``), l = 0..N-1:
    every channel pair's residual correlation at every non-negative lag, as SIDPAC's ``xcorrs``.
    """
    count, channels = residuals.shape
    length = 2 * count
    spectra = np.fft.rfft(residuals, n=length, axis=0)
    products = spectra[:, :, None] * np.conj(spectra)[:, None, :]
    correlations = np.fft.irfft(products, n=length, axis=0)[:count]
    divisor = count - np.arange(count) if unbiased else np.full(count, count)
    return correlations / divisor[:, None, None]


def morelli_colored_covariance(
    weighted_sensitivities: np.ndarray, residuals: np.ndarray, information: np.ndarray
) -> np.ndarray:
    """Parameter covariance corrected for colored residuals as NASA SIDPAC's ``m_colores.m``
    computes it (Morelli and Klein, "Aircraft System Identification", 2006, section 6.7):

    Cov = M^-1 [sum_i sum_j (W S_i)^T R(|j - i|) (W S_j)] M^-1,

    with S_i the output sensitivities at sample i, W the inverse noise covariance, and R(l) the
    channels' residual correlation matrix at lag l over *all* lags 0..N-1, unbiased (divided by
    N - l) as ``m_colores`` gets it from ``xcorrs``; R(l)[a, b] = sum_k v_a[k+l] v_b[k]/(N - l),
    used for both signs of j - i as SIDPAC does. The double sum is a Toeplitz product, formed for
    each channel pair by one FFT convolution. The result is raised to at least the Cramer-Rao
    bound in every direction (:func:`at_least_cramer_rao`), which makes it positive definite.

    Parameters
    ----------
    weighted_sensitivities : (N, channels, parameters) array
        W S_k: sensitivities multiplied by the channel weights (inverse noise variances).
    residuals : (N, channels) array
    information : (parameters, parameters) array
        M = sum_k S_k^T W S_k.
    """
    count, channels, size = weighted_sensitivities.shape
    length = 2 * count
    correlations = residual_correlations(residuals)
    kernel = np.zeros((length, channels, channels))
    kernel[:count] = correlations
    kernel[count + 1 :] = correlations[1:][::-1]
    kernel_spectra = np.fft.rfft(kernel, axis=0)
    sensitivity_spectra = np.fft.rfft(weighted_sensitivities, n=length, axis=0)
    # filtered[k, a, p] = sum_b sum_j R_ab(|k - j|) (W S_j)[b, p]
    filtered = np.fft.irfft(
        np.einsum("fab,fbp->fap", kernel_spectra, sensitivity_spectra), n=length, axis=0
    )[:count]
    middle = np.einsum("kap,kaq->pq", weighted_sensitivities, filtered)
    inverse = np.linalg.pinv(information)
    covariance = inverse @ middle @ inverse
    return at_least_cramer_rao(0.5 * (covariance + covariance.T), information)


def at_least_cramer_rao(covariance: np.ndarray, information: np.ndarray) -> np.ndarray:
    """``covariance`` raised, in every direction, to at least the Cramer-Rao bound M^-1.

    In coordinates where M^-1 is the identity (z = L^T theta, M = L L^T) the covariance's
    eigenvalues below 1 are set to 1. The unbiased full-lag correlation of
    :func:`morelli_colored_covariance` does not give a positive semi-definite bracket: on the Twin
    Otter record the colored covariance has a correlation-scale eigenvalue of -0.19, and on short
    simulated manoeuvres most of them are indefinite, a few with negative variances. Where the
    correction inflates the bound (real data: 3-5x) nothing changes; in the directions where it
    would shrink it below the white-noise bound (an artefact of estimating the correlation from
    one short record) the bound is kept. The result is a positive definite covariance that a
    weighted mean, a merge test or the delta method can use; on the Twin Otter record it moves
    the derivatives' sigmas by at most 2.5 %.
    """
    if not (np.all(np.isfinite(covariance)) and np.all(np.isfinite(information))):
        return covariance
    try:
        factor = np.linalg.cholesky(0.5 * (information + information.T))
    except np.linalg.LinAlgError:
        return covariance
    whitened = factor.T @ covariance @ factor
    values, vectors = np.linalg.eigh(0.5 * (whitened + whitened.T))
    if values.min() >= 1.0:
        return covariance
    raised = (vectors * np.maximum(values, 1.0)) @ vectors.T
    inverse_factor = np.linalg.inv(factor)
    result = inverse_factor.T @ raised @ inverse_factor
    return 0.5 * (result + result.T)


def tapered_colored_covariance(
    weighted_sensitivities: np.ndarray,
    residuals: np.ndarray,
    information: np.ndarray,
    max_lag: int | None = None,
) -> np.ndarray:
    """Parameter covariance corrected for colored residuals, with a truncated, tapered
    autocorrelation (the option ``tapered``; ornitail's default before it followed SIDPAC).

    Cov = M^-1 [sum_i sum_j S_i^T W Rvv(j - i) W S_j] M^-1, with Rvv(l) the residual
    autocorrelation of each channel, estimated as (1/N) sum_k v[k] v[k+l] for |l| <= ``max_lag``
    (default N/10) and tapered by Bartlett's window 1 - |l|/(max_lag + 1), which keeps the bracket
    positive semi-definite. Lags beyond the window are dropped: over all lags the sample
    autocorrelation sums to a bracket without its lag-0 term (the residuals are orthogonal to the
    sensitivities at the optimum), which understates the covariance (by ~17 % on white noise).

    Parameters
    ----------
    weighted_sensitivities : (N, channels, parameters) array
        W S_k: sensitivities (or regressors) multiplied by the channel weights (inverse noise
        variances).
    residuals : (N, channels) array
    information : (parameters, parameters) array
        M = sum_k S_k^T W S_k.
    """
    count, channels, size = weighted_sensitivities.shape
    max_lag = max(1, count // 10) if max_lag is None else min(max_lag, count - 1)
    length = 2 * count
    lags = np.arange(max_lag + 1)
    taper = 1.0 - lags / (max_lag + 1.0)
    middle = np.zeros((size, size))
    for channel in range(channels):
        residual_spectrum = np.fft.rfft(residuals[:, channel], n=length)
        autocorrelation = np.fft.irfft(np.abs(residual_spectrum) ** 2, n=length)[: max_lag + 1]
        autocorrelation *= taper / count
        spectra = np.fft.rfft(weighted_sensitivities[:, channel, :], n=length, axis=0)
        # cross[l, a, b] = sum_i w_a[i] w_b[i + l] for l >= 0
        cross = np.fft.irfft(np.conj(spectra)[:, :, None] * spectra[:, None, :], n=length, axis=0)[
            : max_lag + 1
        ]
        lagged = np.einsum("l,lab->ab", autocorrelation[1:], cross[1:])
        middle += autocorrelation[0] * cross[0] + lagged + lagged.T
    inverse = np.linalg.pinv(information)
    covariance = inverse @ middle @ inverse
    return 0.5 * (covariance + covariance.T)


def integrated_autocorrelation_time(residual: np.ndarray) -> float:
    """tau = 1 + 2 sum_{l=1}^{L} rho(l) (samples) of one residual channel: rho the biased sample
    autocorrelation (mean removed), summed over the initial positive run of lags, L the last lag
    before rho first drops to zero or below. 1 for white noise; about fs / (2 B) for noise
    low-passed at bandwidth B (Hz) and sampled at fs (Hz).
    """
    values = np.asarray(residual, dtype=float) - np.mean(residual)
    count = len(values)
    spectrum = np.fft.rfft(values, n=2 * count)
    autocovariance = np.fft.irfft(np.abs(spectrum) ** 2, n=2 * count)[:count]
    if autocovariance[0] <= 0:
        return 1.0
    rho = autocovariance[1:] / autocovariance[0]
    non_positive = np.flatnonzero(rho <= 0)
    last = int(non_positive[0]) if non_positive.size else len(rho)
    return float(1.0 + 2.0 * np.sum(rho[:last]))


def effective_sample_count(residuals: np.ndarray) -> float:
    """N_eff = N / mean_c tau_c: the number of effectively independent samples per channel of
    (N, channels) residuals (:func:`integrated_autocorrelation_time` per channel).
    """
    residuals = np.asarray(residuals, dtype=float).reshape(len(residuals), -1)
    times = [integrated_autocorrelation_time(residuals[:, c]) for c in range(residuals.shape[1])]
    return float(len(residuals) / np.mean(times))


SMALL_SAMPLE_MINIMUM_DEGREES = 1.0
"""Smallest N_eff - p the small-sample factor divides by (a record with fewer effectively
independent samples than estimated values gets factor N_eff: sigmas that say "not determined")."""


def small_sample_factor(residuals: np.ndarray, estimated_count: int) -> float:
    """Variance factor N_eff / (N_eff - p) of the option ``morelli_small_sample``.

    Residuals at the estimate are the noise with the fitted directions projected out: for white
    noise E[sum v^2] = (N - p) sigma^2, the classical degrees-of-freedom loss. For residuals
    correlated over tau samples the noise lives in N_eff = N / tau effectively independent
    samples and the p fitted directions (smooth output sensitivities, in the noise's band)
    remove p of them, so the residual correlation that :func:`morelli_colored_covariance` builds
    its bracket from is low by (N_eff - p) / N_eff, and more so at the low frequencies the
    sensitivities weight. ``estimated_count`` p counts every estimated value (free parameters,
    nuisance biases and estimated initial state); N_eff from :func:`effective_sample_count`.
    White noise: N / (N - p), about 1 for a long record.
    """
    effective = effective_sample_count(residuals)
    return float(effective / max(effective - estimated_count, SMALL_SAMPLE_MINIMUM_DEGREES))
