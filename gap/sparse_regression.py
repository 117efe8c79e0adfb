"""Sequentially thresholded least squares (the regression behind SINDy) on a residual.

Features are standardised, the target is regressed on all of them, coefficients whose
standardised magnitude falls below ``threshold`` (in units of the target's standard deviation) are
dropped and the rest refitted, until the support stops changing. The surviving terms point at the
missing physics; ``explained`` is the fraction of the target's variance they account for.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

DEFAULT_THRESHOLD = 0.2
MAX_ITERATIONS = 20


def sparse_terms(
    features: np.ndarray,
    target: np.ndarray,
    names: Sequence[str],
    threshold: float = DEFAULT_THRESHOLD,
) -> dict[str, object]:
    """Sparse linear model of ``target`` (N,) on ``features`` (N, F) named ``names``.

    Returns ``terms`` ({name: coefficient in the features' own units}) and ``explained``.
    """
    scale = features.std(axis=0)
    usable = scale > 0
    standardised = np.zeros_like(features)
    standardised[:, usable] = (features[:, usable] - features[:, usable].mean(axis=0)) / scale[
        usable
    ]
    centred = target - target.mean()
    spread = centred.std()
    if spread == 0 or not usable.any():
        return {"terms": {}, "explained": 0.0}
    support = usable.copy()
    coefficients = np.zeros(features.shape[1])
    for _ in range(MAX_ITERATIONS):
        coefficients[:] = 0.0
        coefficients[support] = np.linalg.lstsq(standardised[:, support], centred, rcond=None)[0]
        new_support = support & (np.abs(coefficients) >= threshold * spread)
        if np.array_equal(new_support, support):
            break
        support = new_support
        if not support.any():
            break
    coefficients[~support] = 0.0
    if support.any():
        coefficients[support] = np.linalg.lstsq(standardised[:, support], centred, rcond=None)[0]
    explained = 1.0 - np.var(centred - standardised @ coefficients) / spread**2
    terms = {
        names[index]: float(coefficients[index] / scale[index]) for index in np.flatnonzero(support)
    }
    return {"terms": terms, "explained": float(explained)}
