"""The linear flight model a diagnosis compares with the data, and its response on a run.

dx/dt = A x + B u, y = C x + D u in the model's own states, inputs and outputs (SI, or the units
its model file's ``[columns]`` scale the log to); the DelFly simulator's model has states and
outputs [q (rad/s), u, w (m/s), theta (rad)] (body frame of docs/frames.md) and input elevator
(rad). The response on a run starts from the run's measured initial state and is driven by the
logged inputs (held between samples as the model says, first-order by default:
:mod:`ornitail.flight.discretisation`), each changed by the model's measurement augmentations:

- ``delays_s[j]`` (s): input j acts that long after it is logged (u_true(t) = u_log(t - d));
- ``filters_s[j]`` (s): input j is logged through a first-order low-pass of that time constant,
  so the input that acts is u_true = u_log + tau du_log/dt (the filter inverted). The derivative
  is not formed where it would be integrated: with T = diag(tau), z = x - B T u_log obeys
  dz/dt = A z + (B + A B T) u_log, and x = z + B T u_log; only a feed-through D T du_log/dt
  (an output that reads the input directly) uses the sampled derivative;
- ``output_biases[i]`` (output i's unit): output i is measured with that constant offset;
- ``output_drifts[i]`` (output i's unit per s): output i is measured with a drift counted from
  the middle of the run-in before the input (the run-in mean is what deviations are taken from).

An output measured by the same data column as a state (same name) carries its bias and drift into
the measured initial state, which is corrected before the motion starts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from ornitail.flight.discretisation import numeric_hold
from ornitail.flight.linear_simulation import next_inputs, propagate
from ornitail.gap.flight_data import SIMULATOR_CHANNELS, FlightRun


def _zeros(count: int) -> tuple[float, ...]:
    return (0.0,) * count


@dataclass(frozen=True)
class LinearFlightModel:
    """A, B, C, D of the model, its names, the pitch inertia it uses and its trim.

    ``iyy_kg_m2`` and ``mass_kg`` are NaN when the model does not declare them; ``theta0_rad`` and ``airspeed_m_s``
    are the model's steady state (NaN when unknown). ``c_matrix``/``d_matrix`` None mean C = I,
    D = 0. ``dynamic_rows`` are the state equations with free coefficients (the detection rule's
    random directions act there; a kinematic row such as theta' = q is left alone). The
    augmentation tuples (see the module docstring) are empty for a plain model (all zero).
    """

    a_matrix: np.ndarray
    b_matrix: np.ndarray
    iyy_kg_m2: float
    theta0_rad: float
    airspeed_m_s: float
    mass_kg: float = math.nan
    input_hold: str = "first_order"
    c_matrix: np.ndarray | None = None
    d_matrix: np.ndarray | None = None
    state_names: tuple[str, ...] = SIMULATOR_CHANNELS
    input_names: tuple[str, ...] = ("elevator",)
    output_names: tuple[str, ...] = SIMULATOR_CHANNELS
    dynamic_rows: tuple[int, ...] = (0, 1, 2)
    delays_s: tuple[float, ...] = field(default=())
    filters_s: tuple[float, ...] = field(default=())
    output_biases: tuple[float, ...] = field(default=())
    output_drifts: tuple[float, ...] = field(default=())

    def with_matrices(self, a_matrix: np.ndarray, b_matrix: np.ndarray) -> LinearFlightModel:
        return replace(self, a_matrix=a_matrix, b_matrix=b_matrix)

    def with_input_change(
        self, index: int, delay_s: float = 0.0, filter_s: float = 0.0
    ) -> LinearFlightModel:
        """This model with input ``index`` delayed by ``delay_s`` and/or filtered by ``filter_s``."""
        delays = list(self.delays_s or _zeros(len(self.input_names)))
        filters = list(self.filters_s or _zeros(len(self.input_names)))
        delays[index] += delay_s
        filters[index] += filter_s
        return replace(self, delays_s=tuple(delays), filters_s=tuple(filters))

    def with_output_change(
        self, index: int, bias: float = 0.0, drift_per_s: float = 0.0
    ) -> LinearFlightModel:
        """This model with output ``index`` measured with ``bias`` and/or ``drift_per_s`` more."""
        biases = list(self.output_biases or _zeros(len(self.output_names)))
        drifts = list(self.output_drifts or _zeros(len(self.output_names)))
        biases[index] += bias
        drifts[index] += drift_per_s
        return replace(self, output_biases=tuple(biases), output_drifts=tuple(drifts))

    @property
    def c(self) -> np.ndarray:
        """C (outputs x states)."""
        return np.eye(len(self.a_matrix)) if self.c_matrix is None else self.c_matrix

    @property
    def d(self) -> np.ndarray:
        """D (outputs x inputs)."""
        if self.d_matrix is None:
            return np.zeros((len(self.output_names), self.b_matrix.shape[1]))
        return self.d_matrix


@dataclass(frozen=True)
class FlightCandidate:
    """One candidate effect: ``build(k)`` is the model with the effect at magnitude ``k`` (in
    ``unit``, within ``bounds``); ``build(0)`` is the baseline."""

    name: str
    description: str
    unit: str
    bounds: tuple[float, float]
    build: Callable[[float], LinearFlightModel]


def _add(
    first: tuple[float, ...], second: tuple[float, ...], base: tuple[float, ...], count: int
) -> tuple[float, ...]:
    """first + second - base of augmentation tuples (empty = ``count`` zeros)."""

    def full(values: tuple[float, ...]) -> np.ndarray:
        return np.asarray(values or _zeros(count), dtype=float)

    return tuple(float(v) for v in full(first) + full(second) - full(base))


def superpose(
    baseline: LinearFlightModel, first: LinearFlightModel, second: LinearFlightModel
) -> LinearFlightModel:
    """Both changes from ``baseline`` at once: matrices and augmentations added."""
    inputs, outputs = len(baseline.input_names), len(baseline.output_names)
    return replace(
        first,
        a_matrix=first.a_matrix + second.a_matrix - baseline.a_matrix,
        b_matrix=first.b_matrix + second.b_matrix - baseline.b_matrix,
        c_matrix=None if baseline.c_matrix is None else first.c + second.c - baseline.c,
        d_matrix=None if baseline.d_matrix is None else first.d + second.d - baseline.d,
        delays_s=_add(first.delays_s, second.delays_s, baseline.delays_s, inputs),
        filters_s=_add(first.filters_s, second.filters_s, baseline.filters_s, inputs),
        output_biases=_add(
            first.output_biases, second.output_biases, baseline.output_biases, outputs
        ),
        output_drifts=_add(
            first.output_drifts, second.output_drifts, baseline.output_drifts, outputs
        ),
    )


def _filter_matrix(model: LinearFlightModel) -> np.ndarray:
    """B T, T = diag(filter time constants) (zero without filters)."""
    return model.b_matrix * np.asarray(model.filters_s or _zeros(len(model.input_names)))


@lru_cache(maxsize=64)
def _hold(
    a_bytes: bytes, b_bytes: bytes, shape: tuple[int, int], step_s: float, input_hold: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`numeric_hold` of A, B given as bytes: the candidates that change only the inputs or
    the outputs (delays, biases, drifts) re-use the baseline's discretisation."""
    a_matrix = np.frombuffer(a_bytes).reshape(shape[0], shape[0])
    b_matrix = np.frombuffer(b_bytes).reshape(shape)
    return numeric_hold(a_matrix, b_matrix, step_s, input_hold)


def simulate_runs(model: LinearFlightModel, runs: Sequence[FlightRun]) -> list[np.ndarray]:
    """Predicted measured outputs (N, outputs) of ``model`` on each run (module docstring).

    The runs of one sample time are propagated together, as the columns of one state recursion
    (shorter runs padded at their end; a padded sample never reaches an earlier one), so the
    recursion's Python steps are paid once per sample time, not once per run.
    """
    a_matrix = np.ascontiguousarray(model.a_matrix, dtype=float)
    driving = np.ascontiguousarray(
        model.b_matrix + model.a_matrix @ _filter_matrix(model), dtype=float
    )
    by_step: dict[float, list[int]] = {}
    for index, run in enumerate(runs):
        by_step.setdefault(round(run.time_step_s, 12), []).append(index)
    predicted: list[np.ndarray] = [np.empty(0)] * len(runs)
    for step_s, indices in by_step.items():
        hold = _hold(a_matrix.tobytes(), driving.tobytes(), driving.shape, step_s, model.input_hold)
        for index, outputs in zip(
            indices, _simulate_together(model, [runs[i] for i in indices], *hold), strict=True
        ):
            predicted[index] = outputs
    return predicted


def delayed_inputs(model: LinearFlightModel, run: FlightRun) -> np.ndarray:
    """The logged inputs (N, inputs) delayed by the model's delays (from the samples logged
    before the run where it has them, else held at its first)."""
    inputs = run.inputs
    if not any(model.delays_s):
        return inputs
    inputs = inputs.copy()
    before = run.inputs_before if run.inputs_before is not None else run.inputs[:0]
    times = np.concatenate([(np.arange(-len(before), 0)) * run.time_step_s, run.time_s])
    logged = np.concatenate([before, run.inputs])
    for index, delay in enumerate(model.delays_s):
        if delay != 0.0:
            inputs[:, index] = np.interp(run.time_s - delay, times, logged[:, index])
    return inputs


def _padded(arrays: Sequence[np.ndarray], longest: int) -> np.ndarray:
    """(longest, runs, ...) of per-run (N, ...) arrays, zero past each run's end."""
    stacked = np.zeros((longest, len(arrays), *arrays[0].shape[1:]))
    for column, array in enumerate(arrays):
        stacked[: len(array), column] = array
    return stacked


def _times(matrix: np.ndarray, stacked: np.ndarray) -> np.ndarray:
    """``matrix`` applied to the last axis of ``stacked`` (N, runs, k): one 2-D product."""
    flat = stacked.reshape(-1, stacked.shape[-1]) @ matrix.T
    return flat.reshape(*stacked.shape[:-1], len(matrix))


def _simulate_together(
    model: LinearFlightModel,
    runs: Sequence[FlightRun],
    ad: np.ndarray,
    bd: np.ndarray,
    bd_next: np.ndarray,
) -> list[np.ndarray]:
    """Predicted outputs of ``model`` on ``runs`` of one sample time, discretised as ``ad``,
    ``bd``, ``bd_next``: one recursion over the runs as columns (padded arrays: sample, run, ...).
    """
    filtered = _filter_matrix(model)
    lengths = [len(run.time_s) for run in runs]
    longest = max(lengths)
    logged = _padded([delayed_inputs(model, run) for run in runs], longest)
    following = next_inputs(logged)
    for column, length in enumerate(lengths):  # u[k+1] of a run's last sample is its own
        following[length - 1, column] = logged[length - 1, column]
    time_s = _padded([run.time_s for run in runs], longest)
    input_start_s = np.array([run.input_start_s for run in runs])
    output_count = len(model.output_names)
    biases = np.asarray(model.output_biases or _zeros(output_count))
    drifts = np.asarray(model.output_drifts or _zeros(output_count))
    offsets = biases + drifts * (time_s - 0.5 * input_start_s)[..., None]  # (N, runs, outputs)
    starts = np.array([run.initial_state for run in runs], dtype=float)  # (runs, states)
    for index, name in enumerate(model.output_names):
        if name in model.state_names:  # the measured start holds the sensor's offset
            starts[:, model.state_names.index(name)] -= offsets[0, :, index]
    starts -= logged[0] @ filtered.T
    forcing = _times(bd, logged) + _times(bd_next, following)  # (N, runs, states)
    states = propagate(ad, forcing.transpose(0, 2, 1), starts.T).transpose(0, 2, 1)
    states += _times(filtered, logged)
    acting = logged
    if any(model.filters_s):
        rates = _padded(
            [
                np.gradient(logged[:length, column], run.time_step_s, axis=0)
                for column, (run, length) in enumerate(zip(runs, lengths, strict=True))
            ],
            longest,
        )
        acting = logged + rates * np.asarray(model.filters_s)
    outputs = _times(model.c, states) + _times(model.d, acting) + offsets
    predicted = []
    for column, length in enumerate(lengths):
        run_outputs = outputs[:length, column]
        finite = np.all(np.isfinite(run_outputs))
        predicted.append(run_outputs if finite else np.full_like(run_outputs, 1e6))
    return predicted
