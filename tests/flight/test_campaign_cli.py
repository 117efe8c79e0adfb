"""``ornitail flight campaign``: option handling, refusals, and a run through the console script."""

from __future__ import annotations

import csv
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from ornitail.app.commands.flight_campaign import _campaign_from_options, campaign_command
from ornitail.core.errors import UserInputError
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import linearise
from ornitail.sim.free_flight import FlightPlan, simulate_flight, write_flight_log_csv

MANOEUVRES = 5


@pytest.fixture(scope="module")
def s3_log(tmp_path_factory) -> Path:
    """A simulated 5-manoeuvre flight of S3 at 98 mm written as a CSV flight log."""
    log = simulate_flight(
        study_configuration("S3", 98.0), plan=FlightPlan(duration_s=8.0 * MANOEUVRES), seed=21
    )
    return write_flight_log_csv(log, tmp_path_factory.mktemp("logs") / "s3_98.csv")


def _ornitail() -> str:
    return shutil.which("ornitail") or str(Path(sys.executable).parent / "ornitail")


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--simulate", "S3@98", "--log", "S3@98=a.csv"], "exactly one of"),
        ([], "exactly one of"),
        (["--simulate", "S3-98"], "'S3-98' is not TAIL@X_H_MM"),
        (["--simulate", "S3@98", "--manoeuvres", "2"], "fewer than 3"),
        (["--log", "S3@98"], "is not LABEL=VALUE"),
        (["--log", "S3@98=a.csv", "--mass-kg", "heavy"], "'heavy' is not a number"),
        (["--log", "S3@98=a.csv", "--mass-kg", "-0.02"], "must be a positive finite number"),
    ],
)
def test_option_mistakes_are_refused(arguments, message, tmp_path):
    result = CliRunner().invoke(campaign_command, [*arguments, "--out", str(tmp_path)])
    assert isinstance(result.exception, UserInputError)
    assert message in str(result.exception)


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--selection-rule", "best"),
        ("--glitch-rule", "jump"),
        ("--input-hold", "linear"),
        ("--colored-sigma", "white"),
    ],
)
def test_unknown_rules_are_refused_by_the_option_parser(option, value, tmp_path):
    result = CliRunner().invoke(campaign_command, ["--simulate", "S3@98", option, value])
    assert result.exit_code == 2 and f"'{value}' is not one of" in result.output


def test_rule_options_override_the_campaign_file(tmp_path):
    campaign = tmp_path / "campaign.toml"
    campaign.write_text(
        'glitch_rule = "sample_jump"\ninput_hold = "zero_order"\n'
        '[[configuration]]\ntail = "S3"\nx_h_mm = 98\nsimulate = 5\n'
    )
    no_rules = {
        "selection_rule": None,
        "glitch_rule": None,
        "input_hold": None,
        "colored_sigma": None,
    }
    from_file = _campaign_from_options(campaign, (), (), 21, None, None, (), (), no_rules)
    assert (from_file.selection_rule, from_file.glitch_rule, from_file.input_hold) == (
        "most_wins",
        "sample_jump",
        "zero_order",
    )
    given = {
        "selection_rule": "lowest_mean_rms",
        "glitch_rule": None,
        "input_hold": "first_order",
        "colored_sigma": "morelli_small_sample",
    }
    overridden = _campaign_from_options(campaign, (), (), 21, None, None, (), (), given)
    assert (from_file.colored_sigma, overridden.colored_sigma) == (
        "morelli",
        "morelli_small_sample",
    )
    assert from_file.model == overridden.model == "delfly_longitudinal_bias"
    assert (overridden.selection_rule, overridden.glitch_rule, overridden.input_hold) == (
        "lowest_mean_rms",
        "sample_jump",
        "first_order",
    )
    simulated = _campaign_from_options(None, (), ("S3@98",), 5, None, None, (), (), given)
    assert (simulated.selection_rule, simulated.glitch_rule, simulated.input_hold) == (
        "lowest_mean_rms",
        "steady_deviation",
        "first_order",
    )


def test_logs_without_mass_properties_are_refused(s3_log, tmp_path):
    result = CliRunner().invoke(
        campaign_command, ["--log", f"S3@98={s3_log}", "--out", str(tmp_path)]
    )
    assert isinstance(result.exception, UserInputError)
    assert "S3@98: flight logs need the vehicle's mass_kg and iyy_kg_m2" in str(result.exception)


def test_a_log_with_missing_columns_is_refused(s3_log, tmp_path):
    broken = tmp_path / "broken.csv"
    broken.write_text(
        "\n".join(",".join(line.split(",")[:-1]) for line in s3_log.read_text().splitlines())
    )  # drops the last column, rudder_cmd
    result = CliRunner().invoke(
        campaign_command,
        ["--log", f"S3@98={broken}", "--mass-kg", "0.0234", "--iyy-kg-m2", "1.35e-4"],
    )
    assert isinstance(result.exception, UserInputError)
    assert f"{broken}: flight log lacks column(s) rudder_cmd" in str(result.exception)


def test_logs_with_rounded_jittered_timestamps_from_two_clocks_are_pooled(s3_log, tmp_path):
    """Two logs of one configuration as real loggers write them: timestamps with 7 decimals, one of them from a
    clock with jitter running 50 ppm fast. Both are cut and time-averaged together (one sample rate within 1e-4)."""
    import numpy as np
    import pandas as pd

    log = pd.read_csv(s3_log)
    rounded, other_clock = tmp_path / "rounded.csv", tmp_path / "other_clock.csv"
    log.assign(time_s=log["time_s"].round(7)).to_csv(rounded, index=False)
    jitter = np.random.default_rng(8).normal(0.0, 0.02 / 512.0, len(log))
    log.assign(time_s=(log["time_s"] * (1 + 5e-5) + jitter).round(7)).to_csv(
        other_clock, index=False
    )
    result = CliRunner().invoke(
        campaign_command,
        ["--log", f"S3@98={rounded}", "--log", f"S3@98={other_clock}", "--mass-kg", "0.0234"]
        + ["--iyy-kg-m2", "1.35e-4", "--out", str(tmp_path / "out"), "--no-pictures", "--json"],
    )
    assert result.exit_code == 0, result.output
    (row,) = json.loads(result.stdout)["configurations"]
    assert row["manoeuvres"] == 2 * MANOEUVRES


def test_campaign_file_run_through_the_console_script(s3_log, tmp_path):
    executable = _ornitail()
    reference = linearise(study_configuration("S3", 98.0))
    campaign = tmp_path / "campaign.toml"
    campaign.write_text(
        'seed = 5\ninput_hold = "zero_order"\n[[configuration]]\ntail = "S3"\nx_h_mm = 98\n'
        f"mass_kg = {reference.mass_kg!r}\niyy_kg_m2 = {reference.iyy_kg_m2!r}\n"
        f'log = ["{s3_log}"]\n'
    )
    out = tmp_path / "out"
    completed = subprocess.run(
        [
            executable,
            "flight",
            "campaign",
            "--campaign",
            str(campaign),
            "--out",
            str(out),
            "--no-pictures",
            "--selection-rule",
            "lowest_mean_rms",
            "--json",
        ],
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    )
    assert completed.returncode == 0, completed.stderr
    document = json.loads(completed.stdout)  # exactly one JSON object on stdout
    # stderr is a pipe, not a terminal: progress comes as timestamped lines, the last once done
    assert re.search(
        r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ flight campaign: 100/100 steps, 1 configuration\(s\) analysed$",
        completed.stderr,
        re.MULTILINE,
    ), completed.stderr
    (row,) = document["configurations"]
    assert row["configuration"] == "S3@98" and document["seed"] == 5
    # the file's input hold reached the model; the option's selection rule picked the model
    assert (row["input_hold"], row["selection_rule"], row["glitch_rule"]) == (
        "zero_order",
        "lowest_mean_rms",
        "steady_deviation",
    )
    # the table says which model and sigma formula produced it; biases are not derivatives
    assert (document["model"], row["model"]) == ("delfly_longitudinal_bias",) * 2
    assert (document["colored_sigma"], row["colored_sigma"]) == ("morelli", "morelli")
    assert row["nuisance_parameters"] == ["bq", "bu", "bw", "btheta"]
    assert not set(row["derivatives"]) & set(row["nuisance_parameters"])
    assert document["selection_rule"] == "lowest_mean_rms"
    assert row["representative_model"] == min(row["scores"], key=row["scores"].get)
    # one RMS and one PCC point per validation manoeuvre at least (more only on exact ties)
    for criterion in ("rms", "pcc"):
        assert sum(wins[criterion] for wins in row["wins"].values()) >= row["validation"]
    with (out / "representative_models.csv").open() as handle:
        (csv_row,) = list(csv.DictReader(handle))
    assert csv_row["selection_rule"] == "lowest_mean_rms"
    assert int(csv_row["wins_mean"]) == row["wins"]["mean"]["total"]
    assert row["manoeuvres"] == MANOEUVRES
    # the same bias allowance as the simulated campaign tests (0.07 in damping ratio, the bias
    # measured in tests/flight/test_campaign_simulated.py; this log: 0.359 against 0.314)
    assert row["damping_ratio"] == pytest.approx(reference.oscillatory_damping_ratio(), abs=0.07)
    assert (out / "representative_models.csv").is_file()
    assert sorted(document["written"]) == sorted(
        str(out / name) for name in ("representative_models.csv", "representative_models.json")
    )


def test_a_refused_log_is_one_line_and_exit_code_2_in_the_console_script(s3_log, tmp_path):
    executable = _ornitail()
    missing = tmp_path / "missing.csv"
    completed = subprocess.run(
        [
            executable,
            "flight",
            "campaign",
            "--log",
            f"S3@98={missing}",
            "--mass-kg",
            "0.0234",
            "--iyy-kg-m2",
            "1.35e-4",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert completed.returncode == 2
    assert (
        completed.stderr.strip().splitlines()[-1]
        == f"ornitail: error: {missing}: flight log not found"
    )
