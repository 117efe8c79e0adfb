"""A model file's derivatives re-fitted jointly over several runs, by the diagnosis' own yardstick.

The objective is the one every candidate is fitted and scored with: the runs' output residuals
(each run simulated from its measured initial state), divided per channel by the diagnosis' noise
levels, squared and summed over all training runs. So the re-fit's closure on its training runs is
never below zero, and its closure on test runs is comparable with a candidate's. (The output-error
fit of the runs' time average it replaces weighted the channels by its own residual variances and
estimated an initial state the runs' scoring does not: on flapper B it mostly did not converge in 100
iterations, and where it did, on a static-stability flight, its seven "moved" derivatives closed
-0.004 on the test runs; fitted jointly, the same training runs close 0.47 on themselves and 0.17
on those test runs, and another split's 0.39.) It lives here rather than in the
flight package's estimator because it must see the runs exactly as the candidates do: simulated by
:func:`ornitail.gap.flight_model.simulate_runs` (the runs' own initial states, input history,
delays and filters) and weighed by the diagnosis' fixed noise levels, where the flight package fits
one record and estimates its own noise covariance (maximum likelihood).

Every derivative is free (no prior): where one doublet shape does not determine a derivative, its
interval says so by its width. (A prior of each derivative's own size was tried as mixed
estimation: with the residuals in noise-level units rather than the noise's own, it outweighed the
data and kept flapper B's static-stability re-fit (the other split) at a test closure of 0.015, against 0.39
free.)

*Covariance*: clustered by run, as a leave-one-run-out jackknife. The residuals within a run are
strongly correlated (gusts, the model error itself) but runs are independent, so the run is the unit
of evidence; each run's removal is taken as one Gauss-Newton step from the optimum, d_r = (J^T J -
J_r^T J_r)^-1 J_r^T e_r, and the covariance is (R - 1) / R sum_r (d_r - mean d)(d_r - mean d)^T over R
runs, with R - 1 degrees of freedom (the intervals use Student's t). Where the runs have the same
input, as in the coverage test (tests/gap/test_derivative_refit.py), it equals the sandwich
(J^T J)^-1 [sum_r s_r s_r^T R / (R - 1)] (J^T J)^-1 with s_r = J_r^T e_r: over 60 seeds of 4 DelFly
manoeuvres the 90 % intervals held each of the 12 derivatives' true change in 0.87-0.97 of the seeds,
0.91 pooled. Where they differ (segments of a record, each holding other inputs), a run that carries
more of a derivative's information weighs more when it is left out, which the sandwich misses with
few runs (the CR3 estimator of Cameron and Miller's "Practitioner's guide to cluster-robust
inference", J. Human Resources 50, 2015): on 30 records of a lateral-directional model cut into 20
segments (10 training; the records of tests/gap/test_lateral_model.py at data seeds 10-39, an offline
survey, docs/gap-diagnosis.md step 7), the intervals of its 12 unchanged derivatives held zero in 0.875
against the sandwich's 0.853.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.gap.flight_candidates import model_matrices
from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_model import LinearFlightModel

DIVERGED = 1e3  # a residual this many times the baseline's largest: the simulation diverged


@dataclass(frozen=True)
class JointRefit:
    """Re-fitted derivatives (``names``, ``values`` in the model file's units), their covariance
    and the re-fitted model."""

    names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    model: LinearFlightModel
    converged: bool
    message: str


def _model_at(
    spec: StateSpaceModelSpec,
    constants: Mapping[str, float],
    baseline: LinearFlightModel,
    values: Mapping[str, float],
) -> LinearFlightModel:
    """``baseline`` with the model file's matrices at ``values`` (other parameters at their start)."""
    return replace(baseline, **model_matrices(spec, {**spec.start_values(), **values}, constants))


def refit_jointly(
    spec: StateSpaceModelSpec,
    constants: Mapping[str, float],
    baseline: LinearFlightModel,
    training: Sequence[FlightRun],
    weighted_residuals: Callable[[LinearFlightModel, Sequence[FlightRun]], list[np.ndarray]],
) -> JointRefit:
    """Weighted least-squares derivatives over ``training``, within the model file's bounds (module
    docstring);
    ``weighted_residuals(model, runs)`` gives each run's residual (samples, outputs) divided by the
    diagnosis' noise levels."""
    start = spec.start_values()
    names = spec.derivative_names
    start_vector = np.array([start[name] for name in names])
    sizes = [run.outputs.size for run in training]

    def residual_rows(model: LinearFlightModel) -> np.ndarray:
        with np.errstate(all="ignore"):
            return np.concatenate([r.ravel() for r in weighted_residuals(model, training)])

    limit = DIVERGED * max(float(np.max(np.abs(residual_rows(baseline)))), 1e-300)

    def data_rows(vector: np.ndarray) -> np.ndarray:
        rows = residual_rows(
            _model_at(spec, constants, baseline, dict(zip(names, vector, strict=True)))
        )
        if not (np.all(np.isfinite(rows)) and np.max(np.abs(rows)) <= limit):
            return np.full(sum(sizes), limit)
        return rows

    bounds = (
        [spec.parameter(name).lower for name in names],
        [spec.parameter(name).upper for name in names],
    )  # the model file's own (infinite when it gives none)
    fit = least_squares(
        data_rows,
        start_vector,
        bounds=bounds,
        x_scale="jac",
        method="trf",
        max_nfev=200 * len(names),
    )
    values = fit.x
    jacobian, residual = fit.jac, fit.fun
    covariance = _jackknife_covariance(jacobian, residual, sizes)
    model = _model_at(spec, constants, baseline, dict(zip(names, values, strict=True)))
    return JointRefit(names, values, covariance, model, bool(fit.success), str(fit.message))


def _jackknife_covariance(
    jacobian: np.ndarray, residual: np.ndarray, sizes: Sequence[int]
) -> np.ndarray:
    """Leave-one-run-out (jackknife) covariance of the fitted parameters, each run's removal taken as
    one Gauss-Newton step from the optimum: d_r = (H - H_r)^-1 s_r, H = J^T J, H_r and s_r = J_r^T e_r
    run r's share, and the covariance (R - 1) / R sum_r (d_r - mean d)(d_r - mean d)^T."""
    information = jacobian.T @ jacobian
    ends = zip(np.cumsum([0, *sizes[:-1]]), np.cumsum(sizes), strict=True)
    shifts = []
    for first, last in ends:
        part = jacobian[first:last]
        shifts.append(np.linalg.pinv(information - part.T @ part) @ (part.T @ residual[first:last]))
    shifts = np.array(shifts)
    shifts -= shifts.mean(axis=0)
    runs = len(sizes)
    return shifts.T @ shifts * (runs - 1) / runs
