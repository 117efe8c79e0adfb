"""``ornitail design geometry`` and ``ornitail design trends``; mass model anchors."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from ornitail.app.commands.design import design_group
from ornitail.core.errors import UserInputError
from ornitail.design.mass_model import pitch_inertia_kg_m2, vehicle_mass_kg
from ornitail.vehicle.geometry import study_tails

HEXAGON_TAILS = {name: tail for name, tail in study_tails().items() if name != "T2"}


@pytest.mark.parametrize("name", sorted(HEXAGON_TAILS))
def test_geometry_command_reproduces_the_table(name):
    g = HEXAGON_TAILS[name].geometry
    arguments = [
        "geometry",
        "--b",
        str(g.span_m * 1e3),
        "--b-le",
        str(g.leading_edge_span_m * 1e3),
        "--c-r",
        str(g.root_chord_m * 1e3),
        "--c-t",
        str(g.tip_chord_m * 1e3),
        "--json",
    ]
    result = CliRunner().invoke(design_group, arguments)
    printed = json.loads(result.output)
    # Same tolerances as tests/design/test_geometry.py: table rounding of S (0.05 cm^2) and AR.
    assert printed["s_cm2"] == pytest.approx(HEXAGON_TAILS[name].published_area_m2 * 1e4, abs=0.15)
    assert printed["ar"] == pytest.approx(HEXAGON_TAILS[name].published_aspect_ratio, abs=0.02)
    assert printed["valid"] is True


def test_geometry_command_refuses_a_planform_not_enclosing_the_base_tail():
    result = CliRunner().invoke(
        design_group, ["geometry", "--b", "78", "--b-le", "70", "--c-r", "60", "--c-t", "50"]
    )
    assert isinstance(result.exception, UserInputError)
    assert "enclose the base tail" in str(result.exception)


def _ornitail() -> str:
    return shutil.which("ornitail") or str(Path(sys.executable).parent / "ornitail")


def test_geometry_through_the_console_script():
    ornitail = _ornitail()
    done = subprocess.run(
        [
            ornitail,
            "design",
            "geometry",
            "--b",
            "203",
            "--b-le",
            "105",
            "--c-r",
            "66",
            "--c-t",
            "35",
            "--json",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0
    assert json.loads(done.stdout)["s_cm2"] == pytest.approx(
        118.79, abs=1e-9
    )  # (105+203)/2*31+203*35 mm^2
    bad = subprocess.run(
        [
            ornitail,
            "design",
            "geometry",
            "--b",
            "200",
            "--b-le",
            "210",
            "--c-r",
            "60",
            "--c-t",
            "40",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert "leading-edge span 210.0 mm exceeds span" in bad.stderr


PREDICT_S3_AT_57 = [
    "--predict-b",
    "203",
    "--predict-b-le",
    "105",
    "--predict-c-r",
    "66",
    "--predict-c-t",
    "35",
    "--predict-x-h-mm",
    "57",
]


def test_trends_command_with_prediction_and_pictures(tmp_path):
    result = CliRunner().invoke(
        design_group, ["trends", "--study", *PREDICT_S3_AT_57, "--out", str(tmp_path), "--json"]
    )
    printed = json.loads(result.output)
    theta = printed["prediction"]["quantities"]["theta_ss_rad"]
    assert theta["sigma_new"] > theta["sigma_mean"] > 0
    assert not theta["outside_fitted_range"]
    # Table 4 is at 98 mm only: a derivative predicted at 57 mm is an unbounded extrapolation.
    mq = printed["prediction"]["quantities"]["Mq"]
    assert (
        mq["extrapolation_mahalanobis"] is None and mq["outside_fitted_range"]
    )  # inf -> null in JSON
    assert printed["trends"]["Mq"]["sources"] == ["study-table-4"]
    assert (tmp_path / "trend_Mq.png").stat().st_size > 0 and (
        tmp_path / "trend_f_ss_hz.pdf"
    ).exists()
    assert json.loads((tmp_path / "trends.json").read_text())["basis"] == "linear"


@pytest.mark.parametrize(
    ("arguments", "fragment"),
    [
        (["trends"], "give at least one of --study"),
        (["trends", "--study", "--predict-b", "203"], "a prediction needs --predict-b-le"),
        (["trends", "--study", "--user-csv", "/nonexistent/x.csv"], "file not found"),
    ],
)
def test_trends_command_mistakes(arguments, fragment):
    result = CliRunner().invoke(design_group, arguments)
    assert isinstance(result.exception, UserInputError) and fragment in str(result.exception)


def test_mass_model_anchors():
    tails = study_tails()

    def vector(name, x_h_mm):
        g = tails[name].geometry
        return (g.span_m, g.leading_edge_span_m, g.root_chord_m, g.tip_chord_m, x_h_mm / 1000)

    # The study's mass range 22.8-24.3 g spans its lightest (T3 at 57) and heaviest (S6 at 126) set-ups.
    assert vehicle_mass_kg(vector("T3", 57)) == pytest.approx(0.0228, abs=2e-5)
    assert vehicle_mass_kg(vector("S6", 126)) == pytest.approx(0.0243, abs=2e-5)
    # +150 % I_yy from 57 to 126 mm (study), up to the tail term that differs between positions.
    ratio = pitch_inertia_kg_m2(vector("T1", 126)) / pitch_inertia_kg_m2(vector("T1", 57))
    assert ratio == pytest.approx(2.5, abs=0.01)
    assert 1e-4 <= pitch_inertia_kg_m2(vector("T1", 98)) <= 2e-4
