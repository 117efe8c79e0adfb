"""Printing results: one JSON object with ``--json``, a readable table otherwise."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any

import click
import numpy as np


def to_jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(key): to_jsonable(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(item) for item in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, np.generic):
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
