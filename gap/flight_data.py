"""Flight logs as the gap diagnosis sees them: runs at a reduced rate, and the split of runs.

Two ways to cut a log into runs:

- **manoeuvres**: a log with the campaign's columns (docs/flight-campaign.md, "Flight-log
  columns": ``elevator_cmd`` and ``rudder_cmd`` mark the inputs) is read with the flight package's
  reader and cut with its pre-processing (glitch removal, 5 Hz zero-phase low-pass, cutting at the
  commands); each manoeuvre's signals are deviations from its run-in. After the 5 Hz filter they
  are decimated to about 64 Hz, which keeps their content and makes every simulation cheap;
- **segments**: any other log (a record without the campaign's command columns, e.g. NASA's
  Twin Otter record) is read whole and cut into consecutive segments of ``segment_s`` seconds (the
  last one takes the remainder), each a run that starts from its own measured state.

With a simulator baseline the runs hold [q (rad/s), u, w, theta] (SI, body frame of
docs/frames.md) and the elevator (rad). With a model file the runs hold the model's outputs,
inputs and states read from the log's columns as the flight package reads them for identification
(:func:`ornitail.flight.model_data.model_data`: the file's ``[columns]`` table with its scales,
offsets and start-mean removal).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.flight.equation_error import smoothed_with_derivative
from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.manoeuvres import (
    ELEVATOR_COLUMN,
    REQUIRED_LOG_COLUMNS,
    STATE_COLUMNS,
    cut_manoeuvres,
)
from ornitail.flight.model_data import model_data
from ornitail.flight.model_file import StateSpaceModelSpec

SIMULATOR_CHANNELS = ("q", "u", "w", "theta")
SIMULATOR_UNITS = ("rad/s", "m/s", "m/s", "rad")
HISTORY_S = 0.5  # a segment carries this much of the inputs logged before it (s)
MODEL_UNIT = "model unit"  # a model file's signals are in whatever its [columns] scale them to
TARGET_RATE_HZ = 64.0
MINIMUM_PER_PART = 2
MINIMUM_RUNS = 3 * MINIMUM_PER_PART
MINIMUM_MANOEUVRES = MINIMUM_RUNS
OUTER_FOLDS = 4


@dataclass(frozen=True)
class FlightRun:
    """One run (a manoeuvre or a segment) at the reduced rate.

    ``outputs`` (N, outputs), ``inputs`` (N, inputs) and ``states`` (N, states) are the measured
    signals in the model's units (deviations from the run-in for manoeuvres); ``initial_state``
    the measured state the model starts from; ``time_s`` counts from the run's start;
    ``input_start_s`` is the input's onset (0 for a segment); ``excitation_index`` the input that
    excites the run (the first that is not a constant); ``theta0_rad`` and ``airspeed_m_s`` the
    run-in's steady state (NaN for a segment). ``inputs_before`` (M, inputs) holds the logged
    inputs of the M samples just before the run (the end of the previous segment, so that a
    delayed input is known at a segment's start; empty for a manoeuvre, whose run-in is steady).
    """

    label: str
    time_s: np.ndarray
    outputs: np.ndarray
    inputs: np.ndarray
    states: np.ndarray
    initial_state: np.ndarray
    input_start_s: float
    theta0_rad: float = math.nan
    airspeed_m_s: float = math.nan
    excitation_index: int = 0
    inputs_before: np.ndarray | None = None

    @property
    def time_step_s(self) -> float:
        return float(self.time_s[1] - self.time_s[0])

    @property
    def excitation(self) -> np.ndarray:
        return self.inputs[:, self.excitation_index]


MANOEUVRES_CUT = "manoeuvres"
""":attr:`FlightRecord.cut` of runs that each repeat one manoeuvre (not segments of one record)."""


@dataclass(frozen=True)
class FlightRecord:
    """The runs of a diagnosis and how they were cut.

    ``constants``: the model's constants with those taken from data (mean over the logs);
    ``absolute_outputs``: per output, True when its runs hold absolute values (a segment of a
    column without start-mean removal), so a constant sensor offset shows in them (in manoeuvre
    deviations it cancels); ``varying_inputs``: the inputs read from a column (not held constant);
    ``cut``: :data:`MANOEUVRES_CUT` or ``"segments of X s"``.
    """

    runs: list[FlightRun]
    constants: dict[str, float]
    absolute_outputs: tuple[bool, ...]
    varying_inputs: tuple[int, ...]
    cut: str


def output_units(names: Sequence[str]) -> tuple[str, ...]:
    """Units of output channels: SI for the simulator's four states, else :data:`MODEL_UNIT`."""
    if tuple(names) == SIMULATOR_CHANNELS:
        return SIMULATOR_UNITS
    return (MODEL_UNIT,) * len(names)


def _decimation(time_s: np.ndarray) -> int:
    rate = 1.0 / float(np.median(np.diff(time_s)))
    return max(1, int(round(rate / TARGET_RATE_HZ)))


def _require_count(runs: Sequence[FlightRun], paths: Sequence[str | Path]) -> None:
    if len(runs) < MINIMUM_MANOEUVRES:
        raise UserInputError(
            ", ".join(str(path) for path in paths),
            f"{len(runs)} run(s) found; the diagnosis needs at least {MINIMUM_MANOEUVRES} "
            "(some to fit candidate effects on, some to choose among them, some to test the choice)",
        )


def read_simulator_record(paths: Sequence[str | Path]) -> FlightRecord:
    """:func:`read_flight_runs` as a record: deviations of the four states, input the elevator."""
    return FlightRecord(read_flight_runs(paths), {}, (False,) * 4, (0,), MANOEUVRES_CUT)


def read_flight_runs(paths: Sequence[str | Path]) -> list[FlightRun]:
    """Every manoeuvre of every campaign log in ``paths`` as the simulator's four states and the
    elevator, decimated to about :data:`TARGET_RATE_HZ` (the simulator baseline's runs)."""
    runs: list[FlightRun] = []
    for path in paths:
        log = read_flight_log(path)
        for manoeuvre in cut_manoeuvres(log, str(path)):
            table = manoeuvre.deviations
            picked = slice(None, None, _decimation(table["time_s"].to_numpy(float)))
            states = table[list(STATE_COLUMNS)].to_numpy(float)[picked]
            runs.append(
                FlightRun(
                    label=manoeuvre.label,
                    time_s=table["time_s"].to_numpy(float)[picked],
                    outputs=states,
                    inputs=table[[ELEVATOR_COLUMN]].to_numpy(float)[picked],
                    states=states,
                    initial_state=states[0].copy(),
                    input_start_s=manoeuvre.input_start_s,
                    theta0_rad=manoeuvre.steady_state.theta_rad,
                    airspeed_m_s=manoeuvre.steady_state.airspeed_m_s,
                )
            )
    _require_count(runs, paths)
    return runs


def _model_run(
    model: StateSpaceModelSpec,
    table: pd.DataFrame,
    where: str,
    label: str,
    input_start_s: float = 0.0,
    **steady: float,
) -> FlightRun:
    """One run of ``model``'s signals from the log rows ``table`` (time from the first row, s);
    ``steady``: the run-in's ``theta0_rad`` and ``airspeed_m_s`` when it has one."""
    signals = model_data(model, table, where)
    if signals.states is None:
        missing = [state for state in model.states if state not in model.columns]
        raise UserInputError(
            f"{model.source}: [columns]",
            f"state {missing[0]!r} has no data column; the diagnosis starts every run from the "
            "measured state",
        )
    initial = signals.states[0].copy()
    if model.initial_state == "data":  # as the flight package: the smoothed measured start
        initial = smoothed_with_derivative(signals.states, signals.time_step_s)[0][0]
    varying = [i for i, name in enumerate(model.inputs) if model.columns[name].constant is None]
    return FlightRun(
        label=label,
        time_s=signals.time_s - signals.time_s[0],
        outputs=signals.outputs,
        inputs=signals.inputs,
        states=signals.states,
        initial_state=initial,
        input_start_s=input_start_s,
        excitation_index=varying[0] if varying else 0,
        **steady,
    )


def read_model_runs(
    paths: Sequence[str | Path], model: StateSpaceModelSpec, segment_s: float | None
) -> FlightRecord:
    """The runs of ``model`` in the logs ``paths``: the campaign's manoeuvres when a log has its
    columns and no ``segment_s`` is given, else consecutive segments of ``segment_s`` (s)."""
    runs: list[FlightRun] = []
    constants: list[dict[str, float]] = []
    for path in paths:
        log = read_flight_log(path)
        where = str(path)
        whole = model_data(model, log, where)
        constants.append(whole.constants)
        if segment_s is None:
            missing = [column for column in REQUIRED_LOG_COLUMNS if column not in log.columns]
            if missing:
                raise UserInputError(
                    where,
                    f"lacks the campaign's column(s) {', '.join(missing)} to cut manoeuvres by "
                    "(docs/flight-campaign.md); set [baseline].segment_s to cut the record into "
                    "segments of that many seconds",
                )
            for manoeuvre in cut_manoeuvres(log, where):
                table = manoeuvre.deviations
                rows = table.iloc[:: _decimation(table["time_s"].to_numpy(float))]
                steady = manoeuvre.steady_state
                runs.append(
                    _model_run(
                        model,
                        rows.reset_index(drop=True),
                        f"{where}: {manoeuvre.label}",
                        manoeuvre.label,
                        manoeuvre.input_start_s,
                        theta0_rad=steady.theta_rad,
                        airspeed_m_s=steady.airspeed_m_s,
                    )
                )
            continue
        length = int(round(segment_s / whole.time_step_s))
        count = len(log) // max(length, 1)
        if count < 1 or length < 10:
            raise UserInputError(
                where,
                f"segment_s = {segment_s:g} s gives segments of {length} samples in a log of "
                f"{len(log)}; each segment needs at least 10 samples",
            )
        history = int(round(HISTORY_S / whole.time_step_s))
        for index in range(count):
            first = index * length
            stop = len(log) if index == count - 1 else first + length
            rows = log.iloc[first:stop].reset_index(drop=True)
            run = _model_run(model, rows, f"{where}: segment {index + 1}", f"{where}#{index + 1}")
            # the whole log's inputs differ from the segment's by a constant where a column removes
            # its start mean: shift the samples before the segment onto the segment's own level
            offset = whole.inputs[first] - run.inputs[0]
            before = whole.inputs[max(0, first - history) : first] - offset
            runs.append(dataclasses.replace(run, inputs_before=before))
    _require_count(runs, paths)
    merged = {name: float(np.mean([c[name] for c in constants])) for name in constants[0]}
    absolute = tuple(
        segment_s is not None
        and model.columns[name].column is not None
        and model.columns[name].remove_start_mean_s is None
        for name in model.outputs
    )
    varying = tuple(
        i for i, name in enumerate(model.inputs) if model.columns[name].constant is None
    )
    cut = MANOEUVRES_CUT if segment_s is None else f"segments of {segment_s:g} s"
    return FlightRecord(runs, merged, absolute, varying, cut)


@dataclass(frozen=True)
class RunSplit:
    """Indices of the three disjoint parts of a set of runs (manoeuvres, set points, rows).

    ``training``: candidates (and the detection rule's null directions) are fitted on them;
    ``validation``: candidates are ranked, the indistinguishable set and the verdict are decided on
    them; ``test``: how far the gap shrinks is reported on them only.
    """

    training: np.ndarray
    validation: np.ndarray
    test: np.ndarray
    method: str


def nested_splits(count: int, seed: int, where: str = "data") -> list[RunSplit]:
    """Seeded nested splits of ``count`` runs: the runs are cut at random into ``min(``
    :data:`OUTER_FOLDS` ``, count // ``:data:`MINIMUM_PER_PART```)`` groups; fold k tests group k,
    validates on group k + 1 (cyclically) and trains on the others, so every run is a test run
    exactly once and a validation run exactly once, never both in one fold (with 4 groups the
    50/25/25 split: 10/5/5 training/validation/test with 20 runs). The validation runs pooled over
    the folds are then every run once, not a few runs counted several times. Fewer than
    :data:`MINIMUM_RUNS` runs stop with a one-line error naming ``where``."""
    if count < MINIMUM_RUNS:
        raise UserInputError(
            where,
            f"{count} runs; the diagnosis needs at least {MINIMUM_RUNS} ({MINIMUM_PER_PART} each to "
            "fit candidates on, to choose among them and to test the choice)",
        )
    order = np.random.default_rng(seed).permutation(count)
    folds = min(OUTER_FOLDS, count // MINIMUM_PER_PART)
    groups = np.array_split(order, folds)
    splits = []
    for index, test in enumerate(groups):
        validation = groups[(index + 1) % folds]
        training = np.concatenate(
            [
                group
                for other, group in enumerate(groups)
                if other not in (index, (index + 1) % folds)
            ]
        )
        splits.append(
            RunSplit(
                training=np.sort(training),
                validation=np.sort(validation),
                test=np.sort(test),
                method=f"fold {index + 1} of {folds}: {len(training)}/{len(validation)}/{len(test)} "
                f"(training/validation/test, seed {seed})",
            )
        )
    return splits


def nested_split_counts(splits: list[RunSplit], count: int) -> dict[str, object]:
    """The report's ``split`` field for :func:`nested_splits` of ``count`` runs: the first fold's
    training and validation counts (they rank, detect and give the verdict), ``test`` = every run
    (each tested once, in its own fold), ``folds`` and the ``method``."""
    first = splits[0]
    return {
        "training": len(first.training),
        "validation": len(first.validation),
        "test": count,
        "folds": len(splits),
        "method": f"nested: {count} runs in {len(splits)} seeded test folds; each run is a test run "
        "once, scored with the effect chosen on validation runs and fitted on training runs of its "
        f"fold without it; ranking, detection rule and verdict from fold 1 "
        f"({len(first.training)}/{len(first.validation)}/{len(first.test)} training/validation/test)",
    }
