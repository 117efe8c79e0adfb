"""Where trends come from, shared by ``design trends``, ``design propose``, ``design pareto`` and the demo.

The same four sources everywhere: the study's published tables (package data), representative-model tables of
``ornitail flight campaign``, derivative files of ``ornitail process`` and user CSVs (docs/design-trends.md).
"""

from __future__ import annotations

from typing import Any

import click

from ornitail.core.errors import UserInputError
from ornitail.design.trend_basis import BASES
from ornitail.design.trend_data import (
    TrendObservation,
    observations_from_campaign,
    observations_from_study_tables,
    observations_from_tunnel,
    observations_from_user_csv,
)
from ornitail.design.trends import TrendModel, fit_trends


def gather_observations(
    study: bool, campaigns: tuple[str, ...], tunnels: tuple[str, ...], user_csvs: tuple[str, ...]
) -> list[TrendObservation]:
    """Every observation of the chosen sources; at least one source must be chosen."""
    if not (study or campaigns or tunnels or user_csvs):
        raise UserInputError(
            "sources", "give at least one of --study, --campaign, --tunnel, --user-csv"
        )
    observations = observations_from_study_tables() if study else []
    for path in campaigns:
        observations += observations_from_campaign(path)
    for path in tunnels:
        observations += observations_from_tunnel(path)
    for path in user_csvs:
        observations += observations_from_user_csv(path)
    return observations


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


def trend_model_from_options(
    study: bool, campaigns: tuple, tunnels: tuple, user_csvs: tuple, basis: str
) -> TrendModel:
    """Fit the trends of the chosen sources; the study tables when none is chosen."""
    if not (study or campaigns or tunnels or user_csvs):
        study = True
    return fit_trends(gather_observations(study, campaigns, tunnels, user_csvs), basis=basis)
