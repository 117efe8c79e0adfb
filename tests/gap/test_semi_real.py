"""Semi-real gap cases: NASA's real Twin Otter record (a model file with other states, outputs and
a constant input than the DelFly's) with a known effect injected into its logged columns; the
baseline is the short-period model identified on the untouched record (benchmarks/semi_real.py)."""

import dataclasses

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from semi_real import CASES, RECORD, InjectedCase, identified_model_file, write_case

from ornitail.gap.flight_diagnosis import diagnose_flight
from ornitail.gap.model_spec import read_baseline_spec
from ornitail.gap.report_text import render_report


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    return identified_model_file(tmp_path_factory.mktemp("twin_otter"))


def _report(
    case: InjectedCase, folder, model_file, candidates: tuple[str, ...] = (), refit: bool = False
) -> dict:
    log, spec_path = write_case(case, folder, model_file, refit)
    spec = dataclasses.replace(read_baseline_spec(spec_path), candidates=candidates)
    return diagnose_flight(spec, [log], seed=2018).report


@pytest.mark.parametrize("case", CASES, ids=lambda case: str(case.effect))
def test_injected_effect_is_named_with_its_magnitude(case, tmp_path, model_file):
    refit = case.effect == "alpha_bias"  # checked below, on the same diagnosis
    report = _report(case, tmp_path, model_file, refit=refit)
    assert report["split"]["runs_cut_into"] == "segments of 0.5 s"
    assert report["split"]["validation_weighting"] == "none"
    assert report["split"]["validation_runs_weighted_down"] == 0
    assert set(report["gap_before"]["per_channel"]) == {"alpha", "q", "a_z"}
    # the model names no Iyy, no Mu, no state w and no output theta: those augmentations are
    # skipped, by reason (its Ma, Za, Mq and Mde carry the derivative-level candidates)
    skipped = report["candidates_skipped"]
    assert set(skipped) == {"iyy_shift", "speed_stability", "heave_added_mass", "theta_drift"}
    assert "Mu" in skipped["speed_stability"] and "state w" in skipped["heave_added_mass"]
    name, magnitude = case.expected
    if name is None:
        assert report["verdict"] == "none"  # the record the baseline was identified on
        return
    assert report["verdict"] == "effect"
    # a filter is told from a delay only above 1/(2 pi k): on the 15 pooled validation segments the
    # 0.1 s filter closes 0.56 against a -0.07 s delay's 0.49 and is best in 0.93 of resamples, short
    # of the 0.95 that separates them (the first fold's 4 segments alone once gave 0.99, a bootstrap
    # of 35 distinct resamples), so the two may come as one set
    twins = {"input_filter": {"input_delay"}}.get(name, set())
    assert name in report["indistinguishable_set"]
    assert set(report["indistinguishable_set"]) <= {name} | twins
    entry = next(entry for entry in report["ranking"] if entry["name"] == name)
    assert entry["at_bound"] is None
    # the brief's 20 %: on this record the filter comes out 2-7 % high, the delay within 5 % and the
    # alpha bias 1.6 % high, each fitted with weights re-estimated from its own residual
    assert entry["magnitude"] == pytest.approx(magnitude, rel=0.2)
    # how far, on test segments that neither fitted nor chose it: each fold chooses on its own 3-4
    # validation segments of 0.5 s, and one whose segments hold little elevator motion may choose
    # otherwise (at seed 2018 one fold of the delay's chose input_filter, fitted at 0 s, and scored
    # its test segments with the baseline), so the test closure is the procedure's, wide on 15 runs
    closure = report["closure"]
    assert report["split"]["test_choices"].get(name, 0) >= 3
    assert closure["realised_test"] > 0.2 and closure["interval"][0] > 0.0
    if refit:
        _assert_bias_mapped_into_trim_biases(report["derivative_refit"], magnitude)


def test_a_short_filter_is_named_with_its_magnitude_where_the_baselines_weights_lost_it(
    tmp_path, model_file
):
    """A 0.05 s elevator filter (2.5 samples) acts on the short period much as a -0.05 s delay, so the two may be
    named together; the filter's own magnitude must still be within the brief's 20 %. Fitted with the baseline's
    channel weights it came out 0.032 s (-37 %): the baseline's q residual holds the injected effect, so q was
    down-weighted and alpha's model error pulled the fit; relaxed (weights from the candidate's own residual) it
    is 0.054 s."""
    report = _report(InjectedCase("elevator_filter", 0.05), tmp_path, model_file)
    assert report["verdict"] == "effect" and "input_filter" in report["indistinguishable_set"]
    entry = next(entry for entry in report["ranking"] if entry["name"] == "input_filter")
    assert entry["magnitude"] == pytest.approx(0.05, rel=0.2) and entry["at_bound"] is None


def _assert_bias_mapped_into_trim_biases(refit: dict, bias: float) -> None:
    """A vane reading alpha + b looks, to the linear model, like trim biases moved by -b times the
    alpha column: Mbias by -Ma b and az_bias by -V Za b (and Zbias by -Za b)."""
    derivatives = refit["derivatives"]
    speed = 238.9 * 0.3048  # the record's mean airspeed, ft/s to m/s
    # 20 %: per-segment fits of 9 parameters on 25 samples, merged; the re-fit also trades the
    # biases against the other derivatives it moves (Mq by 4 %, Ma by 12 %)
    assert derivatives["Mbias"]["change"] == pytest.approx(
        -derivatives["Ma"]["baseline"] * bias, rel=0.2
    )
    assert derivatives["az_bias"]["change"] == pytest.approx(
        -speed * derivatives["Za"]["baseline"] * bias, rel=0.2
    )
    assert {"Mbias", "az_bias"} <= set(refit["moved"])
    # the most a linear re-fit closes on the test segments, next to the named alpha_bias
    assert refit["closure_test"] > 0.7


def test_a_filter_beyond_the_candidates_range_is_reported_as_at_least_its_bound(
    tmp_path, model_file
):
    # a 0.4 s elevator filter; the input_filter candidate's range ends at 0.25 s
    case = InjectedCase("elevator_filter", 0.4)
    report = _report(case, tmp_path, model_file, candidates=("input_filter", "input_delay"))
    assert report["best_candidate"] == "input_filter"
    assert report["magnitude"]["at_bound"] == "upper"
    assert "at least 0.25 s (at the edge of the range)" in render_report(report)


def test_the_derivative_refit_from_the_generic_preset_finds_sidpacs_derivatives(tmp_path):
    """Where in the model, judged against NASA SIDPAC on the real record: the untouched Twin Otter
    record against the preset's generic start values (Ma -5, Mq -2, Mde -8 ...), not an identified
    model. The re-fit on the first fold's 7 training segments (of 15) must land on SIDPAC's output-
    error estimates of the whole record (tests/data/twin-otter/sidpac_twin_otter_019.csv) for each of
    the six derivatives: within 3 standard errors of the difference, the re-fit's (from its 90 %
    interval and Student's t on 6 degrees of freedom) and SIDPAC's colored one combined; measured at
    seed 2018 the largest is 1.45 (Ma), every SIDPAC value inside the re-fit's 90 % interval, and the
    re-fit closes 0.62 of the gap on its 4 test segments. (The trim bias az_bias is 3.0 of those
    standard errors from SIDPAC's; it is not among the six.)"""
    (tmp_path / "baseline.toml").write_text(
        '[baseline]\nkind = "linear_model"\nmodel = "twin_otter_short_period"\nsegment_s = 0.5\n'
    )
    spec = read_baseline_spec(tmp_path / "baseline.toml")
    refit = diagnose_flight(spec, [RECORD], seed=2018).report["derivative_refit"]
    sidpac = pd.read_csv(RECORD.parent / "sidpac_twin_otter_019.csv", comment="#")
    sidpac = sidpac.set_index("parameter")
    sidpac.loc["Zq", "value"] -= 1.0  # SIDPAC's A[0, 1] is 1 + ornitail's Zq
    quantile = stats.t.ppf(0.95, refit["training_runs"] - 1)
    for name in ("Za", "Zq", "Zde", "Ma", "Mq", "Mde"):
        item = refit["derivatives"][name]
        low, high = item["change_interval"]
        sigma = np.hypot((high - low) / (2 * quantile), sidpac.loc[name, "sigma_colored"])
        assert abs(item["refit"] - sidpac.loc[name, "value"]) < 3.0 * sigma, name
    for name in ("Ma", "Mq", "Mde"):  # the generic start was far: they must have moved
        assert name in refit["moved"]
    assert refit["supported_by_test_runs"]
