"""CasADi functions of a model file's matrices: A, B, C, D as symbols of the parameters and constants, and the
compiled functions built from them, each built once per model structure.

:mod:`ornitail.flight.model_file` reads and checks model files and knows nothing of CasADi; this module turns a
checked :class:`StateSpaceModelSpec` into CasADi, and :mod:`ornitail.flight.discretisation` builds its exact
discretisations and their parameter derivatives here.
"""

from __future__ import annotations

from collections.abc import Callable

import casadi

from ornitail.flight.expressions import FUNCTION_NAMES
from ornitail.flight.model_file import MATRIX_NAMES, StateSpaceModelSpec

CASADI_FUNCTIONS = {name: getattr(casadi, name) for name in FUNCTION_NAMES}
"""The functions a model file's expressions may call, as CasADi's (for symbols)."""

_compiled: dict[tuple, casadi.Function] = {}
"""Compiled functions by (model structure, function name). Specs that differ only in start values, constants'
values or bounds (``with_starts``, ``with_constants``) share them: those enter as arguments, not as structure."""


def structure_key(spec: StateSpaceModelSpec) -> tuple:
    """What a compiled function depends on: names, order and the matrices' expressions (not values)."""
    return (
        spec.states,
        spec.inputs,
        spec.outputs,
        spec.parameter_names,
        spec.constant_names,
        tuple(
            (name, tuple(tuple(entry.text for entry in row) for row in spec.matrices[name]))
            for name in MATRIX_NAMES
        ),
    )


def compiled_function(
    spec: StateSpaceModelSpec, name: str, build: Callable[[], casadi.Function]
) -> casadi.Function:
    """The function ``name`` of this model structure: built by ``build`` the first time, then kept."""
    key = (structure_key(spec), name)
    if key not in _compiled:
        _compiled[key] = build()
    return _compiled[key]


def symbolic_matrices(
    spec: StateSpaceModelSpec, parameters: casadi.SX, constants: casadi.SX
) -> tuple[casadi.SX, casadi.SX, casadi.SX, casadi.SX]:
    """A, B, C, D as CasADi SX of ``parameters`` (all, in file order) and ``constants`` (in
    :attr:`~StateSpaceModelSpec.constant_names` order)."""
    values = {name: parameters[index] for index, name in enumerate(spec.parameter_names)}
    values.update({name: constants[index] for index, name in enumerate(spec.constant_names)})
    result = []
    for matrix_name in MATRIX_NAMES:
        rows, columns = spec.matrix_shape(matrix_name)
        matrix = casadi.SX.zeros(rows, columns)
        for row_index, row in enumerate(spec.matrices[matrix_name]):
            for column_index, entry in enumerate(row):
                matrix[row_index, column_index] = entry.evaluate(values, CASADI_FUNCTIONS)
        result.append(matrix)
    return tuple(result)


def matrices_function(spec: StateSpaceModelSpec) -> casadi.Function:
    """CasADi Function (parameters, constants) -> (A, B, C, D)."""

    def build() -> casadi.Function:
        parameters = casadi.SX.sym("p", len(spec.parameters))
        constants = casadi.SX.sym("c", len(spec.constant_names))
        return casadi.Function(
            "matrices",
            [parameters, constants],
            list(symbolic_matrices(spec, parameters, constants)),
        )

    return compiled_function(spec, "matrices", build)
