"""Blind diagnosis of simulated flight logs (through files) whose withheld effect is known."""

import pytest

from ornitail.gap.flight_diagnosis import diagnose_flight
from ornitail.gap.model_spec import read_baseline_spec, write_baseline_spec
from ornitail.gap.withheld_effects import WithheldCase, simulate_withheld_log, true_magnitudes
from ornitail.sim.free_flight import write_flight_log_csv


def _diagnose(case: WithheldCase, folder) -> dict:
    log = write_flight_log_csv(simulate_withheld_log(case), folder / "flight.csv")
    spec = read_baseline_spec(write_baseline_spec(case.baseline_spec(), folder / "model.toml"))
    return diagnose_flight(spec, [log], seed=5).report


@pytest.fixture(scope="module")
def added_mass_report(tmp_path_factory):
    case = WithheldCase("S4", 105.0, {"added_mass": 3.0}, manoeuvres=16, seed=21)
    return case, _diagnose(case, tmp_path_factory.mktemp("added_mass"))


def test_added_mass_is_named_with_its_indistinguishable_inertia_twin(added_mass_report):
    case, report = added_mass_report
    assert report["verdict"] == "effect"
    assert set(report["indistinguishable_set"]) == {"added_mass", "iyy_shift"}
    entry = next(e for e in report["ranking"] if e["name"] == "added_mass")
    # 11 training manoeuvres at the default noise: the benchmark's median magnitude error is
    # ~5 %; 25 % leaves room for a single draw's scatter while a wrong family would miss by far more
    assert entry["magnitude"] == pytest.approx(true_magnitudes(case)["added_mass"], rel=0.25)


def test_the_gap_shrinks_on_withheld_manoeuvres_and_training_predicts_it(added_mass_report):
    _, report = added_mass_report
    before, after = report["gap_before"], report["gap_after"]
    assert after["total"] < 0.75 * before["total"]
    assert report["closure"]["interval"][0] > 0.15  # paired bootstrap over withheld runs
    closure = report["closure"]
    assert closure["realised_withheld"] == pytest.approx(1 - after["total"] / before["total"])
    assert abs(closure["predicted_from_training"] - closure["realised_withheld"]) < 0.2
    assert set(before["per_channel"]) == {"q", "u", "w", "theta"}


def test_where_reports_channels_bands_segments_and_tests(added_mass_report):
    _, report = added_mass_report
    where = report["where"]
    assert sum(item["energy_share"] for item in where["by_channel"].values()) == pytest.approx(1)
    assert sum(band["pooled_share"] for band in where["by_band"]) == pytest.approx(1, abs=1e-9)
    assert sum(s["energy_share"] for s in where["by_segment"].values()) == pytest.approx(1)
    # a missing inertia acts through the doublet's response: the residual is driven by the input
    dominant = max(where["by_band"], key=lambda band: band["pooled_share"])
    assert dominant["band_hz"][1] <= 2.0
    assert max(dominant["coherence_with_input"].values()) > 0.5
    assert len(where["summary"]) == 5


def test_no_withheld_effect_gives_no_verdict(tmp_path):
    case = WithheldCase("S2", 90.0, {}, manoeuvres=14, seed=8)
    report = _diagnose(case, tmp_path)
    assert report["verdict"] == "none"
    assert report["effect"] is None
    assert report["closure"]["realised_withheld"] < 0.15


def test_input_delay_is_named_and_its_size_recovered(tmp_path):
    case = WithheldCase("AR4", 80.0, {"input_delay": 0.07}, manoeuvres=14, seed=9)
    report = _diagnose(case, tmp_path)
    assert report["effect"] == "input_delay"
    # the delay is resolved to a fraction of the 1/64 s step by interpolation; 15 % = 10 ms
    assert report["magnitude"]["value"] == pytest.approx(0.07, rel=0.15)


def test_a_second_effect_is_found_on_top_of_the_first(tmp_path):
    case = WithheldCase("S3", 105.0, {"pitch_damping": 0.6, "theta_drift": 0.01}, 14, seed=4)
    report = _diagnose(case, tmp_path)
    found = {report["effect"], (report["second_effect"] or {}).get("effect")}
    assert found == {"pitch_damping", "theta_drift"}
    assert report["second_effect"]["closure_beyond_first"] >= 0.15
