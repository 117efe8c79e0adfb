"""The covariance of a set of tunnel points' loads: their own cycle scatter and the errors they share.

A point's load is its cycle mean minus a zero. Its own error (``<load>_se``, cycle scatter) is independent of every
other point's. The zero is a weighted sum of wind-off tares (the tare before with ``1 - lambda``, the bracketing
tare after with ``lambda``; ``balance.tare_drift``), so points corrected with the same tare share that tare's
error in proportion to their weights on it; when a run's drift bends, a third tare joins the zero with its own
weight (:class:`ornitail.balance.tare_drift.DriftCheck`). Used by the derivative fit and by the pooling of
repeats for the tail's contribution.
"""

from __future__ import annotations

import numpy as np
import pandas as pd


def weighted_tare_covariance(
    standard_errors: np.ndarray, shared_terms: list[tuple[np.ndarray, np.ndarray]]
) -> np.ndarray:
    """Covariance of points whose own errors are ``standard_errors`` and who share errors ``shared_terms``.

    ``shared_terms`` holds, per shared error source (the tare before, the tare after, a third tare), each point's
    source id and the error it takes from that source (``w * se`` for a tare: point i's zero = sum of
    w_ik * tare k). Sources are independent, so ``cov_ij = se_i^2 delta_ij + sum_k e_ik e_jk`` over the sources k
    both points share.
    """
    covariance = np.diag(np.asarray(standard_errors, dtype=float) ** 2)
    for ids_a, weighted_a in shared_terms:
        for ids_b, weighted_b in shared_terms:
            same = np.asarray(ids_a)[:, None] == np.asarray(ids_b)[None, :]
            covariance = covariance + same * np.outer(weighted_a, weighted_b)
    return covariance


def shared_error_terms(points: pd.DataFrame, column: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """The tares ``column``'s points share: the tare before, after and third when the table has them (weighted),
    else one tare each."""
    if "tare_after_weight" not in points or f"{column}_tare_before_se" not in points:
        ids = points["tare_id"].to_numpy() if "tare_id" in points else np.arange(len(points))
        return [(ids, points[f"{column}_tare_se"].to_numpy(dtype=float))]
    after_weight = points["tare_after_weight"].to_numpy(dtype=float)
    third_weight = (
        points["tare_third_weight"].to_numpy(dtype=float)
        if "tare_third_weight" in points
        else np.zeros(len(points))
    )
    terms = [
        (
            points["tare_id"].to_numpy(),
            points[f"{column}_tare_before_se"].to_numpy(dtype=float)
            * (1.0 - after_weight - third_weight),
        ),
        (
            points["tare_after_id"].fillna("").astype(str).to_numpy(),
            points[f"{column}_tare_after_se"].to_numpy(dtype=float) * after_weight,
        ),
    ]
    if "tare_third_id" in points:
        terms.append(
            (
                points["tare_third_id"].fillna("").astype(str).to_numpy(),
                points[f"{column}_tare_third_se"].to_numpy(dtype=float) * third_weight,
            )
        )
    return terms


def point_covariance(points: pd.DataFrame, column: str) -> np.ndarray:
    """Covariance (unit of ``column`` squared) of ``column`` over the rows of ``points``."""
    return weighted_tare_covariance(
        points[f"{column}_se"].to_numpy(dtype=float), shared_error_terms(points, column)
    )
