"""Where trends come from, shared by ``design trends``, ``design propose``, ``design pareto``, the demo and the
window.

The same four sources everywhere: the study's published tables (package data), representative-model tables of
``ornitail flight campaign``, derivative files of ``ornitail process`` and user CSVs (docs/design-trends.md).
"""

from __future__ import annotations

from ornitail.core.errors import UserInputError
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
            "trend sources",
            "none chosen: give the study's tables, a campaign table, a tunnel derivatives file or a user CSV",
        )
    observations = observations_from_study_tables() if study else []
    for path in campaigns:
        observations += observations_from_campaign(path)
    for path in tunnels:
        observations += observations_from_tunnel(path)
    for path in user_csvs:
        observations += observations_from_user_csv(path)
    return observations


def trend_model_from_sources(
    study: bool, campaigns: tuple, tunnels: tuple, user_csvs: tuple, basis: str
) -> TrendModel:
    """Fit the trends of the chosen sources; the study tables when none is chosen."""
    if not (study or campaigns or tunnels or user_csvs):
        study = True
    return fit_trends(gather_observations(study, campaigns, tunnels, user_csvs), basis=basis)
