"""Tail contribution (tailed minus tailless): recovered against the simulator, pooled honestly, stated plainly."""

import math
import tomllib
from importlib.resources import files

import numpy as np
import pandas as pd
import pytest

from ornitail.acquisition.sweep_plan import plan_from_document
from ornitail.balance.sweep_table import BALANCE_RESOLUTION_N, tail_contribution
from ornitail.balance.tail_statement import repeatability_statement, tail_contribution_statements
from ornitail.sim.effects import EffectSet

LOADS = ("x_n", "z_n", "m_n_m")


def steady_state_only_plan():
    """The shipped plan's steady state, tailed and tailless, 3 repeats each, 0.6 s records, no sweeps."""
    document = tomllib.loads(
        (files("ornitail.acquisition") / "data" / "study_tunnel_plan.toml").read_text()
    )
    document.pop("sweeps")
    document["protocol"]["record_s"] = 0.6
    return plan_from_document(document)


def test_tail_contribution_covers_the_simulator_truth(make_simulated_sweep):
    sweep = make_simulated_sweep(
        plan=steady_state_only_plan(), effects=EffectSet.none().with_enabled("balance_resolution")
    )
    plan = sweep.plan
    point = (plan.theta0_rad, plan.velocity0_m_s, plan.frequency0_hz)
    # Both about the same reference point (the tailed CG), so tailless M includes the CG shift's lever.
    truth = sweep.truth(*point, tailed=True) - sweep.truth(*point, tailed=False)
    scores = []
    for seed in range(10):
        contribution = tail_contribution(sweep.table(seed))
        assert len(contribution) == 1
        row = contribution.iloc[0]
        assert row["repeats_tailed"] == row["repeats_tailless"] == 3
        scores.append(
            [(row[name] - truth[index]) / row[f"{name}_sigma"] for index, name in enumerate(LOADS)]
        )
    scores = np.array(scores)
    # 30 intervals at nominal 95 %: at least 25 covered (binomial probability of fewer is below 1 %).
    assert (np.abs(scores) <= 2).sum() >= 25
    # The simulated S3 tail adds of order 0.01 N along x_b (docs/background.md: 0.01-0.03 N): resolvable on the balance.
    assert truth[0] > 3 * BALANCE_RESOLUTION_N


def repeat_table(means_by_state, se=1e-5, tare_se=2e-5, two_sigma=1e-3):
    """A cycle-averaged table of repeats at one point: ``means_by_state[tailed]`` lists the repeat means; the
    repeats of a state share one tare."""
    rows = []
    for tailed, means in means_by_state.items():
        for repeat, mean in enumerate(means):
            row = {
                "tailed": tailed,
                "repeat": repeat,
                "theta_deg": 25.0,
                "v_m_s": 0.8,
                "f_set_hz": 13.5,
                "tare_id": f"tare-{tailed}",
            }
            row["cycles"] = 26
            for name in ("x_n", "y_n", "z_n", "l_n_m", "m_n_m", "n_n_m"):
                row.update({name: mean, f"{name}_se": se, f"{name}_tare_se": tare_se})
                row[f"{name}_2sigma"] = two_sigma
            rows.append(row)
    return pd.DataFrame(rows)


def test_repeats_pool_with_the_shared_tare_and_carry_the_scatter_they_show_beyond_their_errors():
    consistent = tail_contribution(repeat_table({True: [0.1, 0.1, 0.1], False: [0.09, 0.09, 0.09]}))
    # Repeats agree: sigma per state = sqrt(3 se^2 / 9 + tare_se^2) (the three share one tare), then in quadrature.
    per_state = math.sqrt(3 * 1e-5**2 / 9 + 2e-5**2)
    assert consistent.loc[0, "x_n"] == pytest.approx(0.01)
    assert consistent.loc[0, "x_n_sigma"] == pytest.approx(math.sqrt(2) * per_state)
    assert consistent.loc[0, "x_n_repeat_inflation_tailed"] == 1.0
    assert repeatability_statement(consistent).endswith(
        "agree within their errors (no sigma inflated)."
    )
    # Scatter of about one stated error (chi-square 2 on 2 degrees of freedom, p = 0.37): no inflation.
    within = tail_contribution(
        repeat_table({True: [0.1 - 1e-5, 0.1, 0.1 + 1e-5], False: [0.09, 0.09, 0.09]})
    )
    assert within.loc[0, "x_n_repeat_chi_square_tailed"] == pytest.approx(2.0)
    assert within.loc[0, "x_n_sigma"] == pytest.approx(math.sqrt(2) * per_state)
    scattered = tail_contribution(
        repeat_table({True: [0.099, 0.1, 0.101], False: [0.09, 0.09, 0.09]})
    )
    # Tailed repeats scatter by 1e-3 (sd), far beyond their stated 1e-5: chi-square 2e4 on 2, the tailless ones 0
    # on 2. The record variance s^2 brings the joint chi-square 2e-6 / (se^2 + s^2) to its 4 degrees of freedom:
    # se^2 + s^2 = 5e-7. Both states' repeats carry it (the rig's records, not the tail's); the shared tare stays.
    assert scattered.loc[0, "x_n_repeat_chi_square_tailed"] == pytest.approx(2e4)
    assert scattered.loc[0, "x_n_repeat_chi_square_tailless"] == pytest.approx(0.0, abs=1e-9)
    assert scattered.loc[0, "x_n_record_scatter"] == pytest.approx(
        math.sqrt(5e-7 - 1e-10), rel=1e-6
    )
    with_scatter = math.sqrt(5e-7 / 3 + 2e-5**2)
    assert scattered.loc[0, "x_n_sigma"] == pytest.approx(math.sqrt(2) * with_scatter, rel=1e-6)
    assert scattered.loc[0, "x_n_repeat_inflation_tailless"] == pytest.approx(
        with_scatter / per_state, rel=1e-6
    )
    statement = repeatability_statement(scattered)
    assert (
        "X at theta 25.00 deg by 0.00071 N per record (chi-square 20000.0 on 2 tailed, 0.0 on 2"
        in statement
    )
    assert "Z at theta" in statement and "added to each repeat's error" in statement


@pytest.mark.parametrize(
    ("tailed_mean", "verdict"),
    [
        (0.0 + 0.5 * BALANCE_RESOLUTION_N, "NOT resolvable: below the balance resolution"),
        (0.0 + 10 * BALANCE_RESOLUTION_N, "RESOLVABLE, but only in the mean"),
        (0.0 + 1.0, "RESOLVABLE."),
    ],
)
def test_statement_weighs_resolution_uncertainty_and_cycle_scatter(tailed_mean, verdict):
    # Single cycles scatter by 0.05 N (2 sigma): a 0.015 N tail shows only in the mean over many cycles.
    table = repeat_table(
        {True: [tailed_mean] * 3, False: [0.0] * 3}, se=1e-6, tare_se=1e-6, two_sigma=0.05
    )
    lines = tail_contribution_statements(tail_contribution(table))
    x_line = next(line for line in lines if line.startswith("X "))
    assert verdict in x_line
    assert "balance resolution (0.00146 N)" in x_line


def test_difference_below_twice_its_sigma_is_not_resolvable_even_above_resolution():
    table = repeat_table({True: [0.003] * 3, False: [0.0] * 3}, se=1e-3, tare_se=1e-3)
    contribution = tail_contribution(table)
    assert not contribution.loc[0, "x_n_resolvable"]
    x_line = next(
        line for line in tail_contribution_statements(contribution) if line.startswith("X ")
    )
    assert "below the measurement uncertainty" in x_line and "balance resolution" in x_line


def test_the_returns_to_reference_are_left_out_of_the_tail_difference():
    """The tail's difference is between the interleaved steady-state repeats; the returns to the steady state after
    each sweep (all in the first tailed run) do not enter it, however far off they sit."""
    table = repeat_table({True: [0.1, 0.1, 0.1], False: [0.09, 0.09, 0.09]}).assign(
        sweep="steady_state"
    )
    returns = table[table["tailed"]].assign(sweep="reference", x_n=0.2, tare_id="tare-first-run")
    with_returns = tail_contribution(pd.concat([table, returns], ignore_index=True))
    assert with_returns.loc[0, "x_n"] == pytest.approx(0.01)
    assert with_returns.loc[0, "repeats_tailed"] == 3
    pd.testing.assert_frame_equal(with_returns, tail_contribution(table))
