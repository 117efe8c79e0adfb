"""The baseline-model file and the baselines it names."""

import numpy as np
import pytest

from ornitail.core.errors import UserInputError
from ornitail.flight.model_file import load_model
from ornitail.gap.derivative_candidates import MODEL_PARAMETERS
from ornitail.gap.flight_candidates import baseline_flight_model, flight_candidates
from ornitail.gap.model_spec import BaselineSpec, read_baseline_spec, write_baseline_spec


def test_written_spec_reads_back(tmp_path):
    spec = BaselineSpec(
        "simulator", "S5", 114.0, ("added_mass", "wake_profile"), "", ("iyy_shift",)
    )
    again = read_baseline_spec(write_baseline_spec(spec, tmp_path / "b.toml"))
    assert (again.kind, again.tail, again.x_h_mm) == ("simulator", "S5", 114.0)
    assert again.effects_off == spec.effects_off and again.candidates == ("iyy_shift",)


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ('kind = "gp"\ntail = "S3"\nx_h_mm = 98', "kind"),
        ('kind = "simulator"\ntail = "S3"\nx_h_mm = nan', "x_h_mm"),
        ('kind = "simulator"\ntail = "S3"\nx_h_mm = 98\ncolour = 1', "colour"),
        ('kind = "simulator"\ntail = "S3"\nx_h_mm = 98\neffects_off = "added_mass"', "effects_off"),
        (
            'kind = "simulator"\ntail = "S3"\nx_h_mm = 98\nderivative_refit = true',
            "derivative_refit",
        ),
        ('kind = "linear_model"\nmodel = "delfly_longitudinal"\nderivative_refit = 1', "refit"),
        ('kind = "simulator"\ntail = "S3"\nx_h_mm = 98\nvalidation = "pooled"', "validation"),
    ],
)
def test_mistakes_name_the_key(tmp_path, text, where):
    path = tmp_path / "b.toml"
    path.write_text("[baseline]\n" + text + "\n")
    with pytest.raises(UserInputError, match=where):
        read_baseline_spec(path)


def test_a_model_file_baseline_needs_no_configuration_and_reads_back(tmp_path):
    spec = BaselineSpec(
        "linear_model",
        model="twin_otter_short_period",
        segment_s=0.5,
        derivative_refit=True,
        validation="all-folds",
    )
    again = read_baseline_spec(write_baseline_spec(spec, tmp_path / "b.toml"))
    assert (again.tail, again.segment_s, again.derivative_refit) == ("", 0.5, True)
    assert again.validation == "all-folds"
    assert np.isnan(again.x_h_mm)


def test_the_derivative_refit_is_on_for_a_model_file_unless_switched_off(tmp_path):
    path = tmp_path / "b.toml"
    path.write_text('[baseline]\nkind = "linear_model"\nmodel = "twin_otter_short_period"\n')
    assert read_baseline_spec(path).derivative_refit is True
    off = BaselineSpec("linear_model", model="twin_otter_short_period", derivative_refit=False)
    written = write_baseline_spec(off, tmp_path / "off.toml")
    assert "derivative_refit = false" in written.read_text()
    assert read_baseline_spec(written).derivative_refit is False
    # a simulator baseline has no model file's derivatives to re-fit
    assert BaselineSpec("simulator", "S3", 98.0).derivative_refit is False


def test_linear_model_baseline_uses_the_file_and_only_augmentations(tmp_path):
    spec = BaselineSpec("linear_model", "S3", 98.0, model="delfly_longitudinal")
    baseline = baseline_flight_model(spec)
    preset = load_model("delfly_longitudinal")
    expected = preset.state_space(preset.start_values(), preset.constants)
    np.testing.assert_allclose(baseline.a_matrix, expected.a_matrix)
    assert baseline.iyy_kg_m2 == pytest.approx(1.35066e-4)
    library = flight_candidates(spec, baseline)
    names = {candidate.name for candidate in library.candidates}
    # every derivative-level candidate: the file names Mq, Mw, Mu, Zw, Mde, Iyy and a state w
    assert names == {
        "iyy_shift",
        "heave_added_mass",
        *MODEL_PARAMETERS,
        "input_delay",
        "input_filter",
        "theta_drift",
    }
    # manoeuvre deviations by default: constant sensor offsets cancel, so no bias candidates
    assert set(library.skipped) == {"q_bias", "u_bias", "w_bias", "theta_bias"}


def test_an_unavailable_candidate_is_named():
    spec = BaselineSpec("simulator", "S3", 98.0, ("added_mass",), candidates=("wake_profile",))
    with pytest.raises(UserInputError, match="wake_profile"):
        flight_candidates(spec, baseline_flight_model(spec))
