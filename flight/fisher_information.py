"""Fisher information and score of a weighted least-squares fit over time samples and channels."""

from __future__ import annotations

import numpy as np


def fisher_information(sensitivities: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """sum over samples k and channels c of S[k, c, i] w[c] S[k, c, j].

    ``sensitivities`` (samples, channels, parameters): d prediction / d parameter; ``weights`` (channels,): inverse
    noise variances. One matrix product over the flattened samples (a three-operand ``einsum`` loops in C without
    BLAS, several times slower on a manoeuvre).
    """
    count, channels, size = sensitivities.shape
    flat = sensitivities.reshape(count * channels, size)
    weighted = (sensitivities * weights[None, :, None]).reshape(count * channels, size)
    return weighted.T @ flat


def weighted_score(
    sensitivities: np.ndarray, weights: np.ndarray, residuals: np.ndarray
) -> np.ndarray:
    """sum over samples k and channels c of S[k, c, i] w[c] r[k, c]: the Gauss-Newton right-hand side."""
    count, channels, size = sensitivities.shape
    return sensitivities.reshape(count * channels, size).T @ (residuals * weights).reshape(-1)
