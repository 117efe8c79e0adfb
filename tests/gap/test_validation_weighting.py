"""Winsorised validation runs (``[baseline].validation_weighting = "winsorised"``) on numbers
worked by hand, and the rule they leave calibrated."""

import dataclasses

import numpy as np
import pytest

from ornitail.core.errors import UserInputError
from ornitail.gap.flight_data import MANOEUVRES_CUT
from ornitail.gap.flight_diagnosis import rule_from_energies
from ornitail.gap.model_spec import (
    BaselineSpec,
    read_baseline_spec,
    require_flight_only_keys,
    write_baseline_spec,
)
from ornitail.gap.pooled_validation import FoldScores
from ornitail.gap.ranking import CandidateEvidence
from ornitail.gap.validation_weighting import (
    WINSORISED_RUN_ENERGY,
    validation_run_weights,
    validation_weighting_for,
    weighted_scores,
)


def test_only_runs_above_the_cap_lose_weight_and_they_count_as_the_cap():
    energies = np.array([1.0, 2.0, 2.0, 3.0, 30.0])  # median 2: the cap is 6
    weights = validation_run_weights("winsorised", energies)
    np.testing.assert_allclose(weights, [1.0, 1.0, 1.0, 1.0, 0.2])
    assert energies[-1] * weights[-1] == pytest.approx(WINSORISED_RUN_ENERGY * 2.0)
    np.testing.assert_array_equal(validation_run_weights("none", energies), np.ones(5))


def _scores(start, candidate, null_after):
    evidence = [CandidateEvidence("a", 0.1, "s", 1, np.array(candidate), 3.0, 0.2, (0, 1))]
    return FoldScores(
        evidence, np.array(start), 10.0, 0.5, 100, np.array(null_after), np.array(start)
    )


def test_a_disturbed_run_no_longer_dilutes_the_closure_of_candidates_and_null_alike():
    # four quiet runs that an effect halves, and one run of 30 that nothing explains
    start = [2.0, 2.0, 2.0, 2.0, 30.0]
    candidate = [0.5, 0.5, 0.5, 0.5, 30.0]
    null = [[1.8, 1.8, 1.8, 1.8, 30.0]]
    plain = 1 - np.sqrt(32.0 / 38.0)
    scores = weighted_scores(
        _scores(start, candidate, null), validation_run_weights("winsorised", np.array(start))
    )
    (weighted,) = scores.evidence
    # the disturbed run counts as 6 (the cap) before and after: 1 - sqrt((2 + 6) / (8 + 6))
    closure = 1 - np.sqrt(weighted.heldout_sse.sum() / scores.start_heldout_sse.sum())
    assert closure == pytest.approx(1 - np.sqrt(8.0 / 14.0)) and closure > 2 * plain
    # the null direction is scored on the same weighted runs: 1 - sqrt((7.2 + 6) / 14)
    rule = rule_from_energies(scores.null_start_sse, scores.null_after_sse)
    assert rule.closures[0] == pytest.approx(1 - np.sqrt(13.2 / 14.0))


def test_validation_weighting_is_read_written_and_refused_for_tables(tmp_path):
    path = tmp_path / "baseline.toml"
    path.write_text(
        '[baseline]\nkind = "simulator"\ntail = "S3"\nx_h_mm = 98\nvalidation_weighting = "winsorised"\n'
    )
    spec = read_baseline_spec(path)
    assert spec.validation_weighting == "winsorised"
    written = write_baseline_spec(spec, tmp_path / "written.toml")
    assert read_baseline_spec(written).validation_weighting == "winsorised"
    plain = write_baseline_spec(
        BaselineSpec(kind="simulator", tail="S3", x_h_mm=98.0), tmp_path / "p.toml"
    )
    assert "validation_weighting" not in plain.read_text()
    assert read_baseline_spec(plain).validation_weighting is None
    none = dataclasses.replace(spec, validation_weighting="none")
    assert (
        read_baseline_spec(write_baseline_spec(none, tmp_path / "n.toml")).validation_weighting
        == "none"
    )
    require_flight_only_keys(none, "tunnel tables")
    with pytest.raises(UserInputError, match="validation_weighting.*only for flight logs"):
        require_flight_only_keys(spec, "tunnel tables")
    require_flight_only_keys(BaselineSpec(kind="simulator"), "tunnel tables")
    path.write_text(
        '[baseline]\nkind = "simulator"\ntail = "S3"\nx_h_mm = 98\nvalidation_weighting = "huber"\n'
    )
    with pytest.raises(UserInputError, match="validation_weighting"):
        read_baseline_spec(path)


def test_manoeuvres_are_winsorised_by_default_and_segments_never():
    unnamed = BaselineSpec(kind="linear_model", source="twin.toml")
    assert validation_weighting_for(unnamed, MANOEUVRES_CUT) == "winsorised"
    assert validation_weighting_for(unnamed, "segments of 2 s") == "none"
    plain = dataclasses.replace(unnamed, validation_weighting="none")
    assert validation_weighting_for(plain, MANOEUVRES_CUT) == "none"
    assert validation_weighting_for(plain, "segments of 2 s") == "none"
    named = dataclasses.replace(unnamed, validation_weighting="winsorised")
    assert validation_weighting_for(named, MANOEUVRES_CUT) == "winsorised"
    with pytest.raises(
        UserInputError, match=r"twin.toml: \[baseline\].validation_weighting"
    ) as raised:
        validation_weighting_for(named, "segments of 2 s")
    assert "\n" not in str(raised.value)
