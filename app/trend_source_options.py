"""The trend-source options of ``ornitail design propose`` and ``design pareto`` (design/trend_sources.py)."""

from __future__ import annotations

from typing import Any

import click

from ornitail.design.trend_basis import BASES


def trend_source_options(function: Any) -> Any:
    """The trend-source options shared by ``propose`` and ``pareto``."""
    for option in reversed(
        [
            click.option(
                "--study",
                is_flag=True,
                help="The study's published tables (package data; propose and pareto use them by default).",
            ),
            click.option(
                "--campaign",
                "campaigns",
                multiple=True,
                type=click.Path(),
                help="representative_models.csv/json of `ornitail flight campaign`.",
            ),
            click.option(
                "--tunnel",
                "tunnels",
                multiple=True,
                type=click.Path(),
                help="Derivatives CSV/JSON of `ornitail process`.",
            ),
            click.option(
                "--user-csv",
                "user_csvs",
                multiple=True,
                type=click.Path(),
                help="A user CSV of observations (docs/design-trends.md).",
            ),
            click.option(
                "--basis",
                type=click.Choice(sorted(BASES)),
                default="linear",
                show_default=True,
                help="Trend basis.",
            ),
        ]
    ):
        function = option(function)
    return function
