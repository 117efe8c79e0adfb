"""The three averaged models of a configuration and the mathematics of combining estimates.

- mean of parameters, with the covariance of the mean from the spread across manoeuvres;
- covariance-weighted mean (minimum-covariance combination)
  ``theta = P sum_i P_i^-1 theta_i`` with ``P = (sum_i P_i^-1)^-1``, and the chi-square statistic
  ``sum_i (theta_i - theta)^T P_i^-1 (theta_i - theta)`` with ``(n - 1) p`` degrees of freedom
  testing whether the manoeuvres share one parameter vector (for two models it equals
  ``(theta_1 - theta_2)^T (P_1 + P_2)^-1 (theta_1 - theta_2)``, the test of MATLAB's ``merge``);
- time-averaged response: manoeuvres aligned on their input start and averaged sample by sample.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.stats import chi2

from ornitail.core.errors import UserInputError
from ornitail.flight.identification_result import IdentificationResult
from ornitail.flight.identify import identify
from ornitail.flight.manoeuvre_models import ManoeuvreModel, derivative_part
from ornitail.flight.manoeuvres import Manoeuvre
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.output_error import OutputErrorOptions
from ornitail.flight.sampling import uniform_grid

MERGE_SIGNIFICANCE = 0.05


@dataclass(frozen=True)
class CombinedEstimate:
    """A combined parameter vector and its covariance (parameter order of the inputs)."""

    values: np.ndarray
    covariance: np.ndarray

    @property
    def sigmas(self) -> np.ndarray:
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))


@dataclass(frozen=True)
class WeightedMerge(CombinedEstimate):
    """Covariance-weighted mean with the chi-square test of merging."""

    chi_square: float = float("nan")
    degrees_of_freedom: int = 0
    p_value: float = float("nan")

    @property
    def merge_justified(self) -> bool:
        """True when the manoeuvres' differences are explained by their covariances (p > 5 %)."""
        return bool(self.p_value > MERGE_SIGNIFICANCE)


def mean_of_parameters(values: np.ndarray) -> CombinedEstimate:
    """Plain mean over manoeuvres (rows) and the covariance of that mean (spread / n)."""
    values = np.atleast_2d(np.asarray(values, dtype=float))
    count = values.shape[0]
    if count < 2:
        raise UserInputError("manoeuvres", "averaging needs at least 2 models")
    covariance = np.atleast_2d(np.cov(values, rowvar=False)) / count
    return CombinedEstimate(values.mean(axis=0), covariance)


def covariance_weighted_mean(
    values: np.ndarray, covariances: Sequence[np.ndarray]
) -> WeightedMerge:
    """Minimum-covariance combination of ``n`` estimates (rows of ``values``) and its test.

    Parameters
    ----------
    values : ndarray, shape (n, p)
    covariances : n arrays of shape (p, p), each symmetric positive definite
    """
    values = np.atleast_2d(np.asarray(values, dtype=float))
    count, size = values.shape
    if count < 2 or len(covariances) != count:
        raise UserInputError("manoeuvres", "merging needs at least 2 models with covariances")
    informations = []
    for index, covariance in enumerate(covariances):
        covariance = np.asarray(covariance, dtype=float)
        try:
            informations.append(np.linalg.inv(covariance))
        except np.linalg.LinAlgError as error:
            raise UserInputError(
                f"model {index + 1}", "parameter covariance is singular; cannot weight it"
            ) from error
    information_sum = np.sum(informations, axis=0)
    merged_covariance = np.linalg.inv(information_sum)
    weighted_sum = np.sum(
        [information @ value for information, value in zip(informations, values, strict=True)],
        axis=0,
    )
    merged = merged_covariance @ weighted_sum
    chi_square = float(
        sum(
            (value - merged) @ information @ (value - merged)
            for information, value in zip(informations, values, strict=True)
        )
    )
    degrees = (count - 1) * size
    return WeightedMerge(
        values=merged,
        covariance=0.5 * (merged_covariance + merged_covariance.T),
        chi_square=chi_square,
        degrees_of_freedom=degrees,
        p_value=float(chi2.sf(chi_square, degrees)),
    )


SAMPLE_RATE_TOLERANCE = 1e-4
"""Largest relative difference between the sample intervals of manoeuvres averaged sample by sample (100 ppm:
two loggers' crystal clocks, or one rate estimated from timestamps rounded to a few decimals or jittered, agree
far better; a different nominal rate differs by percents). Over a 10 s manoeuvre at 512 Hz it shifts the last
sample by at most half a sample."""


def time_averaged_response(manoeuvres: Sequence[Manoeuvre]) -> pd.DataFrame:
    """Manoeuvres aligned on their input start and averaged sample by sample.

    All manoeuvres must share the sample rate: each one's interval is the least-squares slope of its time column
    against sample index (:func:`~ornitail.flight.sampling.uniform_grid`: unbiased by rounded or jittered
    timestamps), and they must agree within :data:`SAMPLE_RATE_TOLERANCE` (relative); their mean is used. The
    result is as long as the shortest span before and after the input; its ``time_s`` starts at 0 with the input
    at the common run-in.
    """
    if len(manoeuvres) < 2:
        raise UserInputError("manoeuvres", "a time-averaged response needs at least 2 manoeuvres")
    intervals = [
        uniform_grid(m.deviations["time_s"].to_numpy(float), f"{m.label}: column time_s").step_s
        for m in manoeuvres
    ]
    if max(intervals) - min(intervals) > SAMPLE_RATE_TOLERANCE * min(intervals):
        slowest, fastest = (
            manoeuvres[int(np.argmax(intervals))],
            manoeuvres[int(np.argmin(intervals))],
        )
        raise UserInputError(
            "manoeuvres",
            "time-averaging needs one sample rate for all logs of a configuration: "
            f"{slowest.label} is sampled at {1 / max(intervals):.6g} Hz, {fastest.label} at "
            f"{1 / min(intervals):.6g} Hz (more than {SAMPLE_RATE_TOLERANCE:g} apart, relative)",
        )
    interval = float(np.mean(intervals))
    input_indices = [int(round(m.input_start_s / interval)) for m in manoeuvres]
    before = min(input_indices)
    after = min(
        len(m.deviations) - index for m, index in zip(manoeuvres, input_indices, strict=True)
    )
    columns = [column for column in manoeuvres[0].deviations.columns if column != "time_s"]
    stack = np.stack(
        [
            m.deviations[columns].to_numpy(float)[index - before : index + after]
            for m, index in zip(manoeuvres, input_indices, strict=True)
        ]
    )
    averaged = pd.DataFrame(stack.mean(axis=0), columns=columns)
    averaged.insert(0, "time_s", np.arange(before + after) * interval)
    return averaged


@dataclass(frozen=True)
class AveragedModel:
    """One of the three averaged models of a configuration (parameter order ``parameter_names``).

    ``name`` is ``"mean"``, ``"weighted"`` or ``"time_averaged"``; ``merge`` holds the chi-square
    test for the weighted mean; ``result`` the identification of the time-averaged response.
    """

    name: str
    parameter_names: tuple[str, ...]
    estimate: CombinedEstimate
    merge: WeightedMerge | None = None
    result: IdentificationResult | None = None

    def parameter_values(self) -> dict[str, float]:
        return dict(zip(self.parameter_names, self.estimate.values.tolist(), strict=True))


AVERAGED_MODEL_NAMES = ("mean", "weighted", "time_averaged")


def fit_time_averaged_model(
    spec: StateSpaceModelSpec, manoeuvres: Sequence[Manoeuvre], colored_sigma: str = "morelli"
) -> AveragedModel:
    """Identify ``spec`` (constants at the configuration's trim) once on the time-averaged
    response of ``manoeuvres``: equation error, then output error started from it. Its
    estimate holds the derivatives only (nuisance biases stay in ``result``).
    """
    data = time_averaged_response(manoeuvres)
    first_guess = identify(spec, data, method="equation_error")
    start = {name: first_guess.parameters[name].value for name in first_guess.parameter_names}
    options = OutputErrorOptions(colored_sigma=colored_sigma)
    result = identify(spec, data, method="output_error", start=start, options=options)
    names, values, covariance = derivative_part(spec, result)
    estimate = CombinedEstimate(values, covariance)
    return AveragedModel("time_averaged", names, estimate, result=result)


def averaged_models(
    spec: StateSpaceModelSpec,
    models: Sequence[ManoeuvreModel],
    colored_sigma: str = "morelli",
) -> list[AveragedModel]:
    """The mean, covariance-weighted and time-averaged-response models of ``models``' manoeuvres.

    ``spec`` carries the configuration's trim constants (used by the time-averaged fit).
    """
    names = models[0].parameter_names
    if any(model.parameter_names != names for model in models):
        raise ValueError("all manoeuvre models must estimate the same parameters")
    values = np.array([model.values for model in models])
    merge = covariance_weighted_mean(values, [model.covariance for model in models])
    return [
        AveragedModel("mean", names, mean_of_parameters(values)),
        AveragedModel("weighted", names, merge, merge=merge),
        fit_time_averaged_model(spec, [model.manoeuvre for model in models], colored_sigma),
    ]
