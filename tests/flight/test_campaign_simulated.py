"""A small simulated campaign (2 tails x 6 manoeuvres) end to end: representative models follow
the simulator's linearisation and its tail trend; the table and pictures are written.
"""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from ornitail.flight.campaign import run_campaign
from ornitail.flight.campaign_file import CampaignSpec, configuration_from_label
from ornitail.flight.campaign_plots import write_campaign_pictures
from ornitail.flight.campaign_table import write_campaign_table
from ornitail.flight.validation import select_representative
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import linearise

MANOEUVRES = 6
LABELS = ("S1@98", "S5@98")


@pytest.fixture(scope="module")
def campaign_results():
    campaign = CampaignSpec(
        tuple(
            configuration_from_label(label, "test", simulated_manoeuvres=MANOEUVRES)
            for label in LABELS
        ),
        seed=2018,
    )
    notes = []
    results = run_campaign(campaign, lambda index, fraction, note: notes.append((index, fraction)))
    return results, notes


def reference_names() -> set[str]:
    return set(linearise(study_configuration("S1", 98.0)).derivatives)


def _oscillatory(result):
    return next(m.mode for m in result.representative_modes if m.mode.oscillatory)


def test_progress_is_reported_per_configuration(campaign_results):
    _, notes = campaign_results
    assert [fraction for index, fraction in notes if fraction == 1.0] == [1.0, 1.0]
    assert {index for index, _ in notes} == {0, 1}


@pytest.mark.parametrize("position", [0, 1])
def test_representative_oscillatory_mode_matches_the_simulator(campaign_results, position):
    result = campaign_results[0][position]
    tail, x_h_mm = LABELS[position].split("@")
    reference = linearise(study_configuration(tail, float(x_h_mm)))
    mode = _oscillatory(result)
    # The identified linear model fits the filtered response of the nonlinear cycle-averaged
    # vehicle with flapping-frequency coupling and 13 deg doublets; its bias against the
    # small-perturbation linearisation, measured on the simulator of issue 13 (the study's wing
    # arm, a tail that separates past 6.7 deg): damping +0.020 to +0.058 and natural frequency
    # 1-5.5 % low (representative models of S3, 4 campaigns of 5 manoeuvres; S5, 3 campaigns of
    # 6), against colored sigmas of 0.003-0.016. It is a bias, not scatter: +0.014 on a
    # noise-free S3 manoeuvre, the rest from the sensor noise and the gusts in about equal parts
    # (the earlier, stiffer model gave <= 0.015 and <= 2 %). 0.07 and 7 % cover it and stay far
    # below the S1-S5 difference (0.28) that the trend test resolves.
    assert mode.damping_ratio == pytest.approx(reference.oscillatory_damping_ratio(), abs=0.07)
    assert mode.natural_frequency_rad_s == pytest.approx(
        reference.oscillatory_natural_frequency_rad_s(), rel=0.07
    )
    # well-excited pitch derivatives: within 3 standard errors of the representative model
    # (statistical scatter) plus 5 % of the value (the same model-structure bias as above)
    values = result.representative.parameter_values()
    representative = result.representative
    sigmas = dict(zip(representative.parameter_names, representative.estimate.sigmas, strict=True))
    for name in ("Mq", "Mde"):
        truth = reference.derivatives[name]
        assert abs(values[name] - truth) <= 3 * sigmas[name] + 0.05 * abs(truth)


def test_the_tail_trend_of_the_simulator_is_reproduced(campaign_results):
    small, large = campaign_results[0]
    assert _oscillatory(large).damping_ratio > _oscillatory(small).damping_ratio + 0.15
    assert _oscillatory(large).natural_frequency_rad_s < _oscillatory(small).natural_frequency_rad_s
    mq_small = small.representative.parameter_values()["Mq"]
    mq_large = large.representative.parameter_values()["Mq"]
    assert mq_large < mq_small < 0  # |Mq| grows with tail area (docs/background.md section 6)
    # steady state: a bigger tail flies faster and more nose-down
    assert large.steady_state.theta_rad > small.steady_state.theta_rad
    assert large.steady_state.airspeed_m_s > small.steady_state.airspeed_m_s


@pytest.mark.parametrize("position", [0, 1])
def test_steady_state_is_the_simulator_trim(campaign_results, position):
    result = campaign_results[0][position]
    trim = result.simulator_reference.trim
    # Run-in means vs trim. S5 settles within 0.05 deg between manoeuvres; the lightly damped S1
    # (zeta 0.04) has not quite returned to trim 3 s after each turn: its run-ins sit 0.2-0.35 deg
    # high (measured). 0.5 deg and 0.01 m/s bound both with margin.
    assert result.steady_state.theta_rad == pytest.approx(trim.theta_rad, abs=math.radians(0.5))
    assert result.steady_state.airspeed_m_s == pytest.approx(trim.airspeed_m_s, abs=0.01)
    assert result.steady_state.flapping_frequency_hz == pytest.approx(
        trim.flapping_frequency_hz, abs=0.05
    )


def test_bookkeeping_of_manoeuvres(campaign_results):
    for result in campaign_results[0]:
        assert len(result.models) + len(result.diverged) == MANOEUVRES
        assert result.accepted.size == len(result.models) - result.rejected_count
        assert set(result.training) | set(result.validation) == set(result.accepted)
        assert not set(result.training) & set(result.validation)
        # the study's rule by default: most wins by RMS and PCC over the validation manoeuvres
        assert result.selection_rule == "most_wins"
        scores = result.validation_scores
        assert scores.rms.shape == (3, result.validation.size)
        assert result.representative.name == select_representative(scores, "most_wins")
        points = {name: sum(wins.values()) for name, wins in scores.wins().items()}
        assert points[result.representative.name] == max(points.values())
        assert {model.name for model in result.averaged} == {"mean", "weighted", "time_averaged"}


def test_table_and_pictures_are_written(campaign_results, tmp_path):
    results = campaign_results[0]
    csv_path, json_path, records = write_campaign_table(results, tmp_path, {"seed": 2018})
    with csv_path.open() as handle:
        rows = list(csv.DictReader(handle))
    assert [row["configuration"] for row in rows] == list(LABELS)
    for row, result in zip(rows, results, strict=True):
        assert float(row["x_h_m"]) == pytest.approx(0.098)
        assert float(row["Mq"]) == result.representative.parameter_values()["Mq"]
        assert float(row["Mq_sigma"]) > 0
        assert float(row["damping_ratio"]) == pytest.approx(_oscillatory(result).damping_ratio)
        assert row["representative_model"] in ("mean", "weighted", "time_averaged")
        assert row["selection_rule"] == "most_wins"
        assert row["glitch_rule"] == "steady_deviation" and row["input_hold"] == "first_order"
        wins = result.validation_scores.wins()
        for name in ("mean", "weighted", "time_averaged"):
            assert int(row[f"wins_rms_{name}"]) == wins[name]["rms"]
            assert int(row[f"wins_{name}"]) == wins[name]["rms"] + wins[name]["pcc"]
            assert float(row[f"mean_pcc_{name}"]) <= 1.0
        assert int(row["rejected"]) == result.rejected_count
        poles = [
            complex(float(row[f"pole{i}_real_1_s"]), float(row[f"pole{i}_imag_1_s"]))
            for i in range(1, 5)
        ]
        np.testing.assert_allclose(poles, result.representative_eigenvalues, rtol=1e-12)
    document = json.loads(json_path.read_text())
    assert document["seed"] == 2018
    # the campaign's default model: the study's derivatives plus nuisance biases, which are
    # estimated per manoeuvre but never tabulated as derivatives
    for record in document["configurations"]:
        assert record["model"] == "delfly_longitudinal_bias"
        assert record["nuisance_parameters"] == ["bq", "bu", "bw", "btheta"]
        assert set(record["derivatives"]) == set(reference_names())
    assert document["configurations"][1]["derivatives"]["Mq"]["sigma"] > 0
    assert document["configurations"][0]["simulator_reference"]["damping_ratio"] > 0
    pictures = write_campaign_pictures(results, tmp_path / "pictures")
    stems = {path.stem for path in pictures}
    assert stems == {
        "poles",
        "oscillatory_mode",
        "responses_S1_98",
        "responses_S5_98",
        "parameters_S1_98",
        "parameters_S5_98",
    }
    assert all(path.stat().st_size > 10_000 for path in pictures)
    assert {path.suffix for path in pictures} == {".png", ".pdf"}
