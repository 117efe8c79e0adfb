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
from ornitail.core.toml_table import REQUIRED, TomlTable, is_finite_number
from ornitail.flight.expressions import FUNCTION_NAMES, Expression, parse_expression
from ornitail.flight.state_space import NumericStateSpace

PRESET_DIRECTORY = Path(__file__).resolve().parent / "models"
INITIAL_STATE_RULES = ("estimate", "data", "zero")
INPUT_HOLDS = ("first_order", "zero_order")
DATA_STATISTICS = ("mean", "median", "first")
MATRIX_NAMES = ("A", "B", "C", "D")
_NAME_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_TOP_LEVEL_KEYS = ("model", "constants", "parameters", "matrices", "columns", "data")
_MODEL_KEYS = ("name", "description", "states", "inputs", "outputs", "initial_state", "input_hold")
_DATA_CONSTANT_KEYS = ("column", "statistic", "scale", "offset")
_PARAMETER_KEYS = ("start", "lower", "upper", "fixed", "unit", "nuisance")
_COLUMN_KEYS = ("column", "scale", "offset", "constant", "remove_start_mean_s")


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
    """``value`` as a float; anything but a finite number is refused naming ``where``."""
    if not is_finite_number(value):
        raise UserInputError(where, f"{value!r} must be a finite number")
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
    top = TomlTable(source, "", document, _TOP_LEVEL_KEYS)
    model_table = top.sub_table("model", _MODEL_KEYS)
    states = _names(model_table, "states")
    inputs = _names(model_table, "inputs")
    outputs = _names(model_table, "outputs")
    if set(states) & set(inputs):
        both = sorted(set(states) & set(inputs))[0]
        raise UserInputError(model_table.where("inputs"), f"{both!r} is also a state")
    if set(inputs) & set(outputs):
        both = sorted(set(inputs) & set(outputs))[0]
        raise UserInputError(model_table.where("outputs"), f"{both!r} is also an input")
    initial_state = model_table.text("initial_state", "estimate", choices=INITIAL_STATE_RULES)
    input_hold = model_table.text("input_hold", "first_order", choices=INPUT_HOLDS)
    name = model_table.text("name", Path(source).stem)
    description = model_table.text("description", "", empty=True)

    constants, data_constants = _constants(top.sub_table("constants", None, {}))
    parameters_table = top.sub_table("parameters", None)
    parameters = _parameters(parameters_table)
    known = set(constants) | {item.name for item in data_constants}
    for parameter in parameters:
        if parameter.name in known:
            raise UserInputError(
                parameters_table.where(parameter.name),
                f"{parameter.name!r} is also defined as a constant",
            )
    known |= {parameter.name for parameter in parameters}

    shapes = {
        "A": (len(states), len(states)),
        "B": (len(states), len(inputs)),
        "C": (len(outputs), len(states)),
        "D": (len(outputs), len(inputs)),
    }
    matrices_table = top.sub_table("matrices", MATRIX_NAMES)
    matrices = {
        matrix: _matrix(matrices_table, matrix, shapes[matrix], known) for matrix in MATRIX_NAMES
    }

    data_table = top.sub_table("data", ("time_column", "time_scale"))
    time_column = data_table.text("time_column")
    time_scale = data_table.number("time_scale", 1.0, positive=True)

    columns_table = top.sub_table("columns", (*states, *inputs, *outputs))
    columns = _columns(columns_table, states, inputs, outputs)
    if initial_state == "data":
        for state in states:
            if state not in columns:
                raise UserInputError(
                    columns_table.where(state),
                    "required key is missing (initial_state = 'data' needs a column for every state)",
                )
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
    """``value`` if it is one of ``INPUT_HOLDS`` (``with_input_hold``'s check)."""
    if value not in INPUT_HOLDS:
        raise UserInputError(where, f"{value!r} must be one of {', '.join(INPUT_HOLDS)}")
    return value


def _check_name(name: Any, where: str) -> str:
    if not isinstance(name, str) or not _NAME_PATTERN.match(name):
        raise UserInputError(where, f"{name!r} is not a valid name (letter, then letters/digits/_)")
    if name in FUNCTION_NAMES:
        raise UserInputError(where, f"{name!r} is a function name and cannot name a quantity")
    return name


def _names(table: TomlTable, key: str) -> tuple[str, ...]:
    """A non-empty list of unique valid names (``[model].states``, ``inputs``, ``outputs``)."""
    names = tuple(_check_name(name, table.where(key)) for name in table.texts(key, at_least=1))
    repeated = [name for index, name in enumerate(names) if name in names[:index]]
    if repeated:
        raise UserInputError(
            table.where(key), f"{list(names)!r} must be unique names ({repeated[0]!r} repeats)"
        )
    return names


def _constants(table: TomlTable) -> tuple[dict[str, float], tuple[DataConstant, ...]]:
    """``[constants]``: numbers, and tables that take a statistic of a data column."""
    constants: dict[str, float] = {}
    data_constants = []
    for name in table.table:
        _check_name(name, table.where(name))
        if not isinstance(table.get(name), dict):
            constants[name] = table.number(name)
            continue
        entry = table.sub_table(name, _DATA_CONSTANT_KEYS)
        data_constants.append(
            DataConstant(
                name=name,
                column=entry.text("column"),
                statistic=entry.text("statistic", "mean", choices=DATA_STATISTICS),
                scale=entry.number("scale", 1.0),
                offset=entry.number("offset", 0.0),
            )
        )
    return constants, tuple(data_constants)


def _parameters(table: TomlTable) -> tuple[ParameterSpec, ...]:
    """``[parameters]``: a start value, or a table of start, bounds, fixed, unit and nuisance."""
    if not table.table:
        raise UserInputError(table.where(), "the model has no parameters")
    parameters = [_parameter(table, name) for name in table.table]
    if all(parameter.fixed for parameter in parameters):
        raise UserInputError(table.where(), "every parameter is fixed")
    if all(parameter.fixed or parameter.nuisance for parameter in parameters):
        raise UserInputError(table.where(), "every free parameter is a nuisance parameter")
    return tuple(parameters)


def _parameter(table: TomlTable, name: str) -> ParameterSpec:
    """One parameter: a bare start value, or its table (section ``parameters.<name>``)."""
    _check_name(name, table.where(name))
    if not isinstance(table.get(name), dict):
        return ParameterSpec(name, table.number(name))
    entry = table.sub_table(name, _PARAMETER_KEYS)
    start = entry.number("start")
    lower = entry.number("lower", None)
    upper = entry.number("upper", None)
    lower = -math.inf if lower is None else lower
    upper = math.inf if upper is None else upper
    if lower >= upper:
        raise UserInputError(entry.where("lower"), f"lower {lower:g} must be below upper {upper:g}")
    if not lower <= start <= upper:
        raise UserInputError(
            entry.where("start"), f"{start:g} must lie within the bounds [{lower:g}, {upper:g}]"
        )
    return ParameterSpec(
        name,
        start,
        lower,
        upper,
        fixed=entry.boolean("fixed", False),
        unit=entry.text("unit", "", empty=True),
        nuisance=entry.boolean("nuisance", False),
    )


def _matrix(
    table: TomlTable, name: str, shape: tuple[int, int], known: set[str]
) -> tuple[tuple[Expression, ...], ...]:
    """One matrix: rows of numbers or expressions over ``known`` names, ``"identity"`` or
    ``"zero"``; D is zero when absent."""
    where = table.where(name)
    rows, columns = shape
    value = table.get(name, "zero" if name == "D" else REQUIRED)
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


def _columns(
    table: TomlTable,
    states: Sequence[str],
    inputs: Sequence[str],
    outputs: Sequence[str],
) -> dict[str, SignalColumn]:
    """``[columns]``: every input and output (and optionally a state) from a column or a constant."""
    for signal in (*inputs, *outputs):
        if signal not in table.table:
            raise UserInputError(
                table.where(signal), "required key is missing (every input and output needs one)"
            )
    columns = {signal: _column(table, signal) for signal in table.table}
    for signal in (*states, *outputs):
        if signal in columns and columns[signal].constant is not None:
            raise UserInputError(
                table.where(signal), f"{signal!r} is not an input: only an input may be a constant"
            )
    return columns


def _column(table: TomlTable, signal: str) -> SignalColumn:
    """One signal: a bare column name, or its table (section ``columns.<signal>``)."""
    value = table.get(signal)
    if isinstance(value, str):
        return SignalColumn(signal, column=table.text(signal))
    if not isinstance(value, dict):
        raise UserInputError(table.where(signal), f"{value!r} must be a column name or a table")
    entry = table.sub_table(signal, _COLUMN_KEYS)
    if ("column" in value) == ("constant" in value):
        raise UserInputError(entry.where(), "must have exactly one of the keys column and constant")
    if "constant" in value:
        extra = sorted(set(value) - {"constant"})
        if extra:
            raise UserInputError(
                entry.where(extra[0]), "a constant signal takes no scale, offset or mean removal"
            )
        return SignalColumn(signal, constant=entry.number("constant"))
    scale = entry.number("scale", 1.0)
    if scale == 0:
        raise UserInputError(
            entry.where("scale"), "0 must be nonzero (a zero scale loses the signal)"
        )
    return SignalColumn(
        signal,
        column=entry.text("column"),
        scale=scale,
        offset=entry.number("offset", 0.0),
        remove_start_mean_s=entry.number("remove_start_mean_s", None, positive=True),
    )
