"""``ornitail gap``: example, diagnose (text, JSON, files), bad input as one line with exit 2."""

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from ornitail.app.cli import main


@pytest.fixture(scope="module")
def tunnel_example(write_gap_example):
    return write_gap_example("tunnel", "strut_interference")


def _diagnose(example: dict, out, *extra: str):
    return CliRunner().invoke(
        main,
        [
            "gap",
            "diagnose",
            "--model",
            example["model"],
            "--data",
            example["data"],
            "--out",
            str(out),
            *extra,
        ],
    )


def test_diagnose_json_is_one_object_with_the_documented_keys(tunnel_example, tmp_path):
    result = _diagnose(tunnel_example, tmp_path / "report", "--json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["effect"] == "strut_interference"
    assert {"gap_before", "gap_after", "where", "ranking", "closure"} <= set(report)
    assert report["gap_after"]["total"] < report["gap_before"]["total"]
    names = {p.name for p in (tmp_path / "report").iterdir()}
    assert {
        "gap-report.json",
        "gap-report.txt",
        "ranking.png",
        "ranking.pdf",
        "localisation.png",
        "residuals_by_point.pdf",
    } <= names
    saved = json.loads((tmp_path / "report" / "gap-report.json").read_text())
    assert saved["effect"] == report["effect"]


def test_diagnose_text_names_the_effect(tunnel_example, tmp_path):
    result = _diagnose(tunnel_example, tmp_path, "--no-pictures")
    assert result.exit_code == 0, result.output
    assert "effect: strut_interference" in result.output
    assert not (tmp_path / "ranking.png").exists()


def _one_line_error(arguments: list[str]) -> str:
    result = CliRunner().invoke(main, arguments)
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith("ornitail: error: ")
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    return result.stderr


def test_missing_model_file_is_one_line(tunnel_example, tmp_path):
    message = _one_line_error(
        [
            "gap",
            "diagnose",
            "--model",
            str(tmp_path / "nope.toml"),
            "--data",
            tunnel_example["data"],
            "--out",
            str(tmp_path),
        ]
    )
    assert "nope.toml" in message and "not found" in message


def test_a_folder_that_is_not_a_run_is_named(tunnel_example, tmp_path):
    folder = tmp_path / "runs"
    folder.mkdir()
    arguments = ["gap", "diagnose", "--model", tunnel_example["model"], "--data", str(folder)]
    message = _one_line_error([*arguments, "--out", str(tmp_path / "report")])
    assert str(folder) in message and "no run.json" in message


def test_unknown_effect_in_the_model_file_is_named(tunnel_example, tmp_path):
    model = tmp_path / "model.toml"
    model.write_text(
        '[baseline]\nkind = "simulator"\ntail = "S3"\nx_h_mm = 98\n'
        'effects_off = ["strut_interferance"]\n'
    )
    message = _one_line_error(
        [
            "gap",
            "diagnose",
            "--model",
            str(model),
            "--data",
            tunnel_example["data"],
            "--out",
            str(tmp_path),
        ]
    )
    assert "effects_off" in message and "strut_interferance" in message


def test_nan_in_a_load_column_is_named(tunnel_example, tmp_path):
    lines = Path(tunnel_example["data"]).read_text().splitlines()
    header = lines[0].split(",")
    row = lines[3].split(",")
    row[header.index("m_n_m")] = "nan"
    lines[3] = ",".join(row)
    data = tmp_path / "bad.csv"
    data.write_text("\n".join(lines) + "\n")
    message = _one_line_error(
        [
            "gap",
            "diagnose",
            "--model",
            tunnel_example["model"],
            "--data",
            str(data),
            "--out",
            str(tmp_path),
        ]
    )
    assert "m_n_m" in message and "row 3" in message


def test_out_of_range_tail_position_and_bad_effect_magnitude(tmp_path):
    model = tmp_path / "model.toml"
    model.write_text('[baseline]\nkind = "simulator"\ntail = "S3"\nx_h_mm = 500\n')
    message = _one_line_error(
        ["gap", "diagnose", "--model", str(model), "--data", str(model), "--out", str(tmp_path)]
    )
    assert "x_h_mm" in message and "500" in message
    message = _one_line_error(
        ["gap", "example", "--effect", "added_mass=nan", "--out", str(tmp_path)]
    )
    assert "added_mass" in message and "not finite" in message


def test_too_few_manoeuvres_to_fit_choose_and_test_is_one_line(tmp_path):
    # The example command refuses so short a flight; the library writes one.
    from ornitail.gap.example_data import write_example

    example = write_example("flight", {"added_mass": None}, "S3", 98.0, 5, 1, tmp_path / "ex")
    message = _one_line_error(
        ["gap", "diagnose", "--model", example["model"], "--data", example["data"]]
        + ["--out", str(tmp_path / "report")]
    )
    assert "flight.csv" in message and "at least 6" in message


def test_the_example_and_the_benchmark_refuse_fewer_manoeuvres_than_a_diagnosis_needs():
    from ornitail.app.commands.gap import gap_group
    from ornitail.gap.flight_data import MINIMUM_MANOEUVRES

    for name in ("example", "benchmark"):
        (option,) = [p for p in gap_group.commands[name].params if p.name == "manoeuvres"]
        assert option.type.min == MINIMUM_MANOEUVRES


TWIN_OTTER = Path(__file__).parents[1] / "data" / "twin-otter" / "twin_otter_020213f1_019.csv"


def test_a_record_without_manoeuvre_commands_needs_a_segment_length(tmp_path):
    model = tmp_path / "model.toml"
    model.write_text('[baseline]\nkind = "linear_model"\nmodel = "twin_otter_short_period"\n')
    arguments = ["gap", "diagnose", "--model", str(model), "--data", str(TWIN_OTTER)]
    message = _one_line_error([*arguments, "--out", str(tmp_path / "report")])
    assert "twin_otter_020213f1_019.csv" in message and "elevator_cmd" in message
    assert "segment_s" in message


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ('kind = "simulator"\ntail = "S3"\nx_h_mm = 98\nsegment_s = 1.0', "segment_s"),
        ('kind = "linear_model"\nmodel = "twin_otter_short_period"\nsegment_s = -1', "segment_s"),
        ('kind = "linear_model"\nmodel = "twin_otter_short_period"\nsegment_s = 0.1', "segment_s"),
    ],
)
def test_a_bad_segment_length_is_one_line(tmp_path, text, named):
    model = tmp_path / "model.toml"
    model.write_text("[baseline]\n" + text + "\n")
    arguments = ["gap", "diagnose", "--model", str(model), "--data", str(TWIN_OTTER)]
    message = _one_line_error([*arguments, "--out", str(tmp_path / "report")])
    assert named in message
