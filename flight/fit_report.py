"""Judging a fit as MATLAB's ``compare`` and ``resid`` do: residual correlation sequences and the
warnings that a fit is poor or leaves input-driven dynamics in its residuals.

The tests themselves (whiteness, independence of the inputs) are
:func:`ornitail.flight.residual_statistics.residual_tests`; this module adds the whole sequences
that the report draws and the sentences that name what to look at.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ornitail.flight.residual_statistics import CONFIDENCE_Z, CORRELATION_LAGS, ResidualTests

MINIMUM_FIT = 0.5  # 1 - NRMSE below this on an output is reported as a warning
COMPARE_FIGURE = "compare"
RESIDUALS_FIGURE = "residuals"
AUTOCORRELATION_FIGURE = "residual_autocorrelation"
INPUT_CORRELATION_FIGURE = "residual_input_correlation"


@dataclass(frozen=True)
class ResidualCorrelations:
    """Normalised residual correlations (dimensionless, -1..1) at lags in samples.

    ``autocorrelation[output]`` is at ``auto_lags`` (0..L), ``input_correlation[(output,
    input)]`` at ``cross_lags`` (-L..L, positive: the residual follows the input) for every
    non-constant input; L = min(25, N/4) and ``bound`` = 2.5758/sqrt(N) (99 % normal quantile), as
    MATLAB's ``resid``.
    """

    bound: float
    auto_lags: np.ndarray
    cross_lags: np.ndarray
    autocorrelation: dict[str, np.ndarray]
    input_correlation: dict[tuple[str, str], np.ndarray]


def normalised_correlation(first: np.ndarray, second: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """sum_k a[k] b[k + lag] / sqrt(sum a^2 sum b^2) of the mean-removed signals, per lag
    (samples); zeros when either signal is constant.
    """
    first = first - first.mean()
    second = second - second.mean()
    scale = np.sqrt(np.sum(first**2) * np.sum(second**2))
    if scale == 0:
        return np.zeros(len(lags))
    full = np.correlate(second, first, mode="full")  # full[N - 1 + lag] = sum_k a[k] b[k + lag]
    return full[len(first) - 1 + lags] / scale


def correlation_sequences(
    residuals: np.ndarray,
    inputs: np.ndarray,
    output_names: tuple[str, ...],
    input_names: tuple[str, ...],
) -> ResidualCorrelations:
    """Autocorrelation of each output's residual and its correlation with each non-constant
    input, over the lags that :func:`~ornitail.flight.residual_statistics.residual_tests` tests.
    """
    count = len(residuals)
    lag_count = min(CORRELATION_LAGS, count // 4)
    auto_lags = np.arange(lag_count + 1)
    cross_lags = np.arange(-lag_count, lag_count + 1)
    varying = [index for index in range(len(input_names)) if np.ptp(inputs[:, index]) > 0]
    autocorrelation, input_correlation = {}, {}
    for index, output in enumerate(output_names):
        residual = residuals[:, index]
        autocorrelation[output] = normalised_correlation(residual, residual, auto_lags)
        for input_index in varying:
            input_correlation[(output, input_names[input_index])] = normalised_correlation(
                inputs[:, input_index], residual, cross_lags
            )
    bound = CONFIDENCE_Z / math.sqrt(count)
    return ResidualCorrelations(bound, auto_lags, cross_lags, autocorrelation, input_correlation)


def fit_warnings(fit: Mapping[str, float], tests: ResidualTests) -> list[str]:
    """One sentence per output whose 1 - NRMSE is below 0.5 (or not finite) and per output and
    input whose residual-input correlation fails the 99 % test, naming the figure to look at.
    """
    warnings = [
        f"output {output}: fit (1 - NRMSE) {value:.3f} is below {MINIMUM_FIT}; "
        f"see {COMPARE_FIGURE}.png"
        for output, value in fit.items()
        if not value >= MINIMUM_FIT
    ]
    for output, independent in tests.independent_of_inputs.items():
        if independent:
            continue
        for name, largest in tests.max_input_correlation[output].items():
            if largest > tests.bound:
                warnings.append(
                    f"output {output}: the residual correlates with input {name} beyond the "
                    f"99 % bound (largest |r| {largest:.3f} > {tests.bound:.3f}); "
                    f"see {INPUT_CORRELATION_FIGURE}.png"
                )
    return warnings
