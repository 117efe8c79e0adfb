"""Benchmark: coverage of the campaign's 95 % intervals on the simulator's nonlinear free flights.

For each seed, the free-flight campaign (``ornitail.flight.campaign.run_campaign``, exactly as
``ornitail flight campaign --simulate TAIL@X_H --manoeuvres N`` runs it) flies every tail in the
simulator (512 Hz log, 65 % elevator doublets, gusts, flap ripple, sensor noise), filters and cuts
the manoeuvres, identifies each with the campaign's model (``--model``, default the campaign's:
``delfly_longitudinal_bias``, the study's model with nuisance biases; ``delfly_longitudinal`` is
the study's own), validates, rejects, averages and picks a representative model. The truth is the
simulator's linearisation about its trim, ``ornitail.sim.dynamics.linearise(study_configuration(
tail, x_h_mm))``, whose derivatives have the preset's names, frame (docs/frames.md) and SI units
(N m s/rad, N s, N s/m, N m/rad, N/rad). Nuisance biases have no truth and are not counted.

Printed, for four standard errors of every converged manoeuvre model, each evaluated at the same
estimate with the library's functions:

- ``morelli``: SIDPAC ``m_colores`` (full-lag unbiased residual correlation), the campaign's
  default;
- ``morelli_small_sample``: ``m_colores`` times N_eff / (N_eff - p) (``OutputErrorOptions(
  colored_sigma="morelli_small_sample")``; docs/flight-campaign.md);
- ``tapered``: the Bartlett-tapered estimate up to lag N/10 (``colored_sigma="tapered"``);
- ``cramer_rao``: the Cramer-Rao bound (inverse Fisher information);

the coverage of value +- 1.96 sigma per parameter and tail and pooled (with a 95 % interval that
treats each flight as a cluster: manoeuvres of one flight and parameters of one manoeuvre are
correlated), the RMS and mean of the sigma-normalised errors z = (value - truth) / sigma (RMS 1 and
mean 0 for calibrated, unbiased intervals), and the coverage of the representative model's
intervals (its covariance recomputed for each sigma kind: the mean model's comes from the spread
and is the same for all). An interval whose variance came out negative (sigma NaN) counts as not
covering. Targets, judged on the sigma the campaign used (``--colored-sigma``): pooled coverage
0.90-0.98; the representative intervals cover Mq, Mde, Xu and Mu at least 90 % of the time. Exit
code 0 when met, 1 when not, 2 for a bad option.

Run: ``.venv/bin/python benchmarks/flight_coverage.py --seeds 40 --tails S1,S5 --manoeuvres 20``
(12 s per flight of 20 manoeuvres on this 2-core machine when idle, 23-27 s under a load
average of 4-6; the whole run 15-35 min).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.core.normal_quantiles import NORMAL_QUANTILE_95
from ornitail.flight.averaged_models import (
    covariance_weighted_mean,
    time_averaged_response,
)
from ornitail.flight.campaign import ConfigurationResult, run_campaign
from ornitail.flight.campaign_file import (
    DEFAULT_CAMPAIGN_COLORED_SIGMA,
    DEFAULT_CAMPAIGN_MODEL,
    CampaignSpec,
    configuration_from_label,
)
from ornitail.flight.identification_result import IdentificationResult
from ornitail.flight.model_data import model_data
from ornitail.flight.output_error import OutputErrorProblem, noise_variances
from ornitail.flight.residual_statistics import (
    COLORED_SIGMA_METHODS,
    colored_residual_covariance,
    morelli_colored_covariance,
    small_sample_factor,
)
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import linearise

SIGMA_KINDS = ("morelli", "morelli_small_sample", "tapered", "cramer_rao")
TARGET_POOLED = (0.90, 0.98)
REPRESENTATIVE_TARGET_PARAMETERS = ("Mq", "Mde", "Xu", "Mu")
REPRESENTATIVE_TARGET = 0.90


def covariances_at_estimate(
    result: IdentificationResult, data, kinds: Sequence[str] = SIGMA_KINDS
) -> dict[str, np.ndarray]:
    """Parameter covariance of an output-error result for every kind of ``kinds`` (default
    :data:`SIGMA_KINDS`: ``morelli``, ``morelli_small_sample``, ``tapered``, ``cramer_rao``),
    evaluated at its estimate on the data it was fitted to, for its derivatives (nuisance
    parameters dropped: the marginal covariance; parameter units squared).

    Each is what ``estimate_output_error`` computes at convergence with
    ``OutputErrorOptions(colored_sigma=kind)``; the estimate itself does not depend on it.
    ``morelli_small_sample`` is ``morelli`` times the small-sample factor, as
    :func:`~ornitail.flight.residual_statistics.colored_residual_covariance` computes it; ``morelli``
    is formed once for both.
    """
    spec = result.model
    signals = model_data(spec, data)
    problem = OutputErrorProblem(spec, signals, result.parameter_values())
    theta = result.parameter_vector()
    if problem.estimates_initial_state:
        theta = np.concatenate([theta, result.initial_state])
    outputs, sensitivities = problem.outputs_and_sensitivities(theta)
    residuals = signals.outputs - outputs
    weights = 1.0 / noise_variances(residuals, signals.outputs)
    information = np.einsum("koi,o,koj->ij", sensitivities, weights, sensitivities)
    indices = [
        index for index, name in enumerate(result.parameter_names) if name in spec.derivative_names
    ]
    covariances = {}
    morelli = None
    for kind in kinds:
        if kind == "cramer_rao":
            covariance = np.linalg.inv(information)
        elif kind in ("morelli", "morelli_small_sample"):
            if morelli is None:
                morelli = morelli_colored_covariance(
                    sensitivities * weights[None, :, None], residuals, information
                )
            covariance = morelli
            if kind == "morelli_small_sample":
                covariance = morelli * small_sample_factor(residuals, information.shape[0])
        else:
            covariance = colored_residual_covariance(
                sensitivities * weights[None, :, None], residuals, information, kind
            )
        covariances[kind] = covariance[np.ix_(indices, indices)]
    return covariances


def standard_errors(covariance: np.ndarray) -> np.ndarray:
    """sqrt of the diagonal; NaN where the variance is negative (no interval can be formed)."""
    diagonal = np.diag(covariance)
    return np.sqrt(np.where(diagonal >= 0, diagonal, np.nan))


@dataclass
class FlightRecord:
    """One flight (tail, seed) of the campaign: per-manoeuvre estimates and the three sigma
    kinds, the representative model's values and sigmas, and the truth (SI units).
    """

    tail: str
    seed: int
    names: tuple[str, ...]
    truth: np.ndarray  # (p,)
    values: np.ndarray  # (k, p) converged manoeuvre models
    sigmas: dict[str, np.ndarray]  # kind -> (k, p)
    accepted: np.ndarray  # (k,) bool: passed validation
    manoeuvres: int
    diverged: int
    representative: str
    representative_values: dict[str, np.ndarray] = field(default_factory=dict)  # kind -> (p,)
    representative_sigmas: dict[str, np.ndarray] = field(default_factory=dict)  # kind -> (p,)
    seconds: float = 0.0


def representative_estimates(
    result: ConfigurationResult, covariances: dict[str, list[np.ndarray]]
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Values and sigmas of the representative model with its covariance for each sigma kind.

    ``mean``: spread of the training estimates (one covariance for all kinds). ``weighted``:
    the covariance-weighted mean of the training estimates with each kind's covariances (the
    values change with the weights). ``time_averaged``: the time-averaged response's fit with
    each kind's covariance.
    """
    representative = result.representative
    values: dict[str, np.ndarray] = {}
    sigmas: dict[str, np.ndarray] = {}
    if representative.name == "time_averaged":
        data = time_averaged_response([result.models[i].manoeuvre for i in result.training])
        time_averaged = covariances_at_estimate(representative.result, data)
    for kind in SIGMA_KINDS:
        if representative.name == "mean":
            values[kind] = representative.estimate.values
            sigmas[kind] = standard_errors(representative.estimate.covariance)
        elif representative.name == "weighted":
            merged = covariance_weighted_mean(
                np.array([result.models[i].values for i in result.training]),
                [covariances[kind][i] for i in result.training],
            )
            values[kind], sigmas[kind] = merged.values, standard_errors(merged.covariance)
        else:
            values[kind] = representative.estimate.values
            sigmas[kind] = standard_errors(time_averaged[kind])
    return values, sigmas


def flight_record(result: ConfigurationResult, tail: str, seed: int, truth: dict) -> FlightRecord:
    """Collect one configuration's manoeuvre models and representative model."""
    names = result.models[0].parameter_names
    covariances: dict[str, list[np.ndarray]] = {kind: [] for kind in SIGMA_KINDS}
    for model in result.models:
        at_estimate = covariances_at_estimate(model.result, model.manoeuvre.deviations)
        for kind in SIGMA_KINDS:
            covariances[kind].append(at_estimate[kind])
    accepted = np.zeros(len(result.models), dtype=bool)
    accepted[result.accepted] = True
    values, sigmas = representative_estimates(result, covariances)
    return FlightRecord(
        tail=tail,
        seed=seed,
        names=names,
        truth=np.array([truth[name] for name in names]),
        values=np.array([model.values for model in result.models]),
        sigmas={
            kind: np.array([standard_errors(c) for c in covariances[kind]]) for kind in SIGMA_KINDS
        },
        accepted=accepted,
        manoeuvres=result.manoeuvre_count,
        diverged=len(result.diverged),
        representative=result.representative.name,
        representative_values=values,
        representative_sigmas=sigmas,
    )


def fly(
    tails: Sequence[str],
    x_h_mm: float,
    manoeuvres: int,
    seed: int,
    model: str = DEFAULT_CAMPAIGN_MODEL,
    colored_sigma: str = DEFAULT_CAMPAIGN_COLORED_SIGMA,
) -> tuple[list[FlightRecord], float]:
    """One simulated campaign over ``tails`` (tail i flies with seed ``seed + i``; split seed
    ``seed``), its flight records and its wall time (s).
    """
    campaign = CampaignSpec(
        tuple(
            configuration_from_label(
                f"{tail}@{x_h_mm:g}", "benchmark", simulated_manoeuvres=manoeuvres
            )
            for tail in tails
        ),
        seed=seed,
        model=model,
        colored_sigma=colored_sigma,
    )
    began = time.perf_counter()
    results = run_campaign(campaign)
    records = []
    for index, (tail, result) in enumerate(zip(tails, results, strict=True)):
        truth = linearise(study_configuration(tail, x_h_mm)).derivatives
        records.append(flight_record(result, tail, seed + index, truth))
    elapsed = time.perf_counter() - began
    for record in records:
        record.seconds = elapsed / len(records)
    return records, elapsed


def clustered_coverage(covered: Sequence[np.ndarray]) -> dict[str, float]:
    """Pooled coverage of boolean arrays, one per cluster (flight), and its 95 % interval from
    the between-cluster scatter (ratio estimator; correlation inside a cluster is allowed).
    """
    hits = np.array([np.count_nonzero(c) for c in covered], dtype=float)
    counts = np.array([c.size for c in covered], dtype=float)
    total = counts.sum()
    if total == 0:
        return {"coverage": math.nan, "low": math.nan, "high": math.nan, "intervals": 0}
    coverage = hits.sum() / total
    clusters = len(covered)
    if clusters > 1:
        spread = np.sum((hits - coverage * counts) ** 2) * clusters / (clusters - 1)
        error = math.sqrt(spread) / total
    else:
        error = math.nan
    return {
        "coverage": float(coverage),
        "low": float(coverage - NORMAL_QUANTILE_95 * error),
        "high": float(coverage + NORMAL_QUANTILE_95 * error),
        "intervals": int(total),
    }


def normalised_errors(record: FlightRecord, kind: str) -> np.ndarray:
    """z = (value - truth) / sigma, (k, p); NaN where sigma is NaN."""
    return (record.values - record.truth) / record.sigmas[kind]


def covered(record: FlightRecord, kind: str, rows: np.ndarray | None = None) -> np.ndarray:
    """|z| <= 1.96 per manoeuvre and parameter (NaN sigma: not covered)."""
    z = normalised_errors(record, kind)
    if rows is not None:
        z = z[rows]
    with np.errstate(invalid="ignore"):
        return np.abs(z) <= NORMAL_QUANTILE_95


def summarise(
    records: list[FlightRecord], tails: Sequence[str], campaign_kind: str = "morelli"
) -> dict:
    """Coverage and normalised-error figures of all flights (see the module docstring); the
    targets are judged on ``campaign_kind``, the sigma the campaign itself used.
    """
    names = records[0].names
    groups = {tail: [r for r in records if r.tail == tail] for tail in tails}
    groups["all"] = records
    per_manoeuvre: dict[str, dict] = {}
    for kind in SIGMA_KINDS:
        kind_summary: dict[str, dict] = {"parameters": {}, "pooled": {}, "pooled_accepted": {}}
        for group, members in groups.items():
            kind_summary["pooled"][group] = clustered_coverage([covered(r, kind) for r in members])
            kind_summary["pooled_accepted"][group] = clustered_coverage(
                [covered(r, kind, r.accepted) for r in members]
            )
        for index, name in enumerate(names):
            parameter: dict[str, dict] = {}
            for group, members in groups.items():
                z = np.concatenate([normalised_errors(r, kind)[:, index] for r in members])
                finite = z[np.isfinite(z)]
                parameter[group] = {
                    **clustered_coverage([covered(r, kind)[:, index] for r in members]),
                    "rms_z": float(np.sqrt(np.mean(finite**2))) if finite.size else math.nan,
                    "mean_z": float(np.mean(finite)) if finite.size else math.nan,
                    "nan_sigmas": int(np.count_nonzero(~np.isfinite(z))),
                }
            kind_summary["parameters"][name] = parameter
        per_manoeuvre[kind] = kind_summary

    representative: dict[str, dict] = {}
    for kind in SIGMA_KINDS:
        by_parameter: dict[str, dict] = {}
        for index, name in enumerate(names):
            by_parameter[name] = {}
            for group, members in groups.items():
                z = np.array(
                    [
                        (r.representative_values[kind][index] - r.truth[index])
                        / r.representative_sigmas[kind][index]
                        for r in members
                    ]
                )
                with np.errstate(invalid="ignore"):
                    hits = np.abs(z) <= NORMAL_QUANTILE_95
                finite = z[np.isfinite(z)]
                by_parameter[name][group] = {
                    "coverage": float(np.mean(hits)),
                    "flights": len(members),
                    "rms_z": float(np.sqrt(np.mean(finite**2))) if finite.size else math.nan,
                }
        representative[kind] = by_parameter

    relative_bias = {}
    for index, name in enumerate(names):
        relative_bias[name] = {}
        for group, members in groups.items():
            errors = np.concatenate([r.values[:, index] - r.truth[index] for r in members])
            truth = members[0].truth[index] if group != "all" else math.nan
            relative_bias[name][group] = {
                "mean_error": float(np.mean(errors)),
                "sd_error": float(np.std(errors, ddof=1)),
                "truth": float(truth),
            }

    chosen = {
        group: {
            name: sum(r.representative == name for r in members)
            for name in ("mean", "weighted", "time_averaged")
        }
        for group, members in groups.items()
    }
    pooled = per_manoeuvre[campaign_kind]["pooled"]["all"]["coverage"]
    representative_worst = min(
        representative[campaign_kind][name]["all"]["coverage"]
        for name in REPRESENTATIVE_TARGET_PARAMETERS
    )
    targets = {
        "pooled_colored_coverage_0_90_to_0_98": TARGET_POOLED[0] <= pooled <= TARGET_POOLED[1],
        "representative_covers_Mq_Mde_Xu_Mu_90_percent": representative_worst
        >= REPRESENTATIVE_TARGET,
    }
    per_flight = [
        {
            "tail": r.tail,
            "seed": r.seed,
            "converged": len(r.values),
            "diverged": r.diverged,
            "representative": r.representative,
            "coverage": {kind: float(np.mean(covered(r, kind))) for kind in SIGMA_KINDS},
        }
        for r in records
    ]
    flight_scatter = {
        tail: float(
            np.std([f["coverage"][campaign_kind] for f in per_flight if f["tail"] == tail], ddof=1)
        )
        if len(groups[tail]) > 1
        else math.nan
        for tail in tails
    }
    return {
        "parameters": list(names),
        "flights": len(records),
        "per_flight": per_flight,
        "campaign_sigma": campaign_kind,
        "flight_to_flight_sd_of_campaign_sigma_coverage": flight_scatter,
        "manoeuvres": int(sum(r.manoeuvres for r in records)),
        "converged": int(sum(len(r.values) for r in records)),
        "diverged": int(sum(r.diverged for r in records)),
        "accepted": int(sum(np.count_nonzero(r.accepted) for r in records)),
        "per_manoeuvre": per_manoeuvre,
        "errors": relative_bias,
        "representative": representative,
        "representative_chosen": chosen,
        "targets": targets,
        "all_targets_met": all(targets.values()),
    }


def run(
    seeds: int,
    tails: Sequence[str],
    manoeuvres: int,
    first_seed: int,
    x_h_mm: float,
    model: str = DEFAULT_CAMPAIGN_MODEL,
    colored_sigma: str = DEFAULT_CAMPAIGN_COLORED_SIGMA,
) -> dict:
    """Fly ``seeds`` campaigns (campaign i: seed ``first_seed + len(tails) * i``) and summarise."""
    records: list[FlightRecord] = []
    began = time.perf_counter()
    campaign_seconds = []
    for number in range(seeds):
        flown, elapsed = fly(
            tails, x_h_mm, manoeuvres, first_seed + len(tails) * number, model, colored_sigma
        )
        records += flown
        campaign_seconds.append(elapsed)
        print(
            f"seed {number + 1}/{seeds}: {elapsed:.1f} s",
            file=sys.stderr,
            flush=True,
        )
    summary = summarise(records, tails, colored_sigma)
    total = time.perf_counter() - began
    summary.update(
        {
            "seeds": seeds,
            "tails": list(tails),
            "x_h_mm": x_h_mm,
            "manoeuvres_per_flight": manoeuvres,
            "first_seed": first_seed,
            "model": model,
            "colored_sigma": colored_sigma,
            "wall_s": total,
            "s_per_seed": float(np.mean(campaign_seconds)),
            "s_per_flight": total / len(records),
        }
    )
    return summary


def render(summary: dict) -> str:
    """The printed report of :func:`run`'s summary."""
    tails = summary["tails"]
    groups = [*tails, "all"]
    lines = [
        f"{summary['seeds']} seeds x {','.join(tails)} at x_h = {summary['x_h_mm']:g} mm, "
        f"{summary['manoeuvres_per_flight']} manoeuvres per flight: {summary['manoeuvres']} "
        f"manoeuvres, {summary['converged']} converged models ({summary['diverged']} diverged), "
        f"{summary['accepted']} accepted",
        "truth: the simulator's linearisation about its trim; interval value +- 1.96 sigma",
    ]
    for kind in SIGMA_KINDS:
        block = summary["per_manoeuvre"][kind]
        lines.append("")
        lines.append(f"per-manoeuvre coverage, sigma = {kind}")
        header = f"{'':6s}" + "".join(f"{'cover ' + g:>12s}" for g in groups)
        header += "".join(f"{'rms z ' + t:>11s}" for t in tails)
        header += "".join(f"{'mean z ' + t:>11s}" for t in tails)
        header += f"{'NaN':>5s}"
        lines.append(header)
        for name in summary["parameters"]:
            entry = block["parameters"][name]
            row = f"{name:6s}" + "".join(f"{entry[g]['coverage']:12.3f}" for g in groups)
            row += "".join(f"{entry[t]['rms_z']:11.2f}" for t in tails)
            row += "".join(f"{entry[t]['mean_z']:11.2f}" for t in tails)
            row += f"{entry['all']['nan_sigmas']:5d}"
            lines.append(row)
        for label, key in (("pooled", "pooled"), ("accepted only", "pooled_accepted")):
            pooled = block[key]
            lines.append(
                f"{label}: "
                + ", ".join(
                    f"{g} {pooled[g]['coverage']:.3f} [{pooled[g]['low']:.3f}, "
                    f"{pooled[g]['high']:.3f}] of {pooled[g]['intervals']}"
                    for g in groups
                )
            )
    lines.append(
        f"flight-to-flight sd of the pooled {summary['campaign_sigma']} coverage: "
        + ", ".join(
            f"{t} {summary['flight_to_flight_sd_of_campaign_sigma_coverage'][t]:.3f}" for t in tails
        )
    )
    lines.append("")
    chosen = summary["representative_chosen"]
    lines.append(
        "representative model chosen: "
        + "; ".join(
            f"{t} " + ", ".join(f"{name} {count}" for name, count in chosen[t].items())
            for t in tails
        )
    )
    lines.append("representative model coverage (flights covered / flights)")
    lines.append(
        f"{'':6s}" + "".join(f"{kind + ' ' + t:>16s}" for kind in SIGMA_KINDS for t in groups)
    )
    for name in summary["parameters"]:
        lines.append(
            f"{name:6s}"
            + "".join(
                f"{summary['representative'][kind][name][t]['coverage']:16.3f}"
                for kind in SIGMA_KINDS
                for t in groups
            )
        )
    lines.append("")
    lines.append("mean error of the manoeuvre estimates against the truth (SI), per tail")
    for name in summary["parameters"]:
        lines.append(
            f"{name:6s}"
            + "".join(
                f"  {t}: truth {summary['errors'][name][t]['truth']: .3e} mean error "
                f"{summary['errors'][name][t]['mean_error']: .2e} sd {summary['errors'][name][t]['sd_error']:.2e}"
                for t in tails
            )
        )
    lines.append("")
    lines.append(
        f"time: {summary['wall_s']:.0f} s, {summary['s_per_seed']:.1f} s per seed "
        f"({summary['s_per_flight']:.1f} s per flight of {summary['manoeuvres_per_flight']} "
        "manoeuvres)"
    )
    for name, met in summary["targets"].items():
        lines.append(f"target {name}: {'met' if met else 'MISSED'}")
    return "\n".join(lines)


def without_nan(value):
    """``value`` with every NaN float replaced by None (strict JSON has no NaN)."""
    if isinstance(value, dict):
        return {key: without_nan(item) for key, item in value.items()}
    if isinstance(value, list):
        return [without_nan(item) for item in value]
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=40, help="campaigns flown (default 40)")
    parser.add_argument("--tails", default="S1,S5", help="study tails, comma-separated")
    parser.add_argument("--manoeuvres", type=int, default=20, help="doublets per flight")
    parser.add_argument("--x-h-mm", type=float, default=98.0, help="tail position, mm")
    parser.add_argument("--first-seed", type=int, default=2018, help="seed of the first campaign")
    parser.add_argument(
        "--model",
        default=DEFAULT_CAMPAIGN_MODEL,
        help=f"model preset name or file (default the campaign's, {DEFAULT_CAMPAIGN_MODEL})",
    )
    parser.add_argument(
        "--colored-sigma",
        default=DEFAULT_CAMPAIGN_COLORED_SIGMA,
        choices=COLORED_SIGMA_METHODS,
        help=f"the campaign's sigma formula (default {DEFAULT_CAMPAIGN_COLORED_SIGMA}); "
        "the targets are judged on it",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    arguments = parser.parse_args(argv)
    tails = [tail.strip() for tail in arguments.tails.split(",") if tail.strip()]
    if not 1 <= arguments.seeds <= 1000 or not tails:
        print("flight_coverage.py: --seeds must be 1..1000 and --tails non-empty", file=sys.stderr)
        return 2
    if not 3 <= arguments.manoeuvres <= 200:
        print("flight_coverage.py: --manoeuvres must be 3..200", file=sys.stderr)
        return 2
    try:
        summary = run(
            arguments.seeds,
            tails,
            arguments.manoeuvres,
            arguments.first_seed,
            arguments.x_h_mm,
            arguments.model,
            arguments.colored_sigma,
        )
    except UserInputError as error:
        print(f"flight_coverage.py: {error}", file=sys.stderr)
        return 2
    print(json.dumps(without_nan(summary), allow_nan=False) if arguments.json else render(summary))
    return 0 if summary["all_targets_met"] else 1


if __name__ == "__main__":
    sys.exit(main())
