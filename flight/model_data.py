"""Binding a flight log to a model: the model's signals and data constants as arrays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.flight.model_file import SignalColumn, StateSpaceModelSpec
from ornitail.flight.sample_interval import refuse_huge_times, refuse_long_sample_interval
from ornitail.flight.sampling import uniform_grid


@dataclass(frozen=True)
class ModelData:
    """A log's samples in the model's signals (units after each column's scale and offset).

    ``states`` is None unless every state has a column; ``constants`` holds every constant of the
    model, the file's numbers and those taken from the data.
    """

    time_s: np.ndarray
    time_step_s: float
    inputs: np.ndarray  # (samples, inputs)
    outputs: np.ndarray  # (samples, outputs)
    states: np.ndarray | None  # (samples, states)
    constants: dict[str, float]

    @property
    def sample_count(self) -> int:
        return len(self.time_s)


def model_data(spec: StateSpaceModelSpec, data: pd.DataFrame, where: str = "data") -> ModelData:
    """The signals of ``spec`` from the log ``data`` (a DataFrame of numeric columns).

    Raises
    ------
    UserInputError
        Naming every missing column, a column with NaN, too few samples, or a time column
        that is not a uniform grid up to rounding and jitter (:mod:`sampling`; the row of a
        missing or doubled sample is named). The samples are treated as uniformly spaced at the
        grid's interval ``time_step_s`` (s).
    """
    needed = [spec.time_column]
    needed += [column.column for column in spec.columns.values() if column.column is not None]
    needed += [constant.column for constant in spec.data_constants]
    missing = sorted({name for name in needed if name not in data.columns})
    if missing:
        raise UserInputError(
            where, f"missing column(s) {', '.join(missing)} needed by model {spec.name!r}"
        )
    for name in dict.fromkeys(needed):
        values = pd.to_numeric(data[name], errors="coerce").to_numpy(dtype=float)
        if not np.all(np.isfinite(values)):
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            raise UserInputError(f"{where}: column {name}", f"non-finite value at row {bad + 1}")
    parameter_count = len(spec.free_parameter_names) + len(spec.states)
    if len(data) < max(10, 2 * parameter_count):
        raise UserInputError(where, f"only {len(data)} samples: too few to identify the model")
    time_s = data[spec.time_column].to_numpy(dtype=float) * spec.time_scale
    refuse_huge_times(time_s, f"{where}: column {spec.time_column}")
    with np.errstate(over="ignore", invalid="ignore"):  # huge times: refused below, not warned
        time_step_s = uniform_grid(time_s, f"{where}: column {spec.time_column}").step_s
    refuse_long_sample_interval(
        time_step_s,
        f"{where}: column {spec.time_column}",
        f"set [data].time_scale = 0.001 in the model file {spec.source}",
    )

    def signal(column: SignalColumn) -> np.ndarray:
        if column.constant is not None:
            return np.full(len(time_s), column.constant)
        values = column.scale * data[column.column].to_numpy(dtype=float) + column.offset
        if column.remove_start_mean_s is not None:
            window = max(1, int(round(column.remove_start_mean_s / time_step_s)))
            values = values - values[:window].mean()
        return values

    states = None
    if all(state in spec.columns for state in spec.states):
        states = np.column_stack([signal(spec.columns[state]) for state in spec.states])
    constants = dict(spec.constants)
    for constant in spec.data_constants:
        values = constant.scale * data[constant.column].to_numpy(dtype=float) + constant.offset
        statistic = {"mean": np.mean, "median": np.median, "first": lambda v: v[0]}
        constants[constant.name] = float(statistic[constant.statistic](values))
    return ModelData(
        time_s=time_s,
        time_step_s=time_step_s,
        inputs=np.column_stack([signal(spec.columns[name]) for name in spec.inputs]),
        outputs=np.column_stack([signal(spec.columns[name]) for name in spec.outputs]),
        states=states,
        constants=constants,
    )
