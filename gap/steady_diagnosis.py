"""Diagnosis of measured steady states (one row per configuration) against the simulator's trim.

The baseline predicts each configuration's free-flight trim (theta_ss, V_ss, f_ss;
:func:`ornitail.sim.dynamics.trim`) with its ``effects_off`` switched off. Candidates:

- each switched-off effect that acts in flight and moves the trim: prediction = baseline +
  k x (trim with the effect on - trim with it off), k by least squares (k = 1: the simulator's);
- ``trim_offset``: a constant offset of each steady-state value (the vehicle changed, an attitude
  sensor's mounting), one parameter per channel.

Residuals are normalised per value by its standard error (the table's ``*_sigma`` or
:data:`ornitail.gap.steady_data.DEFAULT_SIGMA`), so a gap of 1 is at the noise. With fewer than
:data:`LEAVE_ONE_OUT_BELOW` configurations the ranking, detection rule and verdict come from
leave-one-out (every configuration withheld once, the candidates fitted on the others) and the
gap's shrinking from nested leave-one-out (each configuration in turn is the test row, the choice
and the fit are made on the others by leave-one-out); otherwise the seeded nested
training/validation/test folds of :func:`ornitail.gap.flight_data.nested_splits` apply. Fitting
and ranking: :mod:`ornitail.gap.linear_candidates`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import chi2

from ornitail.core.errors import UserInputError
from ornitail.gap.configuration_regression import (
    channel_shares,
    configuration_regressions,
    geometry_variables,
    localisation_sentences,
)
from ornitail.gap.flight_data import nested_split_counts, nested_splits
from ornitail.gap.linear_candidates import (
    Fold,
    fit_linear_candidates,
    leave_one_out_outer,
    linear_null_rule,
    nested_test,
    rank_linear_candidates,
)
from ornitail.gap.model_spec import BaselineSpec, require_flight_only_keys
from ornitail.gap.plots import steady_residual_picture
from ornitail.gap.report import assemble_report
from ornitail.gap.sparse_regression import sparse_terms
from ornitail.gap.steady_data import CHANNEL_UNITS, CHANNELS, read_steady_table
from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import TrimNotFoundError, trim
from ornitail.sim.effects import EFFECT_SCOPES, EffectSet

LEAVE_ONE_OUT_BELOW = 30
NOISE_QUANTILE = 0.95
OFFSET = ("trim_offset", "SI (norm of the rad, m/s, Hz offsets)")


@dataclass(frozen=True)
class SteadyDiagnosis:
    report: dict[str, object]
    rows: pd.DataFrame
    channels: tuple[str, ...]
    residual_before: np.ndarray
    residual_after: np.ndarray

    def pictures(self, folder: Path) -> list[str]:
        return steady_residual_picture(
            list(self.rows["label"]),
            self.channels,
            self.residual_before / self.scales,
            self.residual_after / self.scales,
            self.report["best_candidate"],
            folder,
        )

    @property
    def scales(self) -> np.ndarray:
        return self.rows[[f"{c}_sigma" for c in self.channels]].to_numpy(float)


def predict_trims(rows: pd.DataFrame, effects: EffectSet) -> np.ndarray:
    """Simulated free-flight trim [theta (rad), V (m/s), f (Hz)] of every row's configuration."""
    predictions = np.empty((len(rows), 3))
    for index, (label, tail, x_h_m) in enumerate(
        rows[["label", "tail", "x_h_m"]].itertuples(False)
    ):
        try:
            state = trim(study_configuration(tail, 1000.0 * x_h_m), effects)
        except TrimNotFoundError as error:
            raise UserInputError(f"configuration {label}", str(error)) from None
        predictions[index] = (state.theta_rad, state.airspeed_m_s, state.flapping_frequency_hz)
    return predictions


def _split(
    count: int, seed: int, where: str
) -> tuple[list[Fold], list[tuple[list[Fold], np.ndarray]], dict[str, object]]:
    """The folds that rank and detect, the nested outer folds that test, and the report's ``split``:
    leave-one-out below :data:`LEAVE_ONE_OUT_BELOW` configurations, else the seeded nested
    training/validation/test folds (:func:`ornitail.gap.flight_data.nested_splits`)."""
    if count < LEAVE_ONE_OUT_BELOW:
        everything = np.arange(count)
        return (
            [(np.delete(everything, i), np.array([i])) for i in range(count)],
            leave_one_out_outer(count),
            {
                "training": count - 2,
                "validation": count - 1,
                "test": count,
                "method": f"nested leave-one-out: {count} configurations (< "
                f"{LEAVE_ONE_OUT_BELOW}); each is the test row once, the effect scored on it "
                "chosen and fitted on the others by leave-one-out (training = rows per fit, "
                "validation = rows that chose); ranking and verdict: leave-one-out over all",
            },
        )
    splits = nested_splits(count, seed, where)
    return (
        [(splits[0].training, splits[0].validation)],
        [([(part.training, part.validation)], part.test) for part in splits],
        nested_split_counts(splits, count),
    )


def _where(
    rows: pd.DataFrame, channels: tuple[str, ...], residual: np.ndarray, scales: np.ndarray
) -> dict[str, object]:
    normalised = residual / scales
    energy = np.sum(normalised**2)
    units = [CHANNEL_UNITS[CHANNELS.index(c)] for c in channels]
    by_channel = channel_shares(residual, scales, channels, units)
    variables = geometry_variables(list(rows["tail"]), rows["x_h_m"].to_numpy())
    by_configuration = configuration_regressions(variables, normalised, channels)
    positions = {}
    for x_h_m, group in rows.groupby("x_h_m"):
        mask = rows.index.isin(group.index)
        positions[f"{1000 * x_h_m:g} mm"] = {
            "energy_share": float(np.sum(normalised[mask] ** 2) / energy),
            "points": int(mask.sum()),
        }
    # share of the residual energy beyond what noise alone reaches in 95 % of tables
    noise = chi2.ppf(NOISE_QUANTILE, normalised.size)
    systematic = max(0.0, 1.0 - noise / energy) if energy > 0 else 0.0
    summary = localisation_sentences(by_channel, by_configuration)
    summary.append(
        "by tail position: "
        + ", ".join(
            f"{name} {100 * item['energy_share']:.0f} %" for name, item in positions.items()
        )
    )
    summary.append(
        f"beyond noise: {100 * systematic:.0f} % of the residual energy exceeds the 95 % "
        "quantile of what the standard errors alone give"
    )
    return {
        "by_channel": by_channel,
        "by_band": [],
        "by_segment": positions,
        "by_configuration": by_configuration,
        "input_locked_fraction": systematic,
        "summary": summary,
    }


def _features(rows: pd.DataFrame) -> tuple[np.ndarray, list[str]]:
    """The geometry variables that vary over the rows, with their names."""
    variables = geometry_variables(list(rows["tail"]), rows["x_h_m"].to_numpy())
    names = [name for name in variables.columns if np.ptp(variables[name].to_numpy()) > 0]
    return variables[names].to_numpy(float), names


def _pointer(
    rows: pd.DataFrame, channels: tuple[str, ...], residual: np.ndarray
) -> dict[str, object]:
    features, names = _features(rows)
    return {
        f"{channel}_residual": sparse_terms(features, residual[:, i], names)
        for i, channel in enumerate(channels)
    }


def diagnose_steady(spec: BaselineSpec, path: Path, seed: int) -> SteadyDiagnosis:
    """Run the diagnosis of one steady-state table against ``spec`` (a simulator baseline)."""
    if spec.kind != "simulator":
        raise UserInputError(
            f"{spec.source}: [baseline].kind", "steady-state tables need a simulator baseline"
        )
    require_flight_only_keys(spec, "steady-state tables")
    rows = read_steady_table(Path(path))
    channels = tuple(c for c in CHANNELS if c in rows.columns)
    keep = [CHANNELS.index(c) for c in channels]
    measured = rows[list(channels)].to_numpy(float)
    scales = rows[[f"{c}_sigma" for c in channels]].to_numpy(float)
    effects = EffectSet().without(*spec.effects_off)
    baseline = predict_trims(rows, effects)[:, keep]
    residual = measured - baseline
    steps = {
        name: predict_trims(rows, effects.with_enabled(name))[:, keep] - baseline
        for name in spec.effects_off
        if EFFECT_SCOPES[name] != "tunnel"
    }
    folds, outer, split = _split(len(rows), seed, str(path))
    fits = fit_linear_candidates(residual, steps, scales, folds, OFFSET)
    if spec.candidates:
        fits = {name: fit for name, fit in fits.items() if name in spec.candidates}
    rule = linear_null_rule(residual, _features(rows)[0], scales, folds, seed)
    scored = rank_linear_candidates(residual, fits, scales, folds, seed, rule)
    after = scored.best.after
    test_after, split["test_choices"] = nested_test(
        residual, steps, scales, OFFSET, spec.candidates, seed, outer
    )
    test = np.concatenate([rows for _, rows in outer])
    where = _where(rows, channels, residual, scales)
    report = assemble_report(
        kind="steady",
        spec=spec,
        data_paths=[path],
        total_runs=len(rows),
        split=split,
        ranking=scored.ranking,
        rule=rule,
        channels=channels,
        sample_counts=np.ones(len(test)),
        before_sse=(residual[test] / scales[test]) ** 2,
        after_sse=(test_after[test] / scales[test]) ** 2,
        where=where,
        pointer=_pointer(rows, channels, residual),
        seed=seed,
    )
    return SteadyDiagnosis(report, rows, channels, residual, after)
