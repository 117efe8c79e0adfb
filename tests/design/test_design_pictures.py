"""``ornitail design propose`` and ``design pareto`` pictures: written with ``--out`` as PNG and PDF, listed in
text and JSON, axes labelled with quantity and unit; the planform's legend sits clear of the tail."""

import json

import pytest
from click.testing import CliRunner

from ornitail.app.cli import main
from ornitail.design.drawing import planform_figure
from ornitail.design.pareto import pareto_front
from ornitail.design.pareto_plots import front_evaluations, pareto_figure
from ornitail.design.proposal import ProposalProblem, propose
from ornitail.design.proposal_plots import in_data_figure, poles_figure, response_figure
from ornitail.design.proposal_report import design_targets
from ornitail.design.trend_sources import gather_observations
from ornitail.design.trends import fit_trends

PROPOSAL_PICTURES = ("proposal_poles", "proposal_response", "proposal_in_data")


@pytest.fixture(scope="module")
def study():
    observations = gather_observations(True, (), (), ())
    return observations, fit_trends(observations)


@pytest.fixture(scope="module")
def proposal(study):
    _, trend_model = study
    targets = design_targets(None, 0.0, None, 0.0, None, 0.0, 0.3, None, 0.0)
    return propose(trend_model, targets, x_h_m=0.098, start_count=2)


def test_propose_out_writes_and_lists_its_pictures(tmp_path):
    out = tmp_path / "proposal"
    arguments = ["design", "propose", "--zeta", "0.3", "--x-h-mm", "98", "--starts", "2"]
    result = CliRunner().invoke(main, [*arguments, "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    files = json.loads(result.stdout)["files"]
    for name in PROPOSAL_PICTURES:
        for suffix in ("png", "pdf"):
            path = out / f"{name}.{suffix}"
            assert path.stat().st_size > 0 and str(path) in files.values()
    assert {"planform_png", "planform_svg", "cut_file_svg"} <= set(files)
    text = CliRunner().invoke(main, [*arguments, "--out", str(out)])
    assert text.exit_code == 0 and f"poles_png: {out / 'proposal_poles.png'}" in text.stdout


def test_proposal_figures_carry_units(proposal, study):
    observations, _ = study
    (axis,) = poles_figure(proposal.evaluation).axes
    assert axis.get_xlabel() == "real part (1/s), negative: decaying"
    assert axis.get_ylabel() == "imaginary part, damped frequency (rad/s)"
    assert "poles of the proposed tail" in axis.get_title()
    response = response_figure(proposal.evaluation)
    assert [axis.get_ylabel() for axis in response.axes] == [
        "pitch attitude theta (deg)",
        "pitch rate q (deg/s)",
        "body velocity u (m/s)",
        "body velocity w (m/s)",
    ]
    assert response.axes[-1].get_xlabel() == "time after the disturbance (s)"
    assert "5 deg" in response.texts[0].get_text()
    ratio_axis, position_axis = in_data_figure(proposal.evaluation, observations).axes
    assert ratio_axis.get_xlabel() == position_axis.get_xlabel() == "tail area S (cm^2)"
    assert ratio_axis.get_ylabel() == "aspect ratio AR (-)"
    assert position_axis.get_ylabel() == "tail position x_h (mm)"
    # the design is drawn among the study's configurations (S1b..S6a, AR2a..AR6a)
    assert len(ratio_axis.texts) == len({(o.configuration, o.x_h_m) for o in observations})


def test_pareto_out_writes_png_pdf_and_the_sigma_columns(tmp_path):
    arguments = ["design", "pareto", "--points", "3", "--out", str(tmp_path), "--json"]
    result = CliRunner().invoke(main, arguments)
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    assert {"plot_png", "plot_pdf", "plot_svg", "table_csv"} == set(record["files"])
    for name in ("pareto.png", "pareto.pdf"):
        assert (tmp_path / name).stat().st_size > 0
    point = record["points"][0]
    assert 0 < point["damping_ratio_sigma_mean"] < point["damping_ratio_sigma_new"]
    header = (tmp_path / "pareto.csv").read_text().splitlines()[0]
    assert "damping_ratio_sigma_mean,damping_ratio_sigma_new" in header


def test_pareto_figure_draws_the_uncertainty_band_with_units(study):
    _, trend_model = study
    problem = ProposalProblem(trend_model)
    targets = design_targets(None, 0.0, None, 0.0, None, 0.0, None, None, 0.0)
    points = pareto_front(problem, "damping-speed", targets, 0.098, 3, 4)
    figure = pareto_figure(points, "damping-speed", front_evaluations(problem, points))
    (axis,) = figure.axes
    assert axis.get_xlabel() == "steady airspeed V_ss (m/s)"
    assert axis.get_ylabel() == "maximum damping ratio, zeta (-)"
    labels = axis.get_legend_handles_labels()[1]
    assert labels == ["95 % interval, a new flight", "95 % interval, mean trend", "front"]


def test_the_planform_legend_lies_below_the_axes(proposal):
    figure = planform_figure(proposal.geometry, "a proposal")
    (axis,) = figure.axes
    figure.canvas.draw()
    legend_box = axis.get_legend().get_window_extent()
    assert legend_box.y1 < axis.get_window_extent().y0
    assert axis.get_xlabel() == "spanwise y (mm)"
    assert axis.get_ylabel() == "aft of root leading edge (mm)"
