"""The linear flight model a diagnosis compares with the data, and its response on a manoeuvre.

States [q (rad/s), u, w (m/s), theta (rad)] as deviations from trim, input elevator (rad), in the
body frame of docs/frames.md; dx/dt = A x + B delta_e, outputs = states. The response on a
manoeuvre starts from the measured first sample and is driven by the measured elevator (held
between samples as the model says, first-order by default: :mod:`ornitail.flight.discretisation`),
optionally delayed by ``delay_s`` and with a measured-theta drift ``theta_drift_rad_s``
(rad/s) counted from the run-in's middle (the run-in mean is what the deviations are taken from).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ornitail.flight.discretisation import numeric_hold
from ornitail.flight.linear_simulation import next_inputs, propagate
from ornitail.gap.flight_data import FlightRun


@dataclass(frozen=True)
class LinearFlightModel:
    """A, B of the longitudinal model (SI), the pitch inertia it uses and its trim.

    ``iyy_kg_m2`` converts a pitch-damping change (N m s/rad) into A; NaN when the model file does
    not declare it. ``theta0_rad`` and ``airspeed_m_s`` are the model's steady state (NaN when
    unknown). ``delay_s`` and ``theta_drift_rad_s`` are measurement augmentations (zero for a
    plain model).
    """

    a_matrix: np.ndarray
    b_matrix: np.ndarray
    iyy_kg_m2: float
    theta0_rad: float
    airspeed_m_s: float
    delay_s: float = 0.0
    theta_drift_rad_s: float = 0.0
    input_hold: str = "first_order"

    def with_matrices(self, a_matrix: np.ndarray, b_matrix: np.ndarray) -> LinearFlightModel:
        return replace(self, a_matrix=a_matrix, b_matrix=b_matrix)


def superpose(
    baseline: LinearFlightModel, first: LinearFlightModel, second: LinearFlightModel
) -> LinearFlightModel:
    """Both changes from ``baseline`` at once: A, B, delay and drift changes added."""
    return replace(
        first,
        a_matrix=first.a_matrix + second.a_matrix - baseline.a_matrix,
        b_matrix=first.b_matrix + second.b_matrix - baseline.b_matrix,
        delay_s=first.delay_s + second.delay_s - baseline.delay_s,
        theta_drift_rad_s=first.theta_drift_rad_s
        + second.theta_drift_rad_s
        - baseline.theta_drift_rad_s,
    )


def simulate_runs(model: LinearFlightModel, runs: Sequence[FlightRun]) -> list[np.ndarray]:
    """Predicted states (N, 4) of ``model`` on each manoeuvre (see the module docstring)."""
    holds: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    predictions = []
    for run in runs:
        step = round(run.time_step_s, 12)
        if step not in holds:
            holds[step] = numeric_hold(
                model.a_matrix, model.b_matrix, run.time_step_s, model.input_hold
            )
        predictions.append(_simulate(model, run, *holds[step]))
    return predictions


def _simulate(
    model: LinearFlightModel, run: FlightRun, ad: np.ndarray, bd: np.ndarray, bd_next: np.ndarray
) -> np.ndarray:
    elevator = run.elevator_rad
    if model.delay_s != 0.0:
        elevator = np.interp(run.time_s - model.delay_s, run.time_s, run.elevator_rad)
    start = run.states[0].copy()
    drift = model.theta_drift_rad_s * (run.time_s - 0.5 * run.input_start_s)
    start[3] -= drift[0]  # the measured first theta holds the drift; the motion starts without it
    inputs = elevator[:, None]
    predicted = propagate(ad, inputs @ bd.T + next_inputs(inputs) @ bd_next.T, start)
    predicted[:, 3] += drift
    if not np.all(np.isfinite(predicted)):
        return np.full_like(predicted, 1e6)
    return predicted
