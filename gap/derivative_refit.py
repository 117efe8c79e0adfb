"""Derivative-level re-identification: which of the baseline's own parameters the data move.

For a model-file baseline, the first fold's training runs re-fit the model's derivatives (its free
parameters that are not nuisance parameters), started at the baseline's values:

- *manoeuvres* (runs with a run-in before a repeated input): one weighted output-error fit over
  all training runs together, each simulated from its measured initial state, by the diagnosis'
  own yardstick (residuals in noise levels, as the candidates are fitted and scored), with a
  covariance clustered by run (:mod:`ornitail.gap.joint_refit`); intervals use Student's t on
  runs - 1 degrees of freedom;
- *segments* (no repeated input to align on): every segment is fitted on its own by the flight
  package's output-error estimator (:func:`ornitail.flight.output_error.estimate_output_error`) and
  the derivative estimates are combined by the campaign's covariance-weighted mean with their
  colored-residual covariances (:func:`ornitail.flight.averaged_models.covariance_weighted_mean`).
  When the runs disagree more than their covariances allow (the merge's chi-square above its
  degrees of freedom: the runs do not share one parameter vector) the combined covariance is scaled
  by chi-square / degrees of freedom (the Birge ratio squared). Runs whose fit does not converge are
  left out and counted.

Each derivative is reported with the baseline's value, the re-fit value, the change and its 90 %
interval; a change whose interval excludes zero has *moved*. The re-fit model is then scored on the
first fold's test runs like a candidate: its closure is what a full linear re-fit closes on runs it
did not see, the most any change of the linear model's derivatives explains (more free parameters
than a candidate, so it also absorbs noise on the training runs and can close less on test runs),
and what it leaves (``remainder_fraction_test``, 1 - that closure) is the nonlinear remainder with
the noise. The moves are *supported by test runs* only when that closure's 5 % bound is above zero:
a re-fit that predicts the unseen runs no better than the baseline bent the model to the training
runs, and its moves do not say where the model is wrong.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from scipy import stats

from ornitail.core.errors import UserInputError
from ornitail.flight.averaged_models import covariance_weighted_mean
from ornitail.flight.manoeuvre_models import derivative_part
from ornitail.flight.model_data import ModelData
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.output_error import estimate_output_error
from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_model import LinearFlightModel
from ornitail.gap.intervals import closure_with_interval
from ornitail.gap.joint_refit import model_at, refit_jointly

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
    weighted_residuals: Callable[[LinearFlightModel, Sequence[FlightRun]], list[np.ndarray]],
    seed: int,
) -> dict[str, object]:
    """The report's ``derivative_refit`` (module docstring). ``weighted_residuals(model, runs)``
    gives each run's residual divided by the diagnosis' noise levels, as the candidates are fitted
    and scored."""
    start = model.start_values()
    if all(run.input_start_s > 0 for run in training):
        joint = refit_jointly(model, constants, baseline, training, weighted_residuals)
        report: dict[str, object] = {
            "method": "weighted output error over the training manoeuvres jointly, run-clustered "
            "covariance",
            "training_runs": len(training),
            "fits": 1,
            "fits_not_converged": 0 if joint.converged else 1,
        }
        if not joint.converged:
            return report | {
                "derivatives": None,
                "reason": f"the fit did not converge ({joint.message})",
            }
        names, values, covariance, refit = joint.names, joint.values, joint.covariance, joint.model
        p_value, inflation = float("nan"), 1.0
        # a run-clustered variance has (runs - 1) degrees of freedom
        quantile = float(stats.t.ppf(0.95, max(len(training) - 1, 1)))
    else:
        records = [(_run_data(run, constants), run.initial_state) for run in training]
        names, estimates, covariances, failed = _estimates(model, records)
        report = {
            "method": "output error per training segment, covariance-weighted mean",
            "training_runs": len(training),
            "fits": len(records),
            "fits_not_converged": failed,
        }
        if len(estimates) < 2:
            return report | {"derivatives": None, "reason": "the output-error fit did not converge"}
        try:
            values, covariance, p_value, inflation = _combined(estimates, covariances)
        except UserInputError as error:
            return report | {"derivatives": None, "reason": str(error)}
        refit = model_at(model, constants, baseline, dict(zip(names, values, strict=True)))
        quantile = INTERVAL_SIGMAS
    sigmas = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    derivatives = {}
    for index, name in enumerate(names):
        value, sigma = float(values[index]), float(sigmas[index])
        change = value - start[name]
        interval = [change - quantile * sigma, change + quantile * sigma]
        derivatives[name] = {
            "baseline": start[name],
            "refit": value,
            "change": change,
            "change_interval": interval,
            "relative_change": change / start[name] if start[name] else None,
            "moved": bool(interval[0] > 0 or interval[1] < 0),
            "unit": model.parameter(name).unit,
        }

    def sse(candidate: LinearFlightModel, runs: Sequence[FlightRun]) -> np.ndarray:
        return np.array([np.sum(r**2) for r in weighted_residuals(candidate, runs)])

    closure, interval = closure_with_interval(sse(baseline, test), sse(refit, test), seed)
    train_closure, _ = closure_with_interval(sse(baseline, training), sse(refit, training), seed)
    return report | {
        "merge_p_value": p_value,
        "covariance_inflation": inflation,
        "derivatives": derivatives,
        "moved": [name for name, item in derivatives.items() if item["moved"]],
        "closure_training": train_closure,
        "closure_test": closure,
        "closure_interval": interval,
        "remainder_fraction_test": 1.0 - closure,
        "supported_by_test_runs": bool(interval[0] > 0),
    }
