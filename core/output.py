"""Printing results: one JSON object with ``--json``, a readable table otherwise."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from typing import Any

import click


def to_jsonable(value: Any) -> Any:
    """``value`` with numpy arrays and scalars made plain and NaN or infinity made ``None`` (strict JSON)."""
    if isinstance(value, dict):
        return {str(key): to_jsonable(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(item) for item in value]
    # numpy is not imported here (`ornitail --help` needs none): before it is imported, no value is numpy's.
    numpy = sys.modules.get("numpy")
    if numpy is not None and isinstance(value, numpy.ndarray):
        return to_jsonable(value.tolist())
    if numpy is not None and isinstance(value, numpy.generic):
        return to_jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def emit(
    result: dict[str, Any], as_json: bool, render_text: Callable[[dict[str, Any]], str]
) -> None:
    """Print ``result`` as exactly one JSON object (``as_json``) or as the text ``render_text`` makes."""
    if as_json:
        click.echo(json.dumps(to_jsonable(result)))
    else:
        click.echo(render_text(result))


def json_option(function: Callable) -> Callable:
    """Add the ``--json`` flag every number-printing command carries."""
    return click.option(
        "--json", "as_json", is_flag=True, help="Print exactly one JSON object on stdout."
    )(function)
