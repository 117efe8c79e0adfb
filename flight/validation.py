"""Validation of per-manoeuvre models: errors, rejection flags, the 70/30 split, and the choice
of the representative among the averaged models.

The study's rules (docs/background.md section 5): every individual model is simulated on its own measured
input and compared with its measured states. Per model three flags are summed:

- RMS flag: for each of the four states, 1/4 if the model's RMS error is in the top 20 % of all
  models' RMS errors for that state (at or above the 80th percentile, ``numpy.quantile`` with
  linear interpolation);
- PCC flag: 1 if the mean Pearson correlation over the four states is <= 0.70;
- sigma flag: the number of parameters whose relative standard error |sigma / value| exceeds 1,
  divided by the number of parameters.

A model whose summed flags exceed 1 is rejected.

The representative model (:func:`select_representative`) is, by the study's rule
``most_wins``, the averaged model that scores best on the most validation manoeuvres: on each
validation manoeuvre the model with the lowest normalised RMS error wins one point and the model
with the highest mean PCC wins one point (models tied for best each win it). Most points wins;
a tie in points goes to the lower mean normalised RMS, then to the earlier model in the
candidates' order (mean, weighted, time-averaged). Rule ``lowest_mean_rms`` picks the lowest
mean normalised RMS over the validation manoeuvres. Models that cannot be simulated on every
validation manoeuvre (a non-finite error) take no part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ornitail.core.errors import UserInputError

RMS_TOP_FRACTION = 0.20
PCC_THRESHOLD = 0.70
RELATIVE_SIGMA_THRESHOLD = 1.0
REJECTION_THRESHOLD = 1.0
TRAINING_FRACTION = 0.70
SELECTION_RULES = ("most_wins", "lowest_mean_rms")
DEFAULT_SELECTION_RULE = "most_wins"


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
    rms_flag = np.sum(rms >= threshold, axis=1) / rms.shape[1]
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

    The RMS score of averaged models on the validation manoeuvres (lower is better); dividing by
    the spread makes states in different units comparable.
    """
    errors = response_errors(measured, simulated)
    spread = np.std(np.asarray(measured, dtype=float), axis=0)
    spread = np.where(spread > 0, spread, 1.0)
    return float(np.mean(errors.rms / spread))


def mean_pcc(measured: np.ndarray, simulated: np.ndarray) -> float:
    """Mean over states of the Pearson correlation of a simulated response (higher is better)."""
    return float(np.mean(response_errors(measured, simulated).pcc))


@dataclass(frozen=True)
class ValidationScores:
    """Scores of candidate models (rows, in ``names`` order) on validation manoeuvres (columns):
    ``rms`` the normalised RMS error (:func:`normalised_rms`), ``pcc`` the mean Pearson
    correlation (:func:`mean_pcc`). Non-finite entries mark a failed simulation.
    """

    names: tuple[str, ...]
    rms: np.ndarray
    pcc: np.ndarray

    def eligible(self) -> np.ndarray:
        """True for candidates simulated with finite errors on every validation manoeuvre."""
        return np.all(np.isfinite(self.rms), axis=1) & np.all(np.isfinite(self.pcc), axis=1)

    def mean_rms(self) -> dict[str, float]:
        return dict(zip(self.names, np.mean(self.rms, axis=1).tolist(), strict=True))

    def mean_pcc(self) -> dict[str, float]:
        return dict(zip(self.names, np.mean(self.pcc, axis=1).tolist(), strict=True))

    def wins(self) -> dict[str, dict[str, int]]:
        """Per candidate, the validation manoeuvres it is best on by RMS and by PCC (ties for best
        each count); ineligible candidates win nothing.
        """
        eligible = self.eligible()[:, None]
        rms = np.where(eligible, self.rms, math.inf)
        pcc = np.where(eligible, self.pcc, -math.inf)
        rms_wins = np.sum(eligible & (rms == rms.min(axis=0)), axis=1)
        pcc_wins = np.sum(eligible & (pcc == pcc.max(axis=0)), axis=1)
        return {
            name: {"rms": int(by_rms), "pcc": int(by_pcc)}
            for name, by_rms, by_pcc in zip(self.names, rms_wins, pcc_wins, strict=True)
        }


def select_representative(
    scores: ValidationScores, rule: str = DEFAULT_SELECTION_RULE, where: str = "validation"
) -> str:
    """The name of the representative candidate by ``rule`` (module docstring), or a
    :class:`UserInputError` naming ``where`` when no candidate could be simulated on every
    validation manoeuvre.
    """
    if rule not in SELECTION_RULES:
        raise UserInputError(
            "selection rule", f"{rule!r} is not one of {', '.join(SELECTION_RULES)}"
        )
    eligible = [name for name, ok in zip(scores.names, scores.eligible(), strict=True) if ok]
    if not eligible:
        raise UserInputError(where, "no averaged model could be simulated")
    mean_rms, wins = scores.mean_rms(), scores.wins()

    def rank(name: str) -> tuple[float, ...]:
        points = wins[name]["rms"] + wins[name]["pcc"] if rule == "most_wins" else 0
        return (-points, mean_rms[name], scores.names.index(name))

    return min(eligible, key=rank)
