"""Validation of per-manoeuvre models: errors, rejection flags, the 70/30 split, scoring.

The study's rules (domain.md section 5): every individual model is simulated on its own measured
input and compared with its measured states. Per model three flags are summed:

- RMS flag: for each of the four states, 1/4 if the model's RMS error is in the top 20 % of all
  models' RMS errors for that state (strictly above the 80th percentile);
- PCC flag: 1 if the mean Pearson correlation over the four states is <= 0.70;
- sigma flag: the number of parameters whose relative standard error |sigma / value| exceeds 1,
  divided by the number of parameters.

A model whose summed flags exceed 1 is rejected.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.core.errors import UserInputError

RMS_TOP_FRACTION = 0.20
PCC_THRESHOLD = 0.70
RELATIVE_SIGMA_THRESHOLD = 1.0
REJECTION_THRESHOLD = 1.0
TRAINING_FRACTION = 0.70


@dataclass(frozen=True)
class ResponseErrors:
    """RMS error (state units) and Pearson correlation per state of one simulated response."""

    rms: np.ndarray
    pcc: np.ndarray


@dataclass(frozen=True)
class RejectionFlags:
    """Flags per model (rows) and the verdict; ``total = rms + pcc + sigma``."""

    rms: np.ndarray
    pcc: np.ndarray
    sigma: np.ndarray
    total: np.ndarray
    rejected: np.ndarray


def response_errors(measured: np.ndarray, simulated: np.ndarray) -> ResponseErrors:
    """RMS error and Pearson correlation coefficient per column of two (samples, states) arrays.

    A column with no variation in either signal has an undefined correlation, reported as 0.
    """
    measured = np.asarray(measured, dtype=float)
    simulated = np.asarray(simulated, dtype=float)
    if measured.shape != simulated.shape:
        raise ValueError(f"shapes differ: {measured.shape} vs {simulated.shape}")
    rms = np.sqrt(np.mean((measured - simulated) ** 2, axis=0))
    measured_centred = measured - measured.mean(axis=0)
    simulated_centred = simulated - simulated.mean(axis=0)
    denominator = np.sqrt(
        np.sum(measured_centred**2, axis=0) * np.sum(simulated_centred**2, axis=0)
    )
    numerator = np.sum(measured_centred * simulated_centred, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        pcc = np.where(denominator > 0, numerator / denominator, 0.0)
    return ResponseErrors(rms=rms, pcc=pcc)


def rejection_flags(rms: np.ndarray, pcc: np.ndarray, relative_sigma: np.ndarray) -> RejectionFlags:
    """The study's flags for ``n`` models.

    Parameters
    ----------
    rms, pcc : ndarray, shape (n, states)
        RMS error and Pearson correlation of each model's simulated states.
    relative_sigma : ndarray, shape (n, parameters)
        |sigma / value| of each model's parameters (inf for a zero estimate).
    """
    rms = np.atleast_2d(np.asarray(rms, dtype=float))
    pcc = np.atleast_2d(np.asarray(pcc, dtype=float))
    relative_sigma = np.atleast_2d(np.asarray(relative_sigma, dtype=float))
    if not (rms.shape == pcc.shape and rms.shape[0] == relative_sigma.shape[0]):
        raise ValueError("rms, pcc and relative_sigma must describe the same models")
    threshold = np.quantile(rms, 1.0 - RMS_TOP_FRACTION, axis=0)
    rms_flag = np.sum(rms > threshold, axis=1) / rms.shape[1]
    pcc_flag = (np.mean(pcc, axis=1) <= PCC_THRESHOLD).astype(float)
    sigma_flag = (
        np.sum(~(relative_sigma <= RELATIVE_SIGMA_THRESHOLD), axis=1) / relative_sigma.shape[1]
    )  # NaN sigma counts as badly determined
    total = rms_flag + pcc_flag + sigma_flag
    return RejectionFlags(rms_flag, pcc_flag, sigma_flag, total, total > REJECTION_THRESHOLD)


def split_training_validation(
    count: int, seed: int, training_fraction: float = TRAINING_FRACTION
) -> tuple[np.ndarray, np.ndarray]:
    """Random split of ``count`` items into training and validation indices (sorted).

    The training share is ``round(training_fraction * count)``, kept between 1 and count - 1 so
    that both sets are non-empty; the same seed gives the same split.
    """
    if count < 2:
        raise UserInputError(
            "manoeuvres", f"{count} accepted manoeuvre(s): need at least 2 to split 70/30"
        )
    training_count = min(max(round(training_fraction * count), 1), count - 1)
    order = np.random.default_rng(seed).permutation(count)
    return np.sort(order[:training_count]), np.sort(order[training_count:])


def normalised_rms(measured: np.ndarray, simulated: np.ndarray) -> float:
    """Mean over states of RMS error divided by the measured signal's standard deviation.

    The score by which averaged models are ranked on the validation manoeuvres (lower is
    better); dividing by the spread makes states in different units comparable.
    """
    errors = response_errors(measured, simulated)
    spread = np.std(np.asarray(measured, dtype=float), axis=0)
    spread = np.where(spread > 0, spread, 1.0)
    return float(np.mean(errors.rms / spread))
