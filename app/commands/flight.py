"""``ornitail flight``: identify a model file's parameters from a flight log; the study's campaign."""

from __future__ import annotations

from ornitail.app.cli import LazyCommand, LazyGroup

flight_group = LazyGroup(
    "flight",
    help="Free-flight system identification.",
    lazy_commands={
        "identify": LazyCommand(
            "ornitail.app.commands.flight_identify:identify_command",
            "Estimate the parameters of a linear model from one flight log.",
        ),
        "campaign": LazyCommand(
            "ornitail.app.commands.flight_campaign:campaign_command",
            "Cut manoeuvres, identify, validate and average: one representative model per configuration (the "
            "study's free-flight procedure).",
        ),
    },
)
"""Both commands (casadi, scipy, matplotlib) are imported on first use, so ``ornitail flight --help`` is quick."""
