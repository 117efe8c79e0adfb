"""Derivative-level candidates (gap/derivative_candidates.py): each changes the one entry it
names, by its dimensional amount, and a diagnosis of manoeuvres flown with that derivative changed
names it with its size."""

import re
from pathlib import Path

import numpy as np
import pytest

from ornitail.flight.model_file import load_model
from ornitail.gap.flight_candidates import baseline_flight_model, flight_candidates
from ornitail.gap.flight_diagnosis import (
    _library_scores,
    _rank,
    _Split,
    noise_scales,
    residuals_of,
    rule_from_energies,
)
from ornitail.gap.model_spec import BaselineSpec

# (candidate, matrix, row, column, scale) on the simulator's states q, u, w, theta
SIMULATOR_ENTRIES = [
    ("pitch_damping", "a", 0, 0, "iyy_kg_m2"),
    ("speed_stability", "a", 0, 1, "iyy_kg_m2"),
    ("static_stability", "a", 0, 2, "iyy_kg_m2"),
    ("heave_damping", "a", 2, 2, "mass_kg"),
    ("control_power", "b", 0, 0, "iyy_kg_m2"),
]


def test_each_simulator_derivative_moves_only_its_own_entry_by_k_over_mass_or_inertia():
    spec = BaselineSpec("simulator", "S3", 98.0)
    baseline = baseline_flight_model(spec)
    library = {c.name: c for c in flight_candidates(spec, baseline).candidates}
    assert baseline.mass_kg > 0 and baseline.iyy_kg_m2 > 0
    for name, matrix, row, column, scale in SIMULATOR_ENTRIES:
        candidate = library[name]
        k = 0.5 * candidate.bounds[1]
        changed = candidate.build(k)
        a_step = changed.a_matrix - baseline.a_matrix
        b_step = changed.b_matrix - baseline.b_matrix
        step = a_step if matrix == "a" else b_step
        assert step[row, column] == pytest.approx(k / getattr(baseline, scale), rel=1e-9)
        step[row, column] = 0.0
        assert not a_step.any() and not b_step.any(), name
        # the range reaches three times the baseline's own value either way
        own = (baseline.a_matrix if matrix == "a" else baseline.b_matrix)[row, column]
        assert candidate.bounds[1] == pytest.approx(3 * abs(own) * getattr(baseline, scale))
    heavier = library["heave_added_mass"].build(0.5)
    np.testing.assert_allclose(heavier.a_matrix[2], baseline.a_matrix[2] / 1.5)
    np.testing.assert_allclose(heavier.b_matrix[2], baseline.b_matrix[2] / 1.5)
    np.testing.assert_array_equal(
        np.delete(heavier.a_matrix, 2, 0), np.delete(baseline.a_matrix, 2, 0)
    )


@pytest.mark.parametrize(
    ("name", "parameter", "factor"),
    [("static_stability", "Mw", 1.8), ("heave_damping", "Zw", 2.5)],
)
def test_a_changed_derivative_is_named_with_its_size(
    name, parameter, factor, fly_linear_manoeuvres
):
    """Manoeuvres flown by the DelFly model file with one derivative changed, diagnosed against
    the file's own values: the candidate on that parameter ranks first, beats the detection rule,
    and its magnitude is the change (3 % noise on 8 training runs pins a single magnitude to well
    under 1 %; 5 % leaves room for the channel weights' relaxation)."""
    spec = BaselineSpec("linear_model", model="delfly_longitudinal")
    model = load_model(spec.model)
    baseline = baseline_flight_model(spec)
    values = model.start_values()
    true_change = (factor - 1.0) * values[parameter]
    numeric = model.state_space(
        {**values, parameter: values[parameter] + true_change}, model.constants
    )
    runs = fly_linear_manoeuvres(baseline.with_matrices(numeric.a_matrix, numeric.b_matrix), 16, 5)
    training, validation = runs[:8], runs[8:]
    signal = np.concatenate([run.outputs for run in training]).std(axis=0)
    scales = noise_scales(training, residuals_of(baseline, training), signal)
    reference = np.sqrt(np.mean(np.concatenate(residuals_of(baseline, validation)) ** 2, axis=0))
    library = flight_candidates(spec, baseline).candidates
    split = _Split(training, validation, scales, reference, seed=2)
    scores, _ = _library_scores(library, baseline, baseline, split)
    rule = rule_from_energies(scores.null_start_sse, scores.null_after_sse)
    ranking = _rank(scores, split.seed, rule)
    top = ranking.entries[0]
    assert top.name == name and ranking.detected
    assert top.heldout_closure > rule.threshold
    assert top.magnitude == pytest.approx(true_change, rel=0.05)


def test_a_model_file_that_spells_its_derivatives_with_underscores_gets_their_candidates(tmp_path):
    """The Twin Otter's file with Ma, Mq, Mde and Za spelled M_alpha, M_q, M_delta_e and Z_alpha:
    the same four derivative candidates, each acting on the renamed parameter."""
    text = (Path(load_model("twin_otter_short_period").source)).read_text()
    for old, new in (("Ma", "M_alpha"), ("Mq", "M_q"), ("Mde", "M_delta_e"), ("Za", "Z_alpha")):
        text = re.sub(rf"\b{old}\b", new, text)
    (tmp_path / "renamed.toml").write_text(text)
    names = {}
    for model in ("twin_otter_short_period", str(tmp_path / "renamed.toml")):
        spec = BaselineSpec("linear_model", model=model)
        airspeed = {"V": 50.0}  # m/s, the one constant the file takes from data
        baseline = baseline_flight_model(spec, airspeed)
        library = flight_candidates(spec, baseline, data_constants=airspeed)
        names[model] = {
            c.name: c.description
            for c in library.candidates
            if c.description.startswith("parameter")
        }
    original, renamed = names.values()
    assert (
        set(original)
        == set(renamed)
        == {
            "pitch_damping",
            "static_stability",
            "heave_damping",
            "control_power",
        }
    )
    assert renamed["pitch_damping"] == "parameter M_q changed by k"
    assert renamed["control_power"] == "parameter M_delta_e changed by k"
    assert renamed["static_stability"] == "parameter M_alpha changed by k"
