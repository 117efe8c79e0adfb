"""``ornitail demo``: the main job on the simulated rig, end to end.

Runs the study's tunnel protocol (the shipped plan) on the shipped simulated rig, faster than real time: wind-off
tares, the tailed steady state and sweeps, the tailless steady state (resumed, up to three times, when a host too
busy to read the board's link in time leaves a record lossy through its retakes); then processes the runs as
``ornitail process`` does (cycle averages, tail contribution, stability derivatives, plots) and prints the
steady-state loads with and without tail, their 2-sigma spread over cycles, the tail's contribution and the
derivatives with their sigma. Finally it flies a small simulated campaign, fits trends against tail geometry and
proposes a tail (:mod:`ornitail.app.demo_design`).
"""

from __future__ import annotations

import math
import sys
from importlib.resources import as_file, files
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from ornitail.app.cli_output import emit, json_option

if TYPE_CHECKING:
    import pandas as pd

# The sweep, processing, simulator and design modules (numpy, pandas, scipy, casadi, matplotlib, h5py) are
# imported inside the functions that use them: `ornitail --help` and `ornitail demo --help` stay fast.

DEMO_TIME_SCALE = 4.0
"""The simulated rig runs this many times faster than real time in the demo (the DAQ then streams 40 k
samples/s of wall time through a pty, which two cores sustain)."""

_PRINTED_LOADS = ("x_n", "z_n", "m_n_m")
_UNITS = {"x_n": "N", "z_n": "N", "m_n_m": "N m"}
AGREEMENT_SIGMAS = 2.0
"""An estimate agrees with the simulator's truth when it lies within this many of its own sigmas of it."""
CHANCE_BEYOND_TWO_SIGMA = 0.0455
"""Probability that a normal error lies beyond 2 of its sigmas."""


def _compared(estimate: float, sigma: float, truth: float, unit: str) -> dict[str, Any]:
    error_in_sigmas = (estimate - truth) / sigma if sigma > 0 else math.inf
    return {
        "unit": unit,
        "estimate": estimate,
        "sigma": sigma,
        "truth": truth,
        "error_in_sigmas": error_in_sigmas,
        "agrees": bool(abs(error_in_sigmas) <= AGREEMENT_SIGMAS),
    }


def _reference_or_set(contribution: dict[str, Any], reference: str, set_value: str) -> float:
    """The condition the repeats were moved to where the table has one, else the set value."""
    value = contribution.get(reference)
    return (
        float(value)
        if value is not None and math.isfinite(value)
        else float(contribution[set_value])
    )


def truth_comparison(
    table: pd.DataFrame,
    contribution: dict[str, Any],
    derivatives: dict[str, Any],
    steady_state: dict[str, float],
) -> dict[str, dict[str, Any]]:
    """The demo's tail contribution, steady-state loads (X0, Z0, M0) and derivatives against the simulator's
    truth for the same configuration and point (:func:`ornitail.sim.tunnel_truth.tunnel_truth`, the simulated
    rig's reference point); each entry with the error in the estimate's own sigmas.

    The tail's contribution is compared at the condition its repeats were moved to (the tailless repeats' pitch
    and velocity read during their records, :mod:`ornitail.balance.condition_correction`: the fan settles within
    its tolerance, not on the set value); X0, Z0, M0 and the derivatives at the set steady state, which the fit's
    intercept refers to."""
    from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, read_rig_file
    from ornitail.sim.configuration import study_configuration
    from ornitail.sim.tunnel_truth import LOAD_KEYS, tunnel_truth

    configuration = study_configuration(
        str(table["tail_id"].iloc[0]), float(table["x_h_mm"].iloc[0])
    )
    transform = read_rig_file(DEFAULT_RIG_FILE).tool_transform
    with_tail, without = (
        tunnel_truth(
            configuration,
            math.radians(_reference_or_set(contribution, "theta_reference_deg", "theta_deg")),
            _reference_or_set(contribution, "v_reference_m_s", "v_m_s"),
            contribution["f_set_hz"],
            tail_attached=state,
            reference_transform=transform,
        )
        for state in (True, False)
    )
    compared = {
        f"tail_{load}": _compared(
            contribution[key],
            contribution[f"{key}_sigma"],
            with_tail.loads[key] - without.loads[key],
            unit,
        )
        for load, key, unit in LOAD_KEYS
    }
    steady = tunnel_truth(
        configuration,
        math.radians(steady_state["theta_deg"]),
        steady_state["v_m_s"],
        steady_state["f_hz"],
        reference_transform=transform,
    )
    truths = {f"{load}0": steady.loads[key] for load, key, _ in LOAD_KEYS} | steady.derivatives
    for name, truth in truths.items():
        entry = derivatives.get(name)
        if isinstance(entry, dict) and "value" in entry:
            compared[name] = _compared(entry["value"], entry["sigma"], truth, entry.get("unit", ""))
    return compared


def _truth_lines(comparison: dict[str, dict[str, Any]]) -> list[str]:
    lines = [
        "",
        f"Against the simulator's truth (`ornitail sim tunnel`; agrees = within {AGREEMENT_SIGMAS:g} of its own "
        "sigmas):",
    ]
    lines.append(f"  {'':22s}{'estimate':>12s}{'1 sigma':>10s}{'truth':>12s}{'error/sigma':>13s}")
    for name, entry in comparison.items():
        label = f"{name.replace('tail_', 'tail ')} [{entry['unit']}]"
        verdict = "agrees" if entry["agrees"] else "DISAGREES"
        lines.append(
            f"  {label:22s}{entry['estimate']:>+12.4g}{entry['sigma']:>10.2g}{entry['truth']:>+12.4g}"
            f"{entry['error_in_sigmas']:>+13.1f}  {verdict}"
        )
    disagreeing = [name for name, entry in comparison.items() if not entry["agrees"]]
    expected = len(comparison) * CHANCE_BEYOND_TWO_SIGMA
    lines.append(
        f"  {len(disagreeing)} of {len(comparison)} lie beyond {AGREEMENT_SIGMAS:g} of their sigmas from the truth"
        + (f" ({', '.join(disagreeing)})" if disagreeing else "")
        + f"; about {expected:.1f} would by chance if every interval were honest"
    )
    return lines


def _steady_state_summary(table: pd.DataFrame) -> dict[str, Any]:
    from ornitail.balance.point_loads import BODY_LOAD_NAMES

    steady = table[table["sweep"] == "steady_state"]
    summary = {}
    for tailed, group in steady.groupby("tailed"):
        summary["tailed" if tailed else "tailless"] = {
            "records": len(group),
            "cycles": int(group["cycles"].sum()),
            "f_hall_hz": float(group["f_hall_hz"].mean()),
            **{name: float(group[name].mean()) for name in BODY_LOAD_NAMES},
            **{f"{name}_2sigma": float(group[f"{name}_2sigma"].mean()) for name in BODY_LOAD_NAMES},
        }
    return summary


def _render(result: dict[str, Any]) -> str:
    lines = [f"sweep {result['sweep']['status']}: {result['sweep']['message']}"]
    health = result["sweep"]["link_health"]
    lost = sum(run["samples_lost"] for run in health)
    retaken = sum(run["set_points_retaken"] for run in health)
    if (
        lost or retaken
    ):  # the link lost samples (a busy machine): say where, and that no record kept a gap
        whole = (
            "every kept record is whole"
            if result["sweep"]["status"] == "completed"
            else "see above"
        )
        lines.append(
            f"  link: {lost} samples lost over {len(health)} runs; {retaken} set point(s) recorded again "
            f"after losing samples inside their record ({whole})"
        )
    steady = result.get("steady_state", {})
    if steady:
        lines.append("")
        lines.append(
            "Steady state, cycle-averaged, body frame (docs/frames.md), mean +- 2 sigma over cycles:"
        )
        lines.append(
            f"{'':10s}"
            + "".join(f"{name + ' [' + _UNITS[name] + ']':>24s}" for name in _PRINTED_LOADS)
            + f"{'f_hall [Hz]':>14s}{'cycles':>8s}"
        )
        for state, values in steady.items():
            cells = "".join(
                f"{values[name]:>+13.6f} +-{values[name + '_2sigma']:<8.2g}"
                for name in _PRINTED_LOADS
            )
            lines.append(f"{state:10s}{cells}{values['f_hall_hz']:>14.2f}{values['cycles']:>8d}")
    contribution = result.get("tail_contribution")
    if contribution:
        cells = "".join(
            f"{contribution[name]:>+13.6f} +-{2 * contribution[name + '_sigma']:<8.2g}"
            for name in _PRINTED_LOADS
        )
        lines.append(f"{'tail':10s}{cells}   (tailed - tailless, +- 2 sigma of the mean)")
        if math.isfinite(contribution.get("v_reference_m_s", math.nan)):
            lines.append(
                f"  at theta {contribution['theta_reference_deg']:.2f} deg, V {contribution['v_reference_m_s']:.4f} "
                f"m/s (read during the tailless repeats; set {contribution['v_m_s']:.3f} m/s): every repeat moved "
                "there along the fitted derivatives"
            )
        resolvable = [name for name in _PRINTED_LOADS if contribution[f"{name}_resolvable"]]
        lines.append(
            "resolvable above the balance resolution and scatter: "
            + (", ".join(resolvable) if resolvable else "none")
        )
    if result.get("drift_statement"):
        lines.append(result["drift_statement"])
    derivatives = result.get("derivatives", {})
    if derivatives:
        lines.append("")
        lines.append(
            "Stability derivatives from the sweeps (tunnel, clamped: no q-derivatives), value +- 1 sigma:"
        )
        for name, entry in derivatives.items():
            if isinstance(entry, dict) and "value" in entry and name[-1] in "uwf":
                resolution = entry.get("resolution", "")
                lines.append(
                    f"  {name:3s} {entry['value']:+.4g} +- {entry['sigma']:.2g} {entry.get('unit', '')}"
                    + ("" if resolution.startswith("resolved") else f"   ({resolution})")
                )
    if result.get("repeatability_statement"):
        lines.append(result["repeatability_statement"])
    if result.get("truth"):
        lines += _truth_lines(result["truth"])
    if result.get("processed_folder"):
        lines.append(f"\nTables and plots: {result['processed_folder']}")
    design = result.get("design")
    if design:
        targets = design["targets"]
        lines.append("")
        lines.append(
            f"Tail proposal from the simulated flight campaign and the tunnel derivatives (target theta_ss "
            f"{targets['theta_ss_deg']:g} +- {targets['theta_tolerance_deg']:g} deg, damping ratio >= "
            f"{targets['damping_ratio_min']:g}, smallest area):"
        )
        from ornitail.design.proposal_report import render_proposal

        lines.append(render_proposal(design))
    return "\n".join(lines)


@click.command("demo")
@click.option(
    "--data-root",
    type=click.Path(path_type=Path),
    default=None,
    help="Where runs and the catalog live [default: $ORNITAIL_DATA or ./ornitail-data].",
)
@click.option(
    "--time-scale",
    type=float,
    default=DEMO_TIME_SCALE,
    show_default=True,
    help="How many times faster than real time the simulated rig runs.",
)
@json_option
def demo_command(data_root: Path | None, time_scale: float, as_json: bool) -> None:
    """Run the study's tunnel protocol on the simulated rig and print cycle-averaged forces."""
    import pandas as pd

    from ornitail.acquisition.catalog import default_data_root
    from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
    from ornitail.acquisition.sweep import resumed_while_incomplete
    from ornitail.app.demo_design import design_from_simulated_campaign
    from ornitail.app.sweep_session import (
        check_time_scale_option,
        exit_code_of,
        guarded,
        run_sweep_with_progress,
        sweep_result_record,
    )
    from ornitail.balance.process_runs import process_runs

    check_time_scale_option(time_scale)
    data_root = data_root or default_data_root()
    plan_resource = files("ornitail.acquisition") / "data" / "study_tunnel_plan.toml"
    with as_file(plan_resource) as plan_path:
        # A host too busy to read the board's link in time leaves a record lossy through its retakes; the demo
        # resumes the sweep for it, as a user would (the sweep's warning on stderr names the point).
        sweep = resumed_while_incomplete(
            lambda resume: guarded(
                lambda: run_sweep_with_progress(
                    plan_path, DEFAULT_RIG_FILE, data_root, resume=resume, time_scale=time_scale
                )
            )
        )
    result: dict[str, Any] = {"sweep": sweep_result_record(sweep)}
    if sweep.status == "completed":
        folder = Path(data_root) / "processed" / Path(sweep.run_directories[-1]).name
        processed = process_runs(sweep.run_directories, folder)
        table = pd.read_csv(processed["table_csv"])
        result["steady_state"] = _steady_state_summary(table)
        configuration = processed["configurations"][0]
        contribution = pd.DataFrame(configuration.get("tail_contribution", []))
        if len(contribution):
            result["tail_contribution"] = contribution.iloc[0].to_dict()
        result["drift_statement"] = configuration.get("drift_statement", "")
        derivatives = configuration.get("derivatives", {})
        result["derivatives"] = derivatives.get("derivatives", {})
        result["repeatability_statement"] = derivatives.get("repeatability_statement", "")
        if "tail_contribution" in result and "steady_state" in derivatives:
            result["truth"] = truth_comparison(
                table,
                result["tail_contribution"],
                result["derivatives"],
                derivatives["steady_state"],
            )
        result["table_csv"] = processed["table_csv"]
        result["processed_folder"] = str(folder)
        tunnel_derivatives = sorted(folder.glob("*-derivatives.json"))
        result["design"] = design_from_simulated_campaign(folder, tunnel_derivatives)
    emit(result, as_json, _render)
    sys.exit(exit_code_of(sweep))
