"""Printing a command's result: one JSON object with ``--json``, a readable table otherwise."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import click

from ornitail.core.output import to_jsonable


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
