"""Campaign files and configuration labels (flight/campaign_file.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from ornitail.core.errors import UserInputError
from ornitail.flight.campaign_file import (
    configuration_from_label,
    parse_configuration_label,
    read_campaign_file,
)

CAMPAIGN = """
seed = 7

[[configuration]]
tail = "S3"
x_h_mm = 98
mass_kg = 0.0235
iyy_kg_m2 = 1.5e-4
log = [{ path = "day1/s3_98.csv", time_range_s = [10.0, 300.0] }, { path = "s3_98_b.csv" }]

[[configuration]]
tail = "X1"
x_h_mm = 126
planform = { b_mm = 120, b_le_mm = 80, c_r_mm = 90, c_t_mm = 50 }
simulate = 0
log = ["x1.csv"]
"""


def test_campaign_file_is_read_with_paths_relative_to_it(tmp_path: Path):
    path = tmp_path / "campaign.toml"
    path.write_text(CAMPAIGN)
    campaign = read_campaign_file(path)
    # The campaign's default model carries nuisance biases; the study's own model is an option.
    assert campaign.seed == 7 and campaign.model == "delfly_longitudinal_bias"
    assert campaign.colored_sigma == "morelli"
    first, second = campaign.configurations
    assert first.label == "S3@98" and first.x_h_m == pytest.approx(0.098)
    assert first.logs[0].path == tmp_path / "day1" / "s3_98.csv"
    assert first.logs[0].time_range_s == (10.0, 300.0)
    assert first.logs[1].time_range_s is None
    assert first.mass_kg == 0.0235 and first.iyy_kg_m2 == 1.5e-4
    assert first.area_m2 == pytest.approx(118.8e-4, rel=0.01)  # S3, published 118.8 cm^2
    # hexagon: (b_LE + b)/2 (c_r - c_t) + b c_t = 100 * 40 + 120 * 50 = 10000 mm^2
    assert second.area_m2 == pytest.approx(0.01, rel=1e-12)
    assert second.aspect_ratio == pytest.approx(1.44, rel=1e-12)
    assert second.mass_kg is None


@pytest.mark.parametrize(
    ("replace", "by", "message"),
    [
        ("x_h_mm = 98", "x_h_mm = 980", r"x_h_mm: tail position 980 mm is outside"),
        ('tail = "X1"', 'tail = "Q9"\nplanform_x = 1', r"planform_x: unknown key"),
        (
            "mass_kg = 0.0235",
            "mass_kg = -1.0",
            r"\[configuration\[1\]\]\.mass_kg: -1\.0 must be > 0",
        ),
        (
            "time_range_s = [10.0, 300.0]",
            "time_range_s = [300.0, 10.0]",
            r"\[configuration\[1\]\.log\[1\]\]\.time_range_s: start 300 must be below end 10",
        ),
        ("seed = 7", 'seed = "a"', r"campaign\.toml: seed: 'a' must be a whole number"),
        ("seed = 7", "seed = 4294967296", r"seed: 4294967296 must be in 0\.\.4294967295"),
        ('log = ["x1.csv"]', "", r"\[configuration\[2\]\]: lists no"),
        (
            'log = ["x1.csv"]',
            "log = [3]",
            r"\[configuration\[2\]\.log\[1\]\]: 3 must be a table or",
        ),
        (
            'log = ["x1.csv"]',
            'log = "x1.csv"',
            r"\[configuration\[2\]\]\.log: 'x1.csv' must be a list",
        ),
        (
            "b_mm = 120,",
            "b_mm = 120, span = 1,",
            r"\[configuration\[2\]\.planform\]\.span: unknown key",
        ),
        (
            "c_t_mm = 50",
            "c_t_mm = nan",
            r"\[configuration\[2\]\.planform\]\.c_t_mm: nan must be a finite",
        ),
        ("simulate = 0", "simulate = 5", r"\[configuration\[2\]\]: give either logs or simulate"),
    ],
)
def test_campaign_file_mistakes_are_refused(tmp_path: Path, replace, by, message):
    path = tmp_path / "campaign.toml"
    path.write_text(CAMPAIGN.replace(replace, by))
    with pytest.raises(UserInputError, match=message):
        read_campaign_file(path)


def test_unknown_tail_without_planform_is_refused(tmp_path: Path):
    path = tmp_path / "campaign.toml"
    planform_line = "planform = { b_mm = 120, b_le_mm = 80, c_r_mm = 90, c_t_mm = 50 }"
    assert planform_line in CAMPAIGN
    path.write_text(CAMPAIGN.replace(planform_line, ""))
    with pytest.raises(UserInputError, match=r"\[configuration\[2\]\]\.tail: unknown tail 'X1'"):
        read_campaign_file(path)


def test_labels():
    assert parse_configuration_label("S5@57", "--simulate") == ("S5", pytest.approx(0.057))
    assert configuration_from_label("AR4@114", "--simulate").label == "AR4@114"
    with pytest.raises(UserInputError, match=r"--simulate: 'S3-98' is not TAIL@X_H_MM"):
        parse_configuration_label("S3-98", "--simulate")
    with pytest.raises(UserInputError, match=r"unknown tail 'Z9'"):
        configuration_from_label("Z9@98", "--log")


def test_campaign_rules_default_to_the_study_and_are_read_from_the_file(tmp_path: Path):
    path = tmp_path / "campaign.toml"
    path.write_text(CAMPAIGN)
    campaign = read_campaign_file(path)
    assert (campaign.selection_rule, campaign.glitch_rule, campaign.input_hold) == (
        "most_wins",
        "steady_deviation",
        None,
    )
    rules = 'selection_rule = "lowest_mean_rms"\nglitch_rule = "sample_jump"\n'
    rules += 'colored_sigma = "morelli_small_sample"\nmodel = "delfly_longitudinal"\n'
    path.write_text(rules + 'input_hold = "zero_order"\n' + CAMPAIGN)
    campaign = read_campaign_file(path)
    assert (campaign.selection_rule, campaign.glitch_rule, campaign.input_hold) == (
        "lowest_mean_rms",
        "sample_jump",
        "zero_order",
    )
    assert (campaign.colored_sigma, campaign.model) == (
        "morelli_small_sample",
        "delfly_longitudinal",
    )


@pytest.mark.parametrize(
    ("line", "message"),
    [
        (
            'selection_rule = "best"',
            r"campaign\.toml: selection_rule: 'best' must be one of most_wins, lowest_mean_rms",
        ),
        ("glitch_rule = 25", r"glitch_rule: 25 must be one of steady_deviation, sample_jump"),
        ('input_hold = "linear"', r"input_hold: 'linear' must be one of first_order, zero_order"),
        (
            'colored_sigma = "white"',
            r"colored_sigma: 'white' must be one of morelli, tapered, morel",
        ),
    ],
)
def test_unknown_rules_are_refused(tmp_path: Path, line, message):
    path = tmp_path / "campaign.toml"
    path.write_text(line + "\n" + CAMPAIGN)
    with pytest.raises(UserInputError, match=message):
        read_campaign_file(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "seeds = 1\n" + CAMPAIGN,
            r"campaign\.toml: seeds: unknown key; allowed keys are colored_sig",
        ),
        ("configuration = []\n", r"campaign\.toml: configuration: no \[\[configuration\]\] listed"),
        ("seed = 1\n", r"campaign\.toml: configuration: no \[\[configuration\]\] listed"),
        ("configuration = [1]\n", r"campaign\.toml: \[configuration\[1\]\]: 1 must be a table"),
        ("model = 3\n" + CAMPAIGN, r"campaign\.toml: model: 3 must be a non-empty string"),
    ],
)
def test_top_level_mistakes_are_refused(tmp_path: Path, text, message):
    path = tmp_path / "campaign.toml"
    path.write_text(text)
    with pytest.raises(UserInputError, match=message):
        read_campaign_file(path)
