"""Blind diagnosis of a tunnel sweep table whose withheld effect is known."""

import pytest

from ornitail.gap.example_data import write_tunnel_example
from ornitail.gap.model_spec import read_baseline_spec
from ornitail.gap.tunnel_diagnosis import diagnose_tunnel


@pytest.mark.parametrize("effect", ["strut_interference", "cg_shift_with_x_h"])
def test_withheld_tunnel_effect_is_named_with_its_size(tmp_path, effect):
    data, model = write_tunnel_example({effect: 1.0}, "S3", seed=4, folder=tmp_path)
    report = diagnose_tunnel(read_baseline_spec(model), [data], seed=2).report
    assert report["effect"] == effect
    # the data hold the simulator's effect at k = 1; a linear step in k fits it to a few %
    assert report["magnitude"]["value"] == pytest.approx(1.0, abs=0.15)
    assert report["gap_after"]["total"] < 0.5 * report["gap_before"]["total"]


def test_strut_interference_residual_follows_the_tail_position(tmp_path):
    data, model = write_tunnel_example({"strut_interference": 1.0}, "S3", seed=4, folder=tmp_path)
    where = diagnose_tunnel(read_baseline_spec(model), [data], seed=2).report["where"]
    moment = where["by_configuration"]["x_h"]["per_load"]["m_n_m"]
    assert abs(moment["correlation"]) > 0.8 and moment["p_value"] < 1e-6
    assert where["by_configuration"]["S"] == {"varies": False}


def test_tunnel_data_without_an_effect_give_none(tmp_path):
    data, model = write_tunnel_example({}, "S3", seed=4, folder=tmp_path)
    report = diagnose_tunnel(read_baseline_spec(model), [data], seed=2).report
    assert report["verdict"] == "none"
