"""Parsing comma-separated number lists given on the command line (``--volts 0.1,0.2,...``)."""

from __future__ import annotations

import math

import numpy as np

from ornitail.core.errors import UserInputError


def parse_comma_separated_numbers(text: str, expected_count: int, where: str) -> np.ndarray:
    """Return the ``expected_count`` finite numbers in ``text`` (``"1.0,2,-3e-2"``).

    Raises :class:`UserInputError` naming ``where`` for a wrong count, a non-number or NaN/inf.
    """
    items = [item.strip() for item in text.split(",")]
    if len(items) != expected_count:
        raise UserInputError(
            where, f"expected {expected_count} comma-separated numbers, got {len(items)}"
        )
    values = []
    for index, item in enumerate(items):
        try:
            value = float(item)
        except ValueError:
            raise UserInputError(where, f"item {index + 1} ({item!r}) is not a number") from None
        if not math.isfinite(value):
            raise UserInputError(where, f"item {index + 1} ({item!r}) is not a finite number")
        values.append(value)
    return np.array(values)
