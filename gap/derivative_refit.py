"""Derivative-level re-identification: which of the baseline's own parameters the data move.

For a model-file baseline, the first fold's training runs (manoeuvres or segments) re-fit the
model's derivatives (its free parameters that are not nuisance parameters), started at the
baseline's values, in one weighted output-error fit over all of them together, each run simulated
from its measured initial state, by the diagnosis' own yardstick (residuals in noise levels, as the
candidates are fitted and scored), with a covariance clustered by run
(:mod:`ornitail.gap.joint_refit`); the 90 % intervals use Student's t on runs - 1 degrees of
freedom.

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

from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_model import LinearFlightModel
from ornitail.gap.intervals import closure_with_interval
from ornitail.gap.joint_refit import refit_jointly

INTERVAL_PROBABILITY = 0.90  # two-sided


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
    joint = refit_jointly(model, constants, baseline, training, weighted_residuals)
    report: dict[str, object] = {
        "method": "weighted output error over the training runs jointly, run-clustered covariance",
        "training_runs": len(training),
        "converged": joint.converged,
    }
    if not joint.converged:
        return report | {
            "derivatives": None,
            "reason": f"the fit did not converge ({joint.message})",
        }
    # a run-clustered variance has (runs - 1) degrees of freedom
    quantile = float(stats.t.ppf(0.5 + INTERVAL_PROBABILITY / 2, max(len(training) - 1, 1)))
    names, values, sigmas = (
        joint.names,
        joint.values,
        np.sqrt(np.clip(np.diag(joint.covariance), 0, None)),
    )
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

    closure, closure_interval = closure_with_interval(
        sse(baseline, test), sse(joint.model, test), seed
    )
    train_closure, _ = closure_with_interval(
        sse(baseline, training), sse(joint.model, training), seed
    )
    return report | {
        "derivatives": derivatives,
        "moved": [name for name, item in derivatives.items() if item["moved"]],
        "closure_training": train_closure,
        "closure_test": closure,
        "closure_interval": closure_interval,
        "remainder_fraction_test": 1.0 - closure,
        "supported_by_test_runs": bool(closure_interval[0] > 0),
    }
