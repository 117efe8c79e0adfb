"""``identify``: estimate a model file's parameters from one flight log."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.flight.equation_error import estimate_equation_error, smoothed_with_derivative
from ornitail.flight.identification_result import IdentificationResult
from ornitail.flight.model_data import model_data
from ornitail.flight.model_file import StateSpaceModelSpec
from ornitail.flight.output_error import OutputErrorOptions, estimate_output_error

METHODS = ("output_error", "equation_error")


def identify(
    model: StateSpaceModelSpec,
    data: pd.DataFrame,
    *,
    method: str = "output_error",
    start: Mapping[str, float] | None = None,
    options: OutputErrorOptions | None = None,
    where: str = "data",
) -> IdentificationResult:
    """Identify ``model`` (from :func:`~ornitail.flight.model_file.load_model`) from ``data``.

    Output error starts from ``start`` (parameter name -> value; others at the file's start
    values) when given; otherwise from the equation-error estimate when every state has a data
    column and that estimate is finite, else from the file's start values.

    Raises
    ------
    UserInputError
        For an unknown method or parameter name, missing or non-finite data columns.
    """
    if method not in METHODS:
        raise UserInputError("method", f"expected one of {', '.join(METHODS)}, got {method!r}")
    spec = model.with_starts(start) if start else model
    signals = model_data(spec, data, where)
    spec.state_space(spec.start_values(), signals.constants)  # refuses 1/0, overflow at the start
    if method == "equation_error":
        return estimate_equation_error(spec, signals)

    start_values = spec.start_values()
    if signals.states is not None:
        smoothed_states, _ = smoothed_with_derivative(signals.states, signals.time_step_s)
        initial_state = smoothed_states[0]
    else:
        initial_state = np.zeros(len(spec.states))
    if spec.initial_state == "zero":
        initial_state = np.zeros(len(spec.states))
    if not start and signals.states is not None:
        first_guess = estimate_equation_error(spec, signals)
        guess = first_guess.parameter_values()
        if all(math.isfinite(value) for value in guess.values()):
            start_values = {
                name: min(max(value, spec.parameter(name).lower), spec.parameter(name).upper)
                for name, value in guess.items()
            }
    return estimate_output_error(spec, signals, start_values, initial_state, options)
