"""The tunnel diagnosis reads recorded run directories as ``ornitail process`` would tabulate them."""

import pandas as pd
import pytest

from ornitail.acquisition.sweep import run_sweep_to_completion
from ornitail.acquisition.sweep_plan import plan_from_document
from ornitail.balance.sweep_table import cycle_averaged_table
from ornitail.gap.tunnel_data import is_tunnel_table, read_tunnel_points

PLAN = {
    "plan": {"name": "gap-recorded"},
    "configuration": {"tail_id": "S3", "x_h_mm": 98},
    "steady_state": {"theta_deg": 25.0, "v_m_s": 0.8, "f_hz": 13.5},
    "sweeps": {"theta_deg": [-3.0, 3.0], "v_m_s": [-0.2, 0.2], "f_hz": [-1.0, 1.0]},
    "protocol": {
        "steady_state_repeats": 1,
        "record_s": 0.6,
        "tailless_points": "steady_state",
        "sample_rate_hz": 2000.0,
    },
    "settle": {"stable_for_s": 0.3, "timeout_s": 60},
}


@pytest.fixture
def simulated_time_scale():
    return 10.0  # as tests/acquisition/test_sweep.py: 2 kHz x 10, 20 k frames/s on the pty


def test_run_directories_give_the_same_points_as_their_processed_table(simulated_rig, tmp_path):
    # resumed where a busy host lost samples through a record's retakes (the chain holds every point once)
    result = run_sweep_to_completion(plan_from_document(PLAN, "plan.toml"), simulated_rig, tmp_path)
    assert result.status == "completed"
    runs = result.run_directories
    table_path = tmp_path / "cycle-averages.csv"
    cycle_averaged_table(runs).to_csv(table_path, index=False)
    assert all(is_tunnel_table(run) for run in runs) and is_tunnel_table(table_path)
    assert not is_tunnel_table(tmp_path)  # the data root is not a run
    from_runs = read_tunnel_points(runs).drop(columns="source")
    from_table = read_tunnel_points([table_path]).drop(columns="source")
    assert len(from_runs) == 7  # tailed points only: steady state and six sweep points
    pd.testing.assert_frame_equal(from_runs, from_table, check_exact=False, rtol=1e-12)
