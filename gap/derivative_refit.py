"""Derivative-level re-identification: which of the baseline's own parameters the data move.

For a model-file baseline, the first fold's training runs are fitted by the flight package's
output-error estimator (:func:`ornitail.flight.output_error.estimate_output_error`, started at the
baseline's values, from the measured initial state unless the model estimates it):

- *manoeuvres* (runs with a run-in before a repeated input): one fit of their time-averaged
  response, the runs aligned on the input and averaged sample by sample (the campaign's
  time-averaged model: gusts and noise average out, which one manoeuvre's fit cannot afford);
- *segments* (no repeated input to align on): every segment is fitted on its own and the
  derivative estimates (the free parameters that are not nuisance parameters) are combined by the
  campaign's covariance-weighted mean with their colored-residual covariances
  (:func:`ornitail.flight.averaged_models.covariance_weighted_mean`). When the runs disagree more than
their covariances allow (the merge's chi-square above its degrees of freedom: the runs do not share
one parameter vector) the combined covariance is scaled by chi-square / degrees of freedom (the
Birge ratio squared), so the interval covers the runs' real scatter. Each derivative is reported
with the baseline's value, the re-fit value, the change and its 90 % interval (+-1.645 sigma of the
combination); a change whose interval excludes zero has *moved*. Runs whose fit does not converge
(one short run rarely determines every derivative) are left out and counted. The re-fit model (every derivative
at its combined value, nuisance parameters at their start) is then scored on the first fold's
test runs like a candidate: its closure is what a full linear re-fit closes on runs it did not
see, the most any change of the linear model's derivatives explains (more free parameters than a
candidate, so it also absorbs noise on the training runs and can close less on test runs). The
moves are *supported by test runs* only when that closure's 5 % bound is above zero: a re-fit that
predicts the unseen runs no better than the baseline (flapper B's static-stability change: seven
derivatives "moved" on the training average, test closure -0.004 [-0.008, -0.001]) bent the model
to the training runs, and its moves do not say where the model is wrong.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.flight.averaged_models import covariance_weighted_mean
from ornitail.flight.manoeuvre_models import derivative_part
from ornitail.flight.model_data import ModelData
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.output_error import estimate_output_error
from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_localisation import aligned_on_input
from ornitail.gap.flight_model import LinearFlightModel
from ornitail.gap.intervals import closure_with_interval

INTERVAL_SIGMAS = 1.645  # two-sided 90 %


def _run_data(run: FlightRun, constants: Mapping[str, float]) -> ModelData:
    return ModelData(
        time_s=run.time_s,
        time_step_s=run.time_step_s,
        inputs=run.inputs,
        outputs=run.outputs,
        states=run.states,
        constants=dict(constants),
    )


def _averaged_data(runs: Sequence[FlightRun], constants: Mapping[str, float]) -> ModelData:
    """The runs aligned on their input and averaged sample by sample, as one record."""
    outputs, inputs, states = (
        aligned_on_input(runs, [getattr(run, name) for run in runs]).mean(axis=0)
        for name in ("outputs", "inputs", "states")
    )
    step = runs[0].time_step_s
    return ModelData(
        time_s=np.arange(len(outputs)) * step,
        time_step_s=step,
        inputs=inputs,
        outputs=outputs,
        states=states,
        constants=dict(constants),
    )


def _estimates(
    model: StateSpaceModelSpec, records: Sequence[tuple[ModelData, np.ndarray]]
) -> tuple[tuple[str, ...], list[np.ndarray], list[np.ndarray], int]:
    """Derivative names, estimates and colored covariances of the converged fits of
    ``records`` ((data, initial state) pairs), and how many did not converge."""
    names, estimates, covariances, failed = (), [], [], 0
    for data, initial_state in records:
        try:
            result = estimate_output_error(model, data, model.start_values(), initial_state)
        except UserInputError:
            failed += 1
            continue
        names, values, covariance = derivative_part(model, result)
        if result.converged and np.all(np.isfinite(values)) and np.all(np.isfinite(covariance)):
            estimates.append(values)
            covariances.append(covariance)
        else:
            failed += 1
    return names, estimates, covariances, failed


def _combined(
    estimates: list[np.ndarray], covariances: list[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Values, covariance, merge p-value and covariance inflation of one or several estimates."""
    if len(estimates) == 1:
        return estimates[0], covariances[0], float("nan"), 1.0
    merged = covariance_weighted_mean(np.array(estimates), covariances)
    inflation = max(1.0, merged.chi_square / max(merged.degrees_of_freedom, 1))
    return merged.values, merged.covariance * inflation, merged.p_value, inflation


def refit_derivatives(
    model: StateSpaceModelSpec,
    constants: Mapping[str, float],
    baseline: LinearFlightModel,
    training: Sequence[FlightRun],
    test: Sequence[FlightRun],
    test_sse: Callable[[LinearFlightModel, Sequence[FlightRun]], np.ndarray],
    seed: int,
) -> dict[str, object]:
    """The report's ``derivative_refit`` (module docstring). ``test_sse(model, runs)`` gives each
    run's weighted squared residual, as the candidates are scored."""
    start = model.start_values()
    manoeuvres = all(run.input_start_s > 0 for run in training)
    if manoeuvres:
        averaged = _averaged_data(training, constants)
        records = [(averaged, averaged.states[0])]
        method = "output error on the time-averaged training manoeuvres"
    else:
        records = [(_run_data(run, constants), run.initial_state) for run in training]
        method = "output error per training segment, covariance-weighted mean"
    names, estimates, covariances, failed = _estimates(model, records)
    needed = 1 if manoeuvres else 2
    report: dict[str, object] = {
        "method": method,
        "training_runs": len(training),
        "fits": len(records),
        "fits_not_converged": failed,
    }
    if len(estimates) < needed:
        return report | {"derivatives": None, "reason": "the output-error fit did not converge"}
    try:
        values, covariance, p_value, inflation = _combined(estimates, covariances)
    except UserInputError as error:
        return report | {"derivatives": None, "reason": str(error)}
    sigmas = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    derivatives = {}
    for index, name in enumerate(names):
        value, sigma = float(values[index]), float(sigmas[index])
        change = value - start[name]
        interval = [change - INTERVAL_SIGMAS * sigma, change + INTERVAL_SIGMAS * sigma]
        derivatives[name] = {
            "baseline": start[name],
            "refit": value,
            "change": change,
            "change_interval": interval,
            "relative_change": change / start[name] if start[name] else None,
            "moved": bool(interval[0] > 0 or interval[1] < 0),
            "unit": model.parameter(name).unit,
        }
    numeric = model.state_space({**start, **dict(zip(names, values, strict=True))}, constants)
    refit = replace(
        baseline,
        a_matrix=numeric.a_matrix,
        b_matrix=numeric.b_matrix,
        c_matrix=numeric.c_matrix,
        d_matrix=numeric.d_matrix,
    )
    closure, interval = closure_with_interval(test_sse(baseline, test), test_sse(refit, test), seed)
    return report | {
        "merge_p_value": p_value,
        "covariance_inflation": inflation,
        "derivatives": derivatives,
        "moved": [name for name, item in derivatives.items() if item["moved"]],
        "closure_test": closure,
        "closure_interval": interval,
        "supported_by_test_runs": bool(interval[0] > 0),
    }
