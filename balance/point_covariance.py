"""The covariance of a set of tunnel points' loads: their own cycle scatter and the errors they share.

A point's load is its cycle mean minus a zero. Its own error (``<load>_se``, cycle scatter) is independent of every
other point's. The zero is a weighted sum of its run's wind-off tares (``tare_terms``: ``<tare id>=<weight>``;
``balance.run_drift_fit``), so points whose zeros use the same tare share that tare's error in proportion to their
weights on it. Used by the derivative fit and by the pooling of repeats for the tail's contribution.

A record's cycle scatter is itself an estimate, and a rough one: its error comes from about 25 cycle means that
neighbouring cycles' shared boundaries correlate negatively, so the long-run variance ``c0 + 2 c1`` is a small
difference of large terms (``balance.point_loads.standard_error_of_cycle_mean``); on the simulated rig the estimates
of one run's records at one flapping frequency spread over a factor of 3 for the same noise. A fit weighting each
point by its own estimate trusts the records whose scatter happened to come out small. ``pooled_cycle_scatter``
replaces each record's estimate by the mean variance over the records of its run at its flapping frequency (the
same balance, flapping and flow noise), which the derivative fit uses.

Records also scatter beyond their cycle scatter and tares (slow flow unsteadiness, drift the model does not follow,
the conditions read during a record). ``record_to_record_variance`` measures that extra variance where repeats
show it: the Paule-Mandel value, with which a generalised least-squares fit's chi-square equals its degrees of
freedom. The derivative fit and the tail's contribution add it to every record they use.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.optimize import brentq


def shared_tare_errors(points: pd.DataFrame, column: str) -> np.ndarray:
    """(points, tares) matrix of the error each point's ``column`` takes from each tare: ``w_ik se_k`` (point i's
    zero = sum of w_ik * tare k). Tables without ``tare_terms`` hold one tare per point (``tare_id``, weight 1,
    ``<column>_tare_se``)."""
    if "tare_terms" not in points:
        ids = (
            points["tare_id"].astype(str).to_numpy()
            if "tare_id" in points
            else np.arange(len(points))
        )
        unique, columns = np.unique(ids, return_inverse=True)
        errors = np.zeros((len(points), len(unique)))
        errors[np.arange(len(points)), columns] = points[f"{column}_tare_se"].to_numpy(dtype=float)
        return errors
    rows = []
    for terms, standard_errors in zip(
        points["tare_terms"].astype(str), points[f"{column}_tare_terms_se"].astype(str), strict=True
    ):
        pairs = [term.rsplit("=", 1) for term in terms.split(";") if term]
        ses = [float(value) for value in standard_errors.split(";") if value]
        rows.append(
            {tare_id: float(weight) * se for (tare_id, weight), se in zip(pairs, ses, strict=True)}
        )
    tare_ids = sorted({tare_id for row in rows for tare_id in row})
    index = {tare_id: k for k, tare_id in enumerate(tare_ids)}
    errors = np.zeros((len(points), len(tare_ids)))
    for i, row in enumerate(rows):
        for tare_id, error in row.items():
            errors[i, index[tare_id]] = error
    return errors


POOLING_KEYS = ("run_id", "f_set_hz")
"""Records whose cycle-scatter estimates are pooled: one run, one flapping frequency set point."""


def pooled_cycle_scatter(points: pd.DataFrame, column: str) -> np.ndarray:
    """Each row's ``<column>_se`` replaced by the root mean square of ``<column>_se`` over the rows of its run
    (``run_id``) at its flapping frequency (``f_set_hz``), unit of ``column`` (module notes); the keys the table
    lacks are left out of the grouping."""
    keys = [key for key in POOLING_KEYS if key in points]
    variances = points[f"{column}_se"].astype(float) ** 2
    if not keys:
        return np.full(len(points), np.sqrt(variances.mean()))
    groups = [points[key].round(6) if key == "f_set_hz" else points[key] for key in keys]
    return np.sqrt(variances.groupby(groups).transform("mean").to_numpy(dtype=float))


def point_covariance(
    points: pd.DataFrame, column: str, pool_cycle_scatter: bool = False
) -> np.ndarray:
    """Covariance (unit of ``column`` squared) of ``column`` over the rows of ``points``: ``diag(se^2) + E E^T``
    with ``E`` the errors the points take from their tares (:func:`shared_tare_errors`; tares independent);
    ``pool_cycle_scatter``: ``se`` from :func:`pooled_cycle_scatter`."""
    shared = shared_tare_errors(points, column)
    own = (
        pooled_cycle_scatter(points, column)
        if pool_cycle_scatter
        else points[f"{column}_se"].to_numpy(dtype=float)
    )
    return np.diag(own**2) + shared @ shared.T


def generalised_least_squares(
    design: np.ndarray, values: np.ndarray, covariance: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Coefficients, ``(A^T C^-1 A)^-1``, the whitened design and the chi-square of a GLS fit."""
    cholesky = np.linalg.cholesky(covariance)
    weighted_design = np.linalg.solve(cholesky, design)
    weighted_values = np.linalg.solve(cholesky, values)
    normal_inverse = np.linalg.inv(weighted_design.T @ weighted_design)
    coefficients = normal_inverse @ weighted_design.T @ weighted_values
    whitened = weighted_values - weighted_design @ coefficients
    return coefficients, normal_inverse, weighted_design, float(whitened @ whitened)


def record_to_record_variance(
    design: np.ndarray, values: np.ndarray, covariance: np.ndarray
) -> float:
    """Paule-Mandel variance ``s**2`` (unit of ``values`` squared): the one with which the GLS fit's chi-square
    under ``covariance + s**2 I`` equals its degrees of freedom; 0 when the chi-square under ``covariance`` is
    already at or below them, NaN without degrees of freedom. The chi-square falls monotonically in ``s**2``."""
    count, parameters = design.shape
    degrees_of_freedom = count - parameters
    if degrees_of_freedom <= 0:
        return math.nan

    def excess(variance: float) -> float:
        extended = covariance + variance * np.eye(count)
        return generalised_least_squares(design, values, extended)[3] - degrees_of_freedom

    if excess(0.0) <= 0.0:
        return 0.0
    upper = max(float(np.max(np.diag(covariance))), float(np.finfo(float).tiny))
    while excess(upper) > 0.0:
        upper *= 4.0
    return float(brentq(excess, 0.0, upper, xtol=upper * 1e-9))
