"""Diagnosis of tunnel cycle-averaged loads against the simulator's tunnel model.

The baseline predicts each tailed set point's cycle-averaged X, Z, M about the CG with its effects
switched off (:func:`ornitail.sim.tunnel.true_cycle_average`). Candidates:

- each switched-off simulator effect that acts in the tunnel: prediction = baseline +
  k x (effect on - effect off), k fitted by least squares (k = 1: the simulator's effect);
- ``load_offset``: a constant offset per load (balance thermal drift, a tare error), 3 parameters.

Residuals are normalised per load by the measured loads' standard deviation on the training points.
Set points are cut into seeded nested folds (:func:`ornitail.gap.flight_data.nested_splits`): in
the first, candidates are fitted on the training points, ranked and detected on the validation
points (:mod:`ornitail.gap.ranking`, :mod:`ornitail.gap.detection`); the gap before and after is
reported on every point as a test point, each predicted by the candidate its own fold chose and
fitted without it (:func:`ornitail.gap.linear_candidates.nested_test`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.gap.configuration_regression import (
    channel_shares,
    configuration_regressions,
    geometry_variables,
    localisation_sentences,
)
from ornitail.gap.flight_data import nested_split_counts, nested_splits
from ornitail.gap.linear_candidates import (
    fit_linear_candidates,
    linear_null_rule,
    nested_test,
    rank_linear_candidates,
)
from ornitail.gap.model_spec import BaselineSpec, require_flight_only_keys
from ornitail.gap.plots import tunnel_residual_picture
from ornitail.gap.report import assemble_report
from ornitail.gap.sparse_regression import sparse_terms
from ornitail.gap.tunnel_data import LOAD_COLUMNS, LOAD_UNITS, read_tunnel_points
from ornitail.sim.configuration import study_configuration
from ornitail.sim.effects import EFFECT_SCOPES, EffectSet
from ornitail.sim.tunnel import true_cycle_average

CONFIGURATION_VARIABLES = ("S", "AR", "b", "x_h", "V", "theta", "f")


@dataclass(frozen=True)
class TunnelDiagnosis:
    report: dict[str, object]
    points: pd.DataFrame
    residual_before: np.ndarray
    residual_after: np.ndarray

    def pictures(self, folder: Path) -> list[str]:
        return tunnel_residual_picture(
            self.points,
            self.residual_before,
            self.residual_after,
            self.report["best_candidate"],
            folder,
        )


def predict_loads(points: pd.DataFrame, effects: EffectSet) -> np.ndarray:
    """Simulated cycle-averaged [X, Z, M] (N, N, N m) about the CG at every point."""
    predictions = np.empty((len(points), 3))
    configurations: dict[tuple[str, float], object] = {}
    for index, row in enumerate(points.itertuples()):
        key = (row.tail_id, row.x_h_mm)
        if key not in configurations:
            configurations[key] = study_configuration(row.tail_id, row.x_h_mm)
        truth = true_cycle_average(
            configurations[key], effects, row.theta_rad, row.v_m_s, row.f_hz, tail_attached=True
        )
        predictions[index] = (truth.aero_x_n, truth.aero_z_n, truth.aero_m_n_m)
    return predictions


def _configuration_table(points: pd.DataFrame) -> pd.DataFrame:
    variables = geometry_variables(list(points["tail_id"]), points["x_h_mm"].to_numpy() / 1000.0)
    return variables.assign(
        V=points["v_m_s"].to_numpy(),
        theta=points["theta_rad"].to_numpy(),
        f=points["f_hz"].to_numpy(),
    )


def _where(points: pd.DataFrame, residual: np.ndarray, scales: np.ndarray) -> dict[str, object]:
    normalised = residual / scales
    energy = np.sum(normalised**2)
    by_channel = channel_shares(residual, scales, LOAD_COLUMNS, LOAD_UNITS)
    by_configuration = configuration_regressions(
        _configuration_table(points)[list(CONFIGURATION_VARIABLES)], normalised, LOAD_COLUMNS
    )
    sweeps = {}
    for sweep, rows in points.groupby("sweep"):
        mask = points.index.isin(rows.index)
        sweeps[str(sweep) or "all"] = {
            "energy_share": float(np.sum(normalised[mask] ** 2) / energy),
            "points": int(mask.sum()),
        }
    summary = localisation_sentences(by_channel, by_configuration)
    summary.append(
        "by sweep: "
        + ", ".join(f"{name} {100 * item['energy_share']:.0f} %" for name, item in sweeps.items())
    )
    return {
        "by_channel": by_channel,
        "by_band": [],
        "by_segment": sweeps,
        "by_configuration": by_configuration,
        "input_locked_fraction": 1.0,
        "summary": summary,
    }


def _features(points: pd.DataFrame) -> tuple[np.ndarray, list[str]]:
    """The configuration variables that vary (and theta^2 when theta does), with their labels."""
    variables = _configuration_table(points)
    names = [name for name in CONFIGURATION_VARIABLES if np.ptp(variables[name].to_numpy()) > 0]
    features = variables[names].to_numpy(float)
    if "theta" not in names:
        return features, names
    return np.column_stack([features, features[:, names.index("theta")] ** 2]), [
        *names,
        "theta^2",
    ]


def _pointer(points: pd.DataFrame, residual: np.ndarray) -> dict[str, object]:
    features, labels = _features(points)
    return {
        f"{load}_residual": sparse_terms(features, residual[:, i], labels)
        for i, load in enumerate(LOAD_COLUMNS)
    }


def diagnose_tunnel(spec: BaselineSpec, paths: Sequence[Path], seed: int) -> TunnelDiagnosis:
    """Run the diagnosis of tunnel tables against ``spec`` (a simulator baseline)."""
    if spec.kind != "simulator":
        raise UserInputError(
            f"{spec.source}: [baseline].kind", "tunnel tables need a simulator baseline"
        )
    require_flight_only_keys(spec, "tunnel tables")
    points = read_tunnel_points(list(paths))
    measured = points[list(LOAD_COLUMNS)].to_numpy(float)
    effects = EffectSet().without(*spec.effects_off)
    baseline = predict_loads(points, effects)
    residual = measured - baseline
    splits = nested_splits(len(points), seed, ", ".join(str(path) for path in paths))
    training = splits[0].training
    scales = measured[training].std(axis=0)
    scales = np.where(scales > 0, scales, 1.0)
    steps = {
        name: predict_loads(points, effects.with_enabled(name)) - baseline
        for name in spec.effects_off
        if EFFECT_SCOPES[name] != "flight"
    }
    folds = [(training, splits[0].validation)]
    fits = fit_linear_candidates(residual, steps, scales, folds, ("load_offset", "N (norm)"))
    if spec.candidates:
        fits = {name: fit for name, fit in fits.items() if name in spec.candidates}
    rule = linear_null_rule(residual, _features(points)[0], scales, folds, seed)
    scored = rank_linear_candidates(residual, fits, scales, folds, seed, rule)
    after = scored.best.after
    split = nested_split_counts(splits, len(points))
    outer = [([(part.training, part.validation)], part.test) for part in splits]
    test_after, split["test_choices"] = nested_test(
        residual, steps, scales, ("load_offset", "N (norm)"), spec.candidates, seed, outer
    )
    test = np.concatenate([part.test for part in splits])
    report = assemble_report(
        kind="tunnel",
        spec=spec,
        data_paths=paths,
        total_runs=len(points),
        split=split,
        ranking=scored.ranking,
        rule=rule,
        channels=LOAD_COLUMNS,
        sample_counts=np.ones(len(test)),
        before_sse=(residual[test] / scales) ** 2,
        after_sse=(test_after[test] / scales) ** 2,
        where=_where(points, residual, scales),
        pointer=_pointer(points, residual),
        seed=seed,
    )
    return TunnelDiagnosis(report, points, residual, after)
