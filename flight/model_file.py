"""Linear state-space models declared in TOML files (format: docs/model-files.md).

A model file names the states, inputs and outputs, the parameters to estimate (start value, optional
bounds, optionally fixed), constants (numbers, or a statistic of a data column), the matrices A, B,
C, D as arithmetic expressions over parameter and constant names, the initial-state rule, and the
``[columns]`` table that maps every signal to a data column (with scale and offset) or a constant.
The model is continuous time: dx/dt = A x + B u, y = C x + D u, in the units the columns are scaled
to (SI for the shipped presets).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_toml_file
from ornitail.flight.expressions import FUNCTION_NAMES, Expression, parse_expression
from ornitail.flight.state_space import NumericStateSpace

PRESET_DIRECTORY = Path(__file__).resolve().parent / "models"
INITIAL_STATE_RULES = ("estimate", "data", "zero")
INPUT_HOLDS = ("first_order", "zero_order")
DATA_STATISTICS = ("mean", "median", "first")
MATRIX_NAMES = ("A", "B", "C", "D")
_NAME_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class ParameterSpec:
    """One model parameter: start value, bounds (-inf/inf when absent), whether it is fixed, its
    unit, and whether it is a nuisance parameter (estimated with the others, but a property of
    one record, such as a constant bias, not of the vehicle: never averaged across records).
    """

    name: str
    start: float
    lower: float = -math.inf
    upper: float = math.inf
    fixed: bool = False
    unit: str = ""
    nuisance: bool = False


@dataclass(frozen=True)
class DataConstant:
    """A constant taken from the data: ``statistic`` of (scale * column + offset)."""

    name: str
    column: str
    statistic: str = "mean"
    scale: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class SignalColumn:
    """Where a signal comes from: ``scale * data[column] + offset``, or a constant value.

    ``remove_start_mean_s``, when set, subtracts the mean of the signal's first that many seconds
    (the trim before a manoeuvre), turning absolute values into deviations from trim.
    """

    signal: str
    column: str | None = None
    scale: float = 1.0
    offset: float = 0.0
    constant: float | None = None
    remove_start_mean_s: float | None = None


@dataclass(frozen=True)
class StateSpaceModelSpec:
    """A grey-box linear model read from a model file (see docs/model-files.md)."""

    name: str
    source: str
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    parameters: tuple[ParameterSpec, ...]
    constants: Mapping[str, float]
    data_constants: tuple[DataConstant, ...]
    matrices: Mapping[str, tuple[tuple[Expression, ...], ...]]
    columns: Mapping[str, SignalColumn]
    time_column: str
    time_scale: float = 1.0
    initial_state: str = "estimate"
    input_hold: str = "first_order"
    description: str = ""

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(parameter.name for parameter in self.parameters)

    @property
    def free_parameter_names(self) -> tuple[str, ...]:
        return tuple(parameter.name for parameter in self.parameters if not parameter.fixed)

    @property
    def derivative_names(self) -> tuple[str, ...]:
        """Free parameters that describe the vehicle (not fixed, not nuisance), file order."""
        return tuple(
            parameter.name
            for parameter in self.parameters
            if not parameter.fixed and not parameter.nuisance
        )

    @property
    def constant_names(self) -> tuple[str, ...]:
        return tuple(self.constants) + tuple(constant.name for constant in self.data_constants)

    def start_values(self) -> dict[str, float]:
        """The file's start value of every parameter (fixed ones at their fixed value)."""
        return {parameter.name: parameter.start for parameter in self.parameters}

    def parameter(self, name: str) -> ParameterSpec:
        for parameter in self.parameters:
            if parameter.name == name:
                return parameter
        raise KeyError(name)

    def with_constants(self, values: Mapping[str, float]) -> StateSpaceModelSpec:
        """A copy with some constants replaced (e.g. the trim of another configuration)."""
        constants = dict(self.constants)
        data_constants = [item for item in self.data_constants if item.name not in values]
        for name, value in values.items():
            if name not in self.constant_names:
                raise UserInputError(f"{self.source}: [constants]", f"no constant named {name!r}")
            require_finite_value(f"{self.source}: [constants].{name}", value)
            constants[name] = float(value)
        return replace(self, constants=constants, data_constants=tuple(data_constants))

    def with_input_hold(self, input_hold: str) -> StateSpaceModelSpec:
        """A copy that holds the sampled inputs between samples as ``input_hold`` says:
        ``first_order`` (linear between samples, for measured continuous inputs) or
        ``zero_order`` (constant over each interval, for a held digital command).
        """
        return replace(self, input_hold=_checked_input_hold(input_hold, "input_hold"))

    def with_starts(self, values: Mapping[str, float]) -> StateSpaceModelSpec:
        """A copy with new start values for some parameters (fixed ones stay at their value)."""
        unknown = sorted(set(values) - set(self.parameter_names))
        if unknown:
            raise UserInputError("start", f"no parameter named {unknown[0]!r} in {self.name}")
        parameters = []
        for parameter in self.parameters:
            if parameter.name in values and not parameter.fixed:
                value = float(values[parameter.name])
                require_finite_value(f"start.{parameter.name}", value)
                value = min(max(value, parameter.lower), parameter.upper)
                parameter = replace(parameter, start=value)
            parameters.append(parameter)
        return replace(self, parameters=tuple(parameters))

    def state_space(
        self, parameter_values: Mapping[str, float], constant_values: Mapping[str, float]
    ) -> NumericStateSpace:
        """Numeric A, B, C, D for the given parameter and constant values (floats)."""
        values = {**constant_values, **parameter_values}
        missing = [
            name for name in (*self.parameter_names, *self.constant_names) if name not in values
        ]
        if missing:
            raise UserInputError(self.source, f"no value given for {missing[0]!r}")
        numeric = {}
        for matrix_name, rows in self.matrices.items():
            numeric[matrix_name] = np.array(
                [[_finite_entry(entry, values) for entry in row] for row in rows], dtype=float
            ).reshape(self.matrix_shape(matrix_name))
        return NumericStateSpace(
            a_matrix=numeric["A"],
            b_matrix=numeric["B"],
            c_matrix=numeric["C"],
            d_matrix=numeric["D"],
            state_names=self.states,
            input_names=self.inputs,
            output_names=self.outputs,
        )

    def matrix_shape(self, matrix_name: str) -> tuple[int, int]:
        rows = {"A": self.states, "B": self.states, "C": self.outputs, "D": self.outputs}
        columns = {"A": self.states, "B": self.inputs, "C": self.states, "D": self.inputs}
        return len(rows[matrix_name]), len(columns[matrix_name])


def _finite_entry(entry: Expression, values: Mapping[str, float]) -> float:
    """A matrix entry's value; a non-finite one is refused naming the entry and its names' values."""
    value = float(entry.evaluate(values))
    if not math.isfinite(value):
        used = ", ".join(f"{name} = {values[name]!r}" for name in sorted(entry.names))
        raise UserInputError(
            entry.where,
            f"{entry.text[:60]!r} is {value} (not a finite number)"
            + (f" with {used}" if used else ""),
        )
    return value


def require_finite_value(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise UserInputError(where, f"expected a number, got {value!r}")
    if not math.isfinite(float(value)):
        raise UserInputError(where, f"value {value!r} is not a finite number")
    return float(value)


def preset_names() -> tuple[str, ...]:
    return tuple(sorted(path.stem for path in PRESET_DIRECTORY.glob("*.toml")))


def load_model(path_or_preset_name: str | Path) -> StateSpaceModelSpec:
    """Read a model file, or a shipped preset by name (``delfly_longitudinal``,
    ``twin_otter_short_period``).

    Raises
    ------
    UserInputError
        Naming the file and field for any mistake in the file.
    """
    text = str(path_or_preset_name)
    if not text.strip():
        raise UserInputError("model", "empty model name; give a preset name or a model file")
    if text in preset_names():
        path = PRESET_DIRECTORY / f"{text}.toml"
    else:
        path = Path(text)
        if not path.exists():
            raise UserInputError(
                text,
                "model file not found (and not a preset name; presets: "
                f"{', '.join(preset_names())})",
            )
    return model_from_document(read_toml_file(path), str(path))


def model_from_document(document: Mapping[str, Any], source: str) -> StateSpaceModelSpec:
    """Build and check a model from a parsed TOML document; ``source`` names it in errors."""
    _reject_unknown_keys(
        document, ("model", "constants", "parameters", "matrices", "columns", "data"), source, ""
    )
    model_table = _table(document, "model", source, required=True)
    _reject_unknown_keys(
        model_table,
        ("name", "description", "states", "inputs", "outputs", "initial_state", "input_hold"),
        source,
        "[model]",
    )
    states = _name_list(model_table, "states", source)
    inputs = _name_list(model_table, "inputs", source)
    outputs = _name_list(model_table, "outputs", source)
    if set(states) & set(inputs):
        raise UserInputError(
            f"{source}: [model].inputs", f"{sorted(set(states) & set(inputs))[0]!r} is also a state"
        )
    if set(inputs) & set(outputs):
        raise UserInputError(
            f"{source}: [model].outputs",
            f"{sorted(set(inputs) & set(outputs))[0]!r} is also an input",
        )
    initial_state = model_table.get("initial_state", "estimate")
    if initial_state not in INITIAL_STATE_RULES:
        raise UserInputError(
            f"{source}: [model].initial_state",
            f"must be one of {', '.join(INITIAL_STATE_RULES)}, got {initial_state!r}",
        )

    input_hold = _checked_input_hold(
        model_table.get("input_hold", "first_order"), f"{source}: [model].input_hold"
    )

    constants, data_constants = _constants(_table(document, "constants", source), source)
    parameters = _parameters(_table(document, "parameters", source, required=True), source)
    known = set(constants) | {item.name for item in data_constants}
    clash = known & {parameter.name for parameter in parameters}
    if clash:
        raise UserInputError(
            f"{source}: [parameters].{sorted(clash)[0]}", "also defined as a constant"
        )
    known |= {parameter.name for parameter in parameters}

    shapes = {
        "A": (len(states), len(states)),
        "B": (len(states), len(inputs)),
        "C": (len(outputs), len(states)),
        "D": (len(outputs), len(inputs)),
    }
    matrices_table = _table(document, "matrices", source, required=True)
    _reject_unknown_keys(matrices_table, MATRIX_NAMES, source, "[matrices]")
    matrices = {
        name: _matrix(matrices_table.get(name), name, shapes[name], known, source)
        for name in MATRIX_NAMES
    }

    data_table = _table(document, "data", source, required=True)
    _reject_unknown_keys(data_table, ("time_column", "time_scale"), source, "[data]")
    time_column = data_table.get("time_column")
    if not isinstance(time_column, str) or not time_column:
        raise UserInputError(f"{source}: [data].time_column", "must name the data's time column")
    time_scale = require_finite_value(
        f"{source}: [data].time_scale", data_table.get("time_scale", 1.0)
    )
    if time_scale <= 0:
        raise UserInputError(f"{source}: [data].time_scale", "must be positive")

    columns = _columns(_table(document, "columns", source, required=True), source)
    for signal in (*inputs, *outputs):
        if signal not in columns:
            raise UserInputError(f"{source}: [columns]", f"no column given for signal {signal!r}")
    unknown_signals = set(columns) - set(states) - set(inputs) - set(outputs)
    if unknown_signals:
        raise UserInputError(
            f"{source}: [columns].{sorted(unknown_signals)[0]}",
            "not a state, input or output of the model",
        )
    for signal in (*states, *outputs):
        if signal in columns and columns[signal].constant is not None:
            raise UserInputError(f"{source}: [columns].{signal}", "only inputs may be constants")
    if initial_state == "data":
        for state in states:
            if state not in columns:
                raise UserInputError(
                    f"{source}: [columns]",
                    f"initial_state = 'data' needs a column for state {state!r}",
                )
    name = model_table.get("name", Path(source).stem)
    description = model_table.get("description", "")
    if not isinstance(name, str) or not isinstance(description, str):
        raise UserInputError(f"{source}: [model].name", "name and description must be strings")
    return StateSpaceModelSpec(
        name=name,
        source=source,
        states=states,
        inputs=inputs,
        outputs=outputs,
        parameters=parameters,
        constants=constants,
        data_constants=data_constants,
        matrices=matrices,
        columns=columns,
        time_column=time_column,
        time_scale=time_scale,
        initial_state=initial_state,
        input_hold=input_hold,
        description=description,
    )


def _checked_input_hold(value: Any, where: str) -> str:
    if value not in INPUT_HOLDS:
        raise UserInputError(where, f"must be one of {', '.join(INPUT_HOLDS)}, got {value!r}")
    return value


def _table(
    document: Mapping[str, Any], key: str, source: str, required: bool = False
) -> Mapping[str, Any]:
    if key not in document:
        if required:
            raise UserInputError(f"{source}: [{key}]", "table missing")
        return {}
    value = document[key]
    if not isinstance(value, dict):
        raise UserInputError(f"{source}: [{key}]", "must be a table")
    return value


def _reject_unknown_keys(
    table: Mapping[str, Any], allowed: Sequence[str], source: str, prefix: str
) -> None:
    for key in table:
        if key not in allowed:
            where = f"{source}: {prefix}.{key}" if prefix else f"{source}: [{key}]"
            raise UserInputError(where, f"unknown field (allowed: {', '.join(allowed)})")


def _check_name(name: Any, where: str) -> str:
    if not isinstance(name, str) or not _NAME_PATTERN.match(name):
        raise UserInputError(where, f"{name!r} is not a valid name (letter, then letters/digits/_)")
    if name in FUNCTION_NAMES:
        raise UserInputError(where, f"{name!r} is a function name and cannot name a quantity")
    return name


def _name_list(table: Mapping[str, Any], key: str, source: str) -> tuple[str, ...]:
    where = f"{source}: [model].{key}"
    values = table.get(key)
    if not isinstance(values, list) or not values:
        raise UserInputError(where, "must be a non-empty list of names")
    names = tuple(_check_name(value, where) for value in values)
    if len(set(names)) != len(names):
        raise UserInputError(where, "names must be unique")
    return names


def _constants(
    table: Mapping[str, Any], source: str
) -> tuple[dict[str, float], tuple[DataConstant, ...]]:
    constants: dict[str, float] = {}
    data_constants = []
    for name, value in table.items():
        where = f"{source}: [constants].{name}"
        _check_name(name, where)
        if isinstance(value, dict):
            _reject_unknown_keys(
                value, ("column", "statistic", "scale", "offset"), source, f"[constants].{name}"
            )
            column = value.get("column")
            if not isinstance(column, str) or not column:
                raise UserInputError(f"{where}.column", "must name a data column")
            statistic = value.get("statistic", "mean")
            if statistic not in DATA_STATISTICS:
                raise UserInputError(
                    f"{where}.statistic", f"must be one of {', '.join(DATA_STATISTICS)}"
                )
            data_constants.append(
                DataConstant(
                    name=name,
                    column=column,
                    statistic=statistic,
                    scale=require_finite_value(f"{where}.scale", value.get("scale", 1.0)),
                    offset=require_finite_value(f"{where}.offset", value.get("offset", 0.0)),
                )
            )
        else:
            constants[name] = require_finite_value(where, value)
    return constants, tuple(data_constants)


def _parameters(table: Mapping[str, Any], source: str) -> tuple[ParameterSpec, ...]:
    if not table:
        raise UserInputError(f"{source}: [parameters]", "the model has no parameters")
    parameters = []
    for name, value in table.items():
        where = f"{source}: [parameters].{name}"
        _check_name(name, where)
        if not isinstance(value, dict):
            value = {"start": value}
        _reject_unknown_keys(
            value,
            ("start", "lower", "upper", "fixed", "unit", "nuisance"),
            source,
            f"[parameters].{name}",
        )
        if "start" not in value:
            raise UserInputError(f"{where}.start", "start value missing")
        start = require_finite_value(f"{where}.start", value["start"])
        lower = -math.inf
        upper = math.inf
        if "lower" in value:
            lower = require_finite_value(f"{where}.lower", value["lower"])
        if "upper" in value:
            upper = require_finite_value(f"{where}.upper", value["upper"])
        if lower >= upper:
            raise UserInputError(
                f"{where}.lower", f"lower bound {lower:g} is not below upper {upper:g}"
            )
        if not lower <= start <= upper:
            raise UserInputError(
                f"{where}.start", f"start {start:g} lies outside the bounds [{lower:g}, {upper:g}]"
            )
        fixed = value.get("fixed", False)
        if not isinstance(fixed, bool):
            raise UserInputError(f"{where}.fixed", "must be true or false")
        unit = value.get("unit", "")
        if not isinstance(unit, str):
            raise UserInputError(f"{where}.unit", f"must be a string such as '1/s', got {unit!r}")
        nuisance = value.get("nuisance", False)
        if not isinstance(nuisance, bool):
            raise UserInputError(f"{where}.nuisance", "must be true or false")
        parameters.append(ParameterSpec(name, start, lower, upper, fixed, unit, nuisance))
    if all(parameter.fixed for parameter in parameters):
        raise UserInputError(f"{source}: [parameters]", "every parameter is fixed")
    if all(parameter.fixed or parameter.nuisance for parameter in parameters):
        raise UserInputError(
            f"{source}: [parameters]", "every free parameter is a nuisance parameter"
        )
    return tuple(parameters)


def _matrix(
    value: Any, name: str, shape: tuple[int, int], known: set[str], source: str
) -> tuple[tuple[Expression, ...], ...]:
    where = f"{source}: [matrices].{name}"
    rows, columns = shape
    if value is None:
        if name == "D":
            value = [[0] * columns for _ in range(rows)]
        else:
            raise UserInputError(where, "matrix missing")
    if value == "identity":
        if rows != columns:
            raise UserInputError(
                where, f"'identity' needs a square matrix, this one is {rows}x{columns}"
            )
        value = [[1 if row == column else 0 for column in range(columns)] for row in range(rows)]
    if value == "zero":
        value = [[0] * columns for _ in range(rows)]
    if not isinstance(value, list) or not all(isinstance(row, list) for row in value):
        raise UserInputError(where, "must be a list of rows (lists of numbers or expressions)")
    if len(value) != rows or any(len(row) != columns for row in value):
        found = f"{len(value)}x{max((len(row) for row in value), default=0)}"
        raise UserInputError(where, f"must be {rows}x{columns}, found {found}")
    result = []
    for row_index, row in enumerate(value):
        entries = []
        for column_index, entry in enumerate(row):
            entry_where = f"{where}[{row_index + 1}][{column_index + 1}]"
            expression = parse_expression(entry, entry_where)
            unknown = sorted(expression.names - known)
            if unknown:
                raise UserInputError(
                    entry_where,
                    f"unknown name {unknown[0]!r} in {expression.text!r} "
                    "(not a parameter or constant)",
                )
            entries.append(expression)
        result.append(tuple(entries))
    return tuple(result)


def _columns(table: Mapping[str, Any], source: str) -> dict[str, SignalColumn]:
    columns = {}
    for signal, value in table.items():
        where = f"{source}: [columns].{signal}"
        if isinstance(value, str):
            value = {"column": value}
        if not isinstance(value, dict):
            raise UserInputError(where, "must be a column name or a table")
        _reject_unknown_keys(
            value,
            ("column", "scale", "offset", "constant", "remove_start_mean_s"),
            source,
            f"[columns].{signal}",
        )
        if ("column" in value) == ("constant" in value):
            raise UserInputError(where, "give exactly one of column or constant")
        if "constant" in value:
            if set(value) != {"constant"}:
                raise UserInputError(
                    where, "a constant signal takes no scale, offset or mean removal"
                )
            columns[signal] = SignalColumn(
                signal, constant=require_finite_value(f"{where}.constant", value["constant"])
            )
            continue
        if not isinstance(value["column"], str) or not value["column"]:
            raise UserInputError(f"{where}.column", "must be a column name")
        scale = require_finite_value(f"{where}.scale", value.get("scale", 1.0))
        if scale == 0:
            raise UserInputError(f"{where}.scale", "must not be zero")
        remove = value.get("remove_start_mean_s")
        if remove is not None:
            remove = require_finite_value(f"{where}.remove_start_mean_s", remove)
            if remove <= 0:
                raise UserInputError(f"{where}.remove_start_mean_s", "must be positive (seconds)")
        columns[signal] = SignalColumn(
            signal,
            column=value["column"],
            scale=scale,
            offset=require_finite_value(f"{where}.offset", value.get("offset", 0.0)),
            remove_start_mean_s=remove,
        )
    return columns
