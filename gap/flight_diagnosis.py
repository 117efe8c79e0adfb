"""Diagnosis of free-flight logs against a linear baseline: where, which effect, how far it shrinks.

1. The logs' manoeuvres (:mod:`ornitail.gap.flight_data`) are cut into seeded nested folds: in
   each, training/validation/test runs (50/25/25 with 20 runs); every run is a test run once.
2. Where: the baseline's residuals on all manoeuvres, decomposed by channel, frequency band, time
   segment and steady state (:mod:`ornitail.gap.flight_localisation`).
3. Which: every candidate (:mod:`ornitail.gap.flight_candidates`) is fitted on the training
   manoeuvres and ranked on the validation ones (:mod:`ornitail.gap.ranking`); the detection rule
   is calibrated on the same runs with random directions of the model (:func:`null_energies`).
4. How far: gap before and after the chosen effect per channel on the test manoeuvres, each
   scored with the effect its own fold chose (on validation runs) and fitted (on training runs)
   without it. Ranking, detection and verdict rest on every fold's validation runs pooled
   (:mod:`ornitail.gap.pooled_validation`), or with ``[baseline].validation = "first-fold"`` on
   the first fold's alone.

Fits, ranking and the gap before and after are weighted per channel by the inverse of the noise
level: the standard deviation of the part of the baseline's training residual that does not repeat
from manoeuvre to manoeuvre (gusts, sensor noise; :func:`unlocked_residual_sd`). A channel the input
hardly moves (its residual mostly disturbance) then weighs less than one whose residual an effect
can explain, as an output-error fit weighs channels by their noise covariance. A candidate's magnitude is then
refitted with weights re-estimated from its own fitted residual (output error's relaxation, :func:`_fit`): where
runs do not repeat, the baseline's residual holds the effect itself. ``where`` and the ``unexplained`` verdict keep
the measured signal's standard deviation as the unit.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from ornitail.flight.model_file import load_model
from ornitail.flight.residual_statistics import residual_tests
from ornitail.gap.derivative_refit import refit_derivatives
from ornitail.gap.detection import (
    NULL_DRAWS,
    DetectionRule,
    closure_of,
    random_matrix_directions,
)
from ornitail.gap.flight_candidates import (
    FlightCandidate,
    baseline_flight_model,
    flight_candidates,
)
from ornitail.gap.flight_data import (
    FlightRecord,
    FlightRun,
    RunSplit,
    nested_split_counts,
    nested_splits,
    read_model_runs,
    read_simulator_record,
)
from ornitail.gap.flight_localisation import (
    localise_flight,
    sparse_pointer,
    unlocked_residual_sd,
)
from ornitail.gap.flight_model import LinearFlightModel, simulate_runs, superpose
from ornitail.gap.intervals import closure_with_interval
from ornitail.gap.magnitude_fit import fit_magnitude
from ornitail.gap.model_spec import FLIGHT_NULL_DIRECTIONS, BaselineSpec
from ornitail.gap.null_response import response_gradients
from ornitail.gap.pooled_validation import FoldScores, pool_folds
from ornitail.gap.ranking import CandidateEvidence, Ranking, rank_candidates
from ornitail.gap.report import assemble_report, magnitude_field
from ornitail.gap.validation_weighting import (
    validation_run_weights,
    validation_weighting_for,
    weighted_scores,
)

DEFAULT_SEED = 2018
NULL_BOUNDS = (-1.0, 1.0)  # magnitude of a null direction: relative change of A and B entries
RELAXATION_PASSES = 4
"""Re-estimations of the channel weights at most when a candidate's magnitude is fitted (:func:`_fit`)."""
RELAXATION_TOLERANCE = 0.002
"""A candidate's magnitude has settled when a pass moves it by less than this fraction of its range."""


@dataclass(frozen=True)
class FlightDiagnosis:
    """The report (JSON-ready dict) and what the plots need.

    ``chosen`` is the top-ranked effect fitted on the first fold's training runs;
    ``after_residuals`` each run's residual (N, outputs; the model's units) as a test run, with the
    effect chosen and fitted in its own fold. ``scales`` are the measured signals' standard
    deviations (per output channel); ``weights`` the noise levels the fits, ranking and closures
    divide each channel by (per output channel).
    """

    report: dict[str, object]
    runs: list[FlightRun]
    baseline: LinearFlightModel
    chosen: LinearFlightModel
    after_residuals: list[np.ndarray]
    scales: np.ndarray
    weights: np.ndarray


def noise_scales(
    training: Sequence[FlightRun], residuals: Sequence[np.ndarray], signal_scales: np.ndarray
) -> np.ndarray:
    """Per-channel weights' scale (SI units of each channel): the baseline's unlocked residual
    standard deviation on the training runs, or the signal's standard deviation where that is not
    positive and finite (fewer than two runs, a channel without noise).
    """
    noise = unlocked_residual_sd(training, residuals)
    return np.where(np.isfinite(noise) & (noise > 0), noise, signal_scales)


def residuals_of(model: LinearFlightModel, runs: Sequence[FlightRun]) -> list[np.ndarray]:
    """Measured minus simulated outputs (N, outputs) per run."""
    return [
        run.outputs - predicted
        for run, predicted in zip(runs, simulate_runs(model, runs), strict=True)
    ]


def _channel_sse(residuals: Sequence[np.ndarray], scales: np.ndarray) -> np.ndarray:
    return np.array([np.sum((residual / scales) ** 2, axis=0) for residual in residuals])


def _input_correlation(
    residuals: Sequence[np.ndarray], runs: Sequence[FlightRun], reference_rms: np.ndarray
) -> float:
    """Mean over channels of the largest |residual-elevator correlation| over lags, each scaled by
    the residual's RMS over ``reference_rms`` (the baseline's), so a smaller residual counts less.
    """
    stacked = np.concatenate(residuals)
    channels = tuple(f"y{index}" for index in range(stacked.shape[1]))
    tests = residual_tests(
        stacked,
        np.concatenate([run.excitation for run in runs])[:, None],
        channels,
        ("input",),
    )
    ratio = np.sqrt(np.mean(stacked**2, axis=0)) / reference_rms
    return float(
        np.mean(
            [
                tests.max_input_correlation[c].get("input", 0.0) * ratio[i]
                for i, c in enumerate(channels)
            ]
        )
    )


def _fit(
    family: Callable[[float], LinearFlightModel],
    bounds: tuple[float, float],
    training: Sequence[FlightRun],
    scales: np.ndarray,
    relax: bool = False,
) -> tuple[float, LinearFlightModel]:
    """The magnitude minimising the training runs' weighted squared residual, and its model.

    With ``relax``, the channel weights are then re-estimated from the fitted model's own residual noise and the
    magnitude refitted, until it settles (:data:`RELAXATION_PASSES` at most): the relaxation of output-error
    estimation (SIDPAC's ``oe``, Maine and Iliff's R re-estimated at each estimate). The baseline's residual
    holds the effect itself wherever runs do not repeat (segments of one manoeuvre), so weights taken from it
    down-weight exactly the channels the effect moves and lean on the others' leftovers: a 0.05 s elevator filter
    injected in the Twin Otter record came out 0.032 s with the baseline's weights, 0.052 s relaxed.
    """

    def cost_with(weights: np.ndarray) -> Callable[[float], float]:
        return lambda magnitude: float(
            _channel_sse(residuals_of(family(magnitude), training), weights).sum()
        )

    magnitude, _ = fit_magnitude(cost_with(scales), bounds)
    if relax:
        low, high = bounds
        for _ in range(RELAXATION_PASSES):
            weights = noise_scales(training, residuals_of(family(magnitude), training), scales)
            refitted, _ = fit_magnitude(cost_with(weights), bounds)
            settled = abs(refitted - magnitude) <= RELAXATION_TOLERANCE * (high - low)
            magnitude = refitted
            if settled:
                break
    return magnitude, family(magnitude)


@dataclass(frozen=True)
class _Split:
    training: list[FlightRun]
    validation: list[FlightRun]
    scales: np.ndarray
    reference_rms: np.ndarray
    seed: int


def _fit_pair(
    first: FlightCandidate,
    first_magnitude: float,
    second: FlightCandidate,
    baseline: LinearFlightModel,
    split: _Split,
) -> tuple[float, LinearFlightModel]:
    """Both magnitudes by coordinate descent (second, first, second), from the first's own fit."""
    magnitudes = [first_magnitude, 0.0]
    for index in (1, 0, 1):
        candidate = (first, second)[index]

        def family(k: float, index: int = index) -> LinearFlightModel:
            pair = [*magnitudes]
            pair[index] = k
            return superpose(baseline, first.build(pair[0]), second.build(pair[1]))

        magnitudes[index], model = _fit(family, candidate.bounds, split.training, split.scales)
    return magnitudes[1], model


NULL_METHOD = (
    "validation closures of {draws} random one-parameter directions in the A and B entries "
    "(dynamic rows, scaled per entry), fitted on the training runs like every candidate"
)


def null_energies(
    start: LinearFlightModel,
    training: Sequence[FlightRun],
    validation: Sequence[FlightRun],
    scales: np.ndarray,
    seed: int,
    draws: int = NULL_DRAWS,
    named_steps: Sequence[np.ndarray] = (),
    response_gradients: Sequence[np.ndarray] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """``start``'s weighted squared residual on each ``validation`` run (runs,), and each of
    ``draws`` random directions' in A and B (:mod:`ornitail.gap.detection`; orthogonal to
    ``named_steps`` and to ``response_gradients``) fitted on the ``training`` runs within
    :data:`NULL_BOUNDS` (draws, runs) (channels divided by ``scales``, SI per channel)."""
    start_sse = _channel_sse(residuals_of(start, validation), scales).sum(axis=1)
    after = []
    for a_step, b_step in random_matrix_directions(
        start.a_matrix,
        start.b_matrix,
        draws,
        seed,
        start.dynamic_rows,
        named_steps,
        response_gradients,
    ):

        def family(k: float, a_step=a_step, b_step=b_step) -> LinearFlightModel:
            return start.with_matrices(start.a_matrix + k * a_step, start.b_matrix + k * b_step)

        _, model = _fit(family, NULL_BOUNDS, training, scales)
        after.append(_channel_sse(residuals_of(model, validation), scales).sum(axis=1))
    return start_sse, np.reshape(after, (draws, len(validation)))


def library_matrix_steps(library: Sequence[FlightCandidate]) -> list[np.ndarray]:
    """The change [dA dB] each candidate makes to the baseline at 1 % of its range (candidates that
    change neither, such as a delay or an output bias, give none)."""
    steps = []
    for candidate in library:
        small = 0.01 * _reach(candidate)
        changed, base = candidate.build(small), candidate.build(0.0)
        if changed.a_matrix.shape != base.a_matrix.shape:
            continue
        step = np.hstack([changed.a_matrix - base.a_matrix, changed.b_matrix - base.b_matrix])
        if np.any(step):
            steps.append(step)
    return steps


def rule_from_energies(
    start_sse: np.ndarray, after_sse: np.ndarray, orthogonal_to: str = ""
) -> DetectionRule:
    """The rule whose null closures are the directions' (``after_sse``, draws x runs) against
    ``start_sse`` (runs,), each summed over the runs; ``orthogonal_to`` names the changes the
    directions were stripped of (empty: none)."""
    method = NULL_METHOD.format(draws=len(after_sse))
    if orthogonal_to:
        method += f", each orthogonal to {orthogonal_to}"
    total = float(np.sum(start_sse))
    closures = np.array([closure_of(total, float(np.sum(after))) for after in after_sse])
    return DetectionRule(method, closures, orthogonal_to)


def _ranked_with_rule(
    scores: FoldScores,
    library: Sequence[FlightCandidate],
    design: str,
    named_steps: Sequence[np.ndarray],
    null_of: Callable[[Sequence[FlightCandidate]], tuple[np.ndarray, np.ndarray]],
    seed: int,
    bonferroni_t: bool,
) -> tuple[Ranking, DetectionRule]:
    """``scores`` ranked and judged by the detection rule of the null ``design``
    (``BaselineSpec.null_directions``): ``any`` and ``library-orthogonal`` use the null energies
    already in ``scores`` (the latter's directions stripped of ``named_steps``,
    :func:`library_matrix_steps`); ``top-set-orthogonal`` first ranks without a rule, then fits null
    directions whose first-order output response shares nothing with the top set's candidates'
    (``null_of(candidates)``: the start model's and the directions' validation energies;
    :mod:`ornitail.gap.null_response`), so no null direction carries the effect under test."""
    if design == "any":
        rule = rule_from_energies(scores.null_start_sse, scores.null_after_sse)
    elif design == "library-orthogonal":
        rule = rule_from_energies(
            scores.null_start_sse,
            scores.null_after_sse,
            f"the {len(named_steps)} changes the library's candidates make",
        )
    else:
        top_set = _rank(scores, seed, None, bonferroni_t).top_set
        members = [candidate for candidate in library if candidate.name in top_set]
        rule = rule_from_energies(
            *null_of(members),
            "the output responses of the top set's candidates on the training runs "
            f"({', '.join(top_set)})",
        )
    return _rank(scores, seed, rule, bonferroni_t), rule


def _null_stripped_of(
    start: LinearFlightModel,
    effects: Sequence[tuple[Callable[[float], LinearFlightModel], float]],
    part: _Split,
    seed: int,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`null_energies` on one fold's runs, the directions stripped of the first-order output
    responses of ``effects`` ((family, reach) pairs, :func:`ornitail.gap.null_response.response_gradients`)."""
    gradients = response_gradients(start, effects, part.training, part.scales)
    return null_energies(
        start, part.training, part.validation, part.scales, seed, response_gradients=gradients
    )


def _on_top_of(
    baseline: LinearFlightModel,
    first_model: LinearFlightModel,
    candidate: FlightCandidate,
    magnitude: float,
) -> LinearFlightModel:
    """``candidate`` at ``magnitude`` added to the first effect's model (both changes from ``baseline``)."""
    return superpose(baseline, first_model, candidate.build(magnitude))


def _reach(candidate: FlightCandidate) -> float:
    """The size of a candidate's largest bound (its magnitude's unit)."""
    return max(abs(bound) for bound in candidate.bounds)


def _library_scores(
    library: Sequence[FlightCandidate],
    start: LinearFlightModel,
    baseline: LinearFlightModel,
    split: _Split,
    first: tuple[FlightCandidate, float] | None = None,
    calibrate: bool = True,
    named_steps: Sequence[np.ndarray] = (),
) -> tuple[FoldScores, dict[str, LinearFlightModel]]:
    """Fit every candidate on the training runs and score it on the validation runs against
    ``start``: alone (``first`` None, ``start`` = ``baseline``), or together with the ``first``
    (candidate, magnitude) whose model is ``start``, both magnitudes refitted. With ``calibrate``
    the null directions (orthogonal to ``named_steps``) are fitted and scored too (else their
    energies are empty).

    Returns the fold's scores and each candidate's model.
    """
    start_residuals = residuals_of(start, split.validation)
    evidence, fitted = [], {}
    for candidate in library:
        if first is None:
            magnitude, model = _fit(
                candidate.build, candidate.bounds, split.training, split.scales, relax=True
            )
        else:
            magnitude, model = _fit_pair(*first, candidate, baseline, split)
        residuals = residuals_of(model, split.validation)
        fitted[candidate.name] = model
        evidence.append(
            CandidateEvidence(
                name=candidate.name,
                magnitude=magnitude,
                unit=candidate.unit,
                parameters=1,
                heldout_sse=_channel_sse(residuals, split.scales).sum(axis=1),
                training_sse=float(
                    _channel_sse(residuals_of(model, split.training), split.scales).sum()
                ),
                input_correlation=_input_correlation(
                    residuals, split.validation, split.reference_rms
                ),
                bounds=candidate.bounds,
            )
        )
    null_start, null_after = (
        null_energies(
            start,
            split.training,
            split.validation,
            split.scales,
            split.seed,
            named_steps=named_steps,
        )
        if calibrate
        else (np.zeros(0), np.zeros((0, 0)))
    )
    scores = FoldScores(
        evidence=evidence,
        start_heldout_sse=_channel_sse(start_residuals, split.scales).sum(axis=1),
        start_training_sse=float(
            _channel_sse(residuals_of(start, split.training), split.scales).sum()
        ),
        start_input_correlation=_input_correlation(
            start_residuals, split.validation, split.reference_rms
        ),
        training_count=int(sum(run.outputs.size for run in split.training)),
        null_after_sse=null_after,
        null_start_sse=null_start,
    )
    return scores, fitted


def _rank(
    scores: FoldScores, seed: int, rule: DetectionRule | None, bonferroni_t: bool = False
) -> Ranking:
    return rank_candidates(
        scores.evidence,
        scores.start_heldout_sse,
        scores.start_training_sse,
        scores.start_input_correlation,
        scores.training_count,
        seed,
        rule,
        bonferroni_t,
    )


def _second_effect(
    scored: tuple[Ranking, dict[str, LinearFlightModel], DetectionRule | None] | None,
    first_model: LinearFlightModel,
    test: Sequence[FlightRun],
    scales: np.ndarray,
    seed: int,
) -> dict[str, object] | None:
    """A second effect found on top of the first (closure counted from the first, on the test
    runs; the validation closure that chose it next to it)."""
    if scored is None or not scored[0].detected:
        return None
    ranking, fitted, rule = scored
    top = ranking.entries[0]
    realised, interval = closure_with_interval(
        _channel_sse(residuals_of(first_model, test), scales).sum(axis=1),
        _channel_sse(residuals_of(fitted[top.name], test), scales).sum(axis=1),
        seed,
    )
    return {
        "effect": top.name,
        "indistinguishable_set": list(ranking.top_set),
        "magnitude": magnitude_field(top.magnitude, top.unit, top.at_bound),
        "closure_beyond_first": realised,
        "closure_interval": interval,
        "validation_closure_beyond_first": top.heldout_closure,
        "detection_rule": rule.as_report(),
    }


def _fold(
    runs: Sequence[FlightRun], part: RunSplit, baseline: LinearFlightModel, seed: int
) -> tuple[_Split, np.ndarray]:
    """One fold's training and validation runs with its channel weights (the baseline's noise
    levels on its training runs), and the measured signals' standard deviations there (SI)."""
    training = [runs[i] for i in part.training]
    validation = [runs[i] for i in part.validation]
    signal_scales = np.concatenate([run.outputs for run in training]).std(axis=0)
    signal_scales = np.where(signal_scales > 0, signal_scales, 1.0)
    scales = noise_scales(training, residuals_of(baseline, training), signal_scales)
    reference_rms = np.sqrt(
        np.mean(np.concatenate(residuals_of(baseline, validation)) ** 2, axis=0)
    )
    reference_rms = np.where(reference_rms > 0, reference_rms, 1.0)
    return _Split(training, validation, scales, reference_rms, seed), signal_scales


def _split_field(splits: Sequence[RunSplit], count: int, pooled: bool) -> dict[str, object]:
    """The report's ``split``; pooled, its training and validation counts are every fold's."""
    field = nested_split_counts(list(splits), count) | {
        "validation_design": "all-folds" if pooled else "first-fold"
    }
    if pooled:
        field["training"] = sum(len(part.training) for part in splits)
        field["validation"] = sum(len(part.validation) for part in splits)
        field["method"] = field["method"].replace(
            "ranking, detection rule and verdict from fold 1",
            f"ranking, detection rule and verdict from every fold's validation runs pooled "
            f"({field['validation']}), magnitudes from fold 1",
        )
    return field


def read_record(spec: BaselineSpec, data_paths: Sequence[str | Path]) -> FlightRecord:
    """The runs of the logs as ``spec``'s baseline reads them: the simulator's four states, or the
    model file's signals (manoeuvres, or segments of ``spec.segment_s``)."""
    if spec.kind == "simulator":
        return read_simulator_record(data_paths)
    return read_model_runs(data_paths, load_model(spec.model), spec.segment_s)


def diagnose_flight(
    spec: BaselineSpec,
    data_paths: Sequence[str | Path],
    seed: int = DEFAULT_SEED,
    on_step: Callable[[int, int, str], None] | None = None,
) -> FlightDiagnosis:
    """Run the whole diagnosis of flight logs against ``spec``'s baseline.

    ``on_step(done, total, what)`` is told of each finished step (the candidate library fitted and ranked on one
    fold of the nested split, the second effect, the localisation), for a progress display.
    """
    record = read_record(spec, data_paths)
    weighting = validation_weighting_for(spec, record.cut)
    runs = record.runs
    splits = nested_splits(len(runs), seed, ", ".join(str(path) for path in data_paths))
    total_steps = len(splits) + 2

    def step(done: int, what: str) -> None:
        if on_step is not None:
            on_step(done, total_steps, what)

    baseline = baseline_flight_model(spec, record.constants)
    channels = baseline.output_names
    split, signal_scales = _fold(runs, splits[0], baseline, seed)
    scales = split.scales
    candidates = flight_candidates(
        spec,
        baseline,
        record.absolute_outputs,
        np.concatenate([run.outputs for run in runs]).std(axis=0),
        record.constants,
        record.varying_inputs,
    )
    library = candidates.candidates
    design = spec.null_directions or FLIGHT_NULL_DIRECTIONS
    named_steps = library_matrix_steps(library) if design == "library-orthogonal" else []
    after_ranking = design == "top-set-orthogonal"  # the null waits for the top set
    # every fold fits and scores the library; the first fold's validation runs rank and calibrate
    # the rule, or every fold's pooled (spec.validation, docs/gap-diagnosis.md)
    pooled = spec.validation == "all-folds"
    fold_scores, fold_models, fold_splits = [], [], []
    for fold, part in enumerate(splits, start=1):
        fold_split = split if fold == 1 else _fold(runs, part, baseline, seed)[0]
        scores, models = _library_scores(
            library,
            baseline,
            baseline,
            fold_split,
            calibrate=(pooled or fold == 1) and not after_ranking,
            named_steps=named_steps,
        )
        fold_scores.append(scores)
        fold_models.append(models)
        fold_splits.append(fold_split)
        step(fold, f"fold {fold} of {len(splits)}: library fitted")
    deciding = pool_folds(fold_scores) if pooled else fold_scores[0]
    run_weights = validation_run_weights(weighting, deciding.start_heldout_sse)
    deciding = weighted_scores(deciding, run_weights)

    def fold_null(members: Sequence[FlightCandidate]) -> tuple[np.ndarray, np.ndarray]:
        effects = [(member.build, _reach(member)) for member in members]
        energies = [
            _null_stripped_of(baseline, effects, part, seed)
            for part in (fold_splits if pooled else fold_splits[:1])
        ]
        start = np.concatenate([start for start, _ in energies])
        after = np.concatenate([after for _, after in energies], axis=1)
        return start * run_weights, after * run_weights

    ranking, rule = _ranked_with_rule(
        deciding, library, design, named_steps, fold_null, seed, pooled
    )
    chosen_model = fold_models[0][ranking.entries[0].name]
    first_test = [runs[i] for i in splits[0].test]
    second = None
    if ranking.detected:
        top = ranking.entries[0]
        first = (next(c for c in library if c.name == top.name), top.magnitude)
        rest = [c for c in library if c.name not in ranking.top_set]

        def second_null(members: Sequence[FlightCandidate]) -> tuple[np.ndarray, np.ndarray]:
            first_model = first[0].build(first[1])
            effects = [
                (partial(_on_top_of, baseline, first_model, member), _reach(member))
                for member in members
            ]
            return _null_stripped_of(chosen_model, effects, split, seed)

        if rest:
            scores, models = _library_scores(
                rest,
                chosen_model,
                baseline,
                split,
                first,
                calibrate=not after_ranking,
                named_steps=named_steps,
            )
            second_ranking, second_rule = _ranked_with_rule(
                scores,
                library,
                design,
                named_steps,
                second_null,
                seed,
                bonferroni_t=False,
            )
            second = (second_ranking, models, second_rule)
    step(len(splits) + 1, "second effect")
    # how far: every run is a test run once, scored with the effect its own fold chose on its own
    # validation runs (never with a choice its test runs took part in) and fitted without it
    after_residuals, choices = {}, {}
    for part, scores, models in zip(splits, fold_scores, fold_models, strict=True):
        name = _rank(scores, seed, None).entries[0].name
        choices[name] = choices.get(name, 0) + 1
        test = [runs[i] for i in part.test]
        after_residuals.update(zip(part.test, residuals_of(models[name], test), strict=True))
    all_residuals = residuals_of(baseline, runs)
    where = localise_flight(runs, all_residuals, signal_scales, baseline)
    pointer = sparse_pointer(split.training, baseline)
    order = np.concatenate([part.test for part in splits])
    counts = np.array([len(runs[i].time_s) for i in order], dtype=float)
    refit = (
        refit_derivatives(
            load_model(spec.model),
            record.constants,
            baseline,
            split.training,
            first_test,
            lambda model, runs: [residual / scales for residual in residuals_of(model, runs)],
            seed,
        )
        if spec.derivative_refit
        else None
    )
    before_sse = _channel_sse([all_residuals[i] for i in order], scales)
    report = assemble_report(
        kind="flight",
        spec=spec,
        data_paths=data_paths,
        total_runs=len(runs),
        split=_split_field(splits, len(runs), pooled)
        | {
            "test_choices": choices,
            "runs_cut_into": record.cut,
            "validation_weighting": weighting,
            "validation_runs_weighted_down": int(np.count_nonzero(run_weights < 1)),
        },
        ranking=ranking,
        rule=rule,
        channels=channels,
        sample_counts=counts,
        before_sse=before_sse,
        after_sse=_channel_sse([after_residuals[i] for i in order], scales),
        where=where,
        pointer=pointer,
        seed=seed,
        verdict_gap=float(
            np.sqrt(
                np.sum(before_sse * (scales / signal_scales) ** 2) / (counts.sum() * len(channels))
            )
        ),
        derivative_refit=refit,
    )
    report["second_effect"] = _second_effect(second, chosen_model, first_test, scales, seed)
    report["candidates_skipped"] = candidates.skipped
    step(total_steps, "localised and reported")
    return FlightDiagnosis(
        report,
        runs,
        baseline,
        chosen_model,
        [after_residuals[i] for i in range(len(runs))],
        signal_scales,
        scales,
    )
