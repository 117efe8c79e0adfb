"""``ornitail flight campaign``: representative models of one or many configurations.

Input: a campaign file (``--campaign``), flight logs labelled by configuration
(``--log S3@98=flight.csv``, repeatable) or simulated flights (``--simulate S3@98``,
repeatable). ``--selection-rule``, ``--glitch-rule``, ``--input-hold`` and ``--colored-sigma``
override the campaign file's rules (defaults: the study's rules, the model's own input hold,
:data:`DEFAULT_CAMPAIGN_COLORED_SIGMA`); ``--model`` the model (default
:data:`DEFAULT_CAMPAIGN_MODEL`). Output:
``representative_models.csv`` / ``.json`` and the pictures (PNG and PDF) in ``--out``; progress on
stderr (``ornitail.app.progress``: a bar in a terminal, timestamped lines in a log); with ``--json`` exactly one
JSON object on stdout.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.app.progress import Progress
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import check_input_file, prepare_output_directory
from ornitail.flight.campaign import run_campaign
from ornitail.flight.campaign_file import (
    DEFAULT_CAMPAIGN_COLORED_SIGMA,
    DEFAULT_CAMPAIGN_MODEL,
    DEFAULT_SEED,
    DEFAULT_SIMULATED_MANOEUVRES,
    MAX_SEED,
    MAX_SIMULATED_MANOEUVRES,
    CampaignSpec,
    ConfigurationSpec,
    LogSource,
    configuration_from_label,
    read_campaign_file,
)
from ornitail.flight.campaign_plots import write_campaign_pictures
from ornitail.flight.campaign_table import write_campaign_table
from ornitail.flight.manoeuvres import DEFAULT_GLITCH_RULE, GLITCH_RULES
from ornitail.flight.model_file import INPUT_HOLDS, load_model
from ornitail.flight.residual_statistics import COLORED_SIGMA_METHODS
from ornitail.flight.validation import DEFAULT_SELECTION_RULE, SELECTION_RULES

PROGRESS_STEPS_PER_CONFIGURATION = 100


def _labelled_values(pairs: tuple[str, ...], option: str) -> list[tuple[str, str]]:
    """``LABEL=VALUE`` option values as (label, value) pairs."""
    result = []
    for pair in pairs:
        label, separator, value = pair.partition("=")
        if not separator or not label or not value:
            raise UserInputError(option, f"{pair!r} is not LABEL=VALUE (e.g. S3@98=flight.csv)")
        result.append((label.strip(), value.strip()))
    return result


def _per_label_number(values: tuple[str, ...], option: str) -> dict[str | None, float]:
    """``--mass-kg 0.0235`` (all configurations) or ``--mass-kg S3@98=0.0235`` (one)."""
    numbers: dict[str | None, float] = {}
    for text in values:
        label, separator, value = text.rpartition("=")
        try:
            number = float(value)
        except ValueError:
            raise UserInputError(option, f"{value!r} is not a number") from None
        if not (math.isfinite(number) and number > 0):
            raise UserInputError(option, f"{value!r} must be a positive finite number")
        numbers[label.strip() if separator else None] = number
    return numbers


def _campaign_from_options(
    campaign_path: Path | None,
    logs: tuple[str, ...],
    simulate: tuple[str, ...],
    manoeuvres: int,
    seed: int | None,
    model: str | None,
    masses: tuple[str, ...],
    inertias: tuple[str, ...],
    rules: dict[str, str | None],
) -> CampaignSpec:
    """The campaign the options describe; ``rules`` (selection_rule, glitch_rule, input_hold,
    colored_sigma) given on the command line override the campaign file's.
    """
    overrides = {key: value for key, value in rules.items() if value is not None}
    sources = sum(bool(item) for item in (campaign_path, logs, simulate))
    if sources != 1:
        raise UserInputError(
            "flight campaign", "give exactly one of --campaign, --log or --simulate"
        )
    if campaign_path is not None:
        campaign = read_campaign_file(campaign_path)
        return replace(
            campaign,
            seed=campaign.seed if seed is None else seed,
            model=model or campaign.model,
            **overrides,
        )
    mass_by_label = _per_label_number(masses, "--mass-kg")
    inertia_by_label = _per_label_number(inertias, "--iyy-kg-m2")
    configurations: dict[str, ConfigurationSpec] = {}
    if simulate:
        if manoeuvres < 3:
            raise UserInputError("--manoeuvres", f"{manoeuvres} is fewer than 3")
        if manoeuvres > MAX_SIMULATED_MANOEUVRES:
            raise UserInputError(
                "--manoeuvres", f"{manoeuvres} is more than {MAX_SIMULATED_MANOEUVRES}"
            )
        for label in simulate:
            spec = configuration_from_label(label, "--simulate", simulated_manoeuvres=manoeuvres)
            if spec.label in configurations:
                raise UserInputError("--simulate", f"{label} is listed twice")
            configurations[spec.label] = spec
    else:
        grouped: dict[str, list[LogSource]] = {}
        for label, path in _labelled_values(logs, "--log"):
            grouped.setdefault(label, []).append(LogSource(Path(path)))
        for label, sources_of_label in grouped.items():
            spec = configuration_from_label(
                label,
                "--log",
                logs=tuple(sources_of_label),
                mass_kg=mass_by_label.get(label, mass_by_label.get(None)),
                iyy_kg_m2=inertia_by_label.get(label, inertia_by_label.get(None)),
            )
            configurations[spec.label] = spec
    return CampaignSpec(
        tuple(configurations.values()),
        DEFAULT_SEED if seed is None else seed,
        model or DEFAULT_CAMPAIGN_MODEL,
        **overrides,
    )


def _check_inputs(campaign: CampaignSpec) -> None:
    """Refuse a model that does not load and log files that cannot be read, before any work."""
    load_model(campaign.model)
    for configuration in campaign.configurations:
        for source in configuration.logs:
            if not source.path.exists():
                raise UserInputError(str(source.path), "flight log not found")
            check_input_file(source.path)


def _render(result: dict[str, Any]) -> str:
    header = (
        f"{'configuration':14s}{'model':>15s}{'theta0 deg':>11s}{'V m/s':>7s}{'f Hz':>7s}"
        f"{'zeta':>8s}{'wn rad/s':>9s}{'Mq':>11s}{'rejected':>9s}"
    )
    hold = result["input_hold"] or "the model's own"
    lines = [
        f"selection rule {result['selection_rule']}, glitch rule {result['glitch_rule']}, "
        f"input hold {hold}",
        header,
    ]
    for row in result["configurations"]:
        mq = row["derivatives"].get("Mq", {}).get("value", float("nan"))
        lines.append(
            f"{row['configuration']:14s}{row['representative_model']:>15s}"
            f"{row['theta0_deg']:>11.2f}{row['airspeed_m_s']:>7.3f}"
            f"{row['flapping_frequency_hz']:>7.2f}{row['damping_ratio']:>8.3f}"
            f"{row['natural_frequency_rad_s']:>9.3f}{mq:>11.3e}"
            f"{row['rejected']:>5d}/{row['manoeuvres']}"
        )
    lines.append("")
    lines += [f"wrote {path}" for path in result["written"]]
    return "\n".join(lines)


@click.command("campaign")
@click.option(
    "--campaign",
    "campaign_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Campaign TOML file listing configurations and their logs (docs/flight-campaign.md).",
)
@click.option(
    "--log",
    "logs",
    multiple=True,
    metavar="TAIL@X_H_MM=PATH",
    help="A flight log (CSV, Parquet, .mat) of a study tail at x_h (mm); repeat for more.",
)
@click.option(
    "--simulate",
    multiple=True,
    metavar="TAIL@X_H_MM",
    help="Fly a configuration in the simulator instead of reading logs; repeat for more.",
)
@click.option(
    "--manoeuvres",
    type=int,
    default=DEFAULT_SIMULATED_MANOEUVRES,
    show_default=True,
    help="Doublet manoeuvres per simulated configuration.",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0, max=MAX_SEED),
    default=None,
    help=f"Seed of the 70/30 split and of simulated flights [default: {DEFAULT_SEED}].",
)
@click.option(
    "--model",
    default=None,
    help="Model preset name or model TOML file [default: the file's, else "
    f"{DEFAULT_CAMPAIGN_MODEL}: the study's model with constant biases; "
    "delfly_longitudinal is the study's model without them].",
)
@click.option(
    "--mass-kg",
    "masses",
    multiple=True,
    metavar="[TAIL@X_H_MM=]KG",
    help="Vehicle mass for --log configurations (all, or one by label).",
)
@click.option(
    "--iyy-kg-m2",
    "inertias",
    multiple=True,
    metavar="[TAIL@X_H_MM=]KG_M2",
    help="Pitch inertia about y_b for --log configurations (all, or one by label).",
)
@click.option(
    "--out",
    "out_directory",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("campaign"),
    show_default=True,
    help="Directory for the table and the pictures.",
)
@click.option(
    "--selection-rule",
    type=click.Choice(SELECTION_RULES),
    default=None,
    help="How the representative model is chosen: most_wins (the study's: best on the most "
    "validation manoeuvres by RMS and PCC) or lowest_mean_rms "
    f"[default: the file's, else {DEFAULT_SELECTION_RULE}].",
)
@click.option(
    "--glitch-rule",
    type=click.Choice(GLITCH_RULES),
    default=None,
    help="Elevator glitches: steady_deviation (the study's: 25 deg or more from the steady "
    "deflection) or sample_jump (25 deg or more from the last good sample) "
    f"[default: the file's, else {DEFAULT_GLITCH_RULE}].",
)
@click.option(
    "--input-hold",
    type=click.Choice(INPUT_HOLDS),
    default=None,
    help="Input hold of the model's discretisation for every manoeuvre "
    "[default: the file's, else the model's own].",
)
@click.option(
    "--colored-sigma",
    type=click.Choice(COLORED_SIGMA_METHODS),
    default=None,
    help="Standard errors of every fit: morelli (SIDPAC's m_colores), morelli_small_sample "
    "(m_colores times N_eff / (N_eff - p) for short records) or tapered "
    f"[default: the file's, else {DEFAULT_CAMPAIGN_COLORED_SIGMA}].",
)
@click.option("--no-pictures", is_flag=True, help="Write the table only.")
@json_option
def campaign_command(
    campaign_path: Path | None,
    logs: tuple[str, ...],
    simulate: tuple[str, ...],
    manoeuvres: int,
    seed: int | None,
    model: str | None,
    masses: tuple[str, ...],
    inertias: tuple[str, ...],
    selection_rule: str | None,
    glitch_rule: str | None,
    input_hold: str | None,
    colored_sigma: str | None,
    out_directory: Path,
    no_pictures: bool,
    as_json: bool,
) -> None:
    """Cut manoeuvres, identify, validate and average: one representative model per
    configuration (the study's free-flight procedure).
    """
    rules = {
        "selection_rule": selection_rule,
        "glitch_rule": glitch_rule,
        "input_hold": input_hold,
        "colored_sigma": colored_sigma,
    }
    campaign = _campaign_from_options(
        campaign_path, logs, simulate, manoeuvres, seed, model, masses, inertias, rules
    )
    _check_inputs(campaign)
    prepare_output_directory(out_directory)
    count = len(campaign.configurations)
    total = count * PROGRESS_STEPS_PER_CONFIGURATION
    with Progress("flight campaign", total, "steps") as bar:

        def progress(index: int, fraction: float, note: str) -> None:
            bar.update(int(round((index + fraction) * PROGRESS_STEPS_PER_CONFIGURATION)), item=note)

        results = run_campaign(campaign, progress)
        bar.update(total, item=f"{count} configuration(s) analysed")
    info = {
        "seed": campaign.seed,
        "model": campaign.model,
        "selection_rule": campaign.selection_rule,
        "glitch_rule": campaign.glitch_rule,
        "input_hold": campaign.input_hold,
        "colored_sigma": campaign.colored_sigma,
    }
    csv_path, json_path, records = write_campaign_table(results, out_directory, info)
    written = [csv_path, json_path]
    if not no_pictures:
        written += write_campaign_pictures(results, out_directory)
    emit(
        {
            **info,
            "configurations": records,
            "written": [str(path) for path in written],
        },
        as_json,
        _render,
    )
