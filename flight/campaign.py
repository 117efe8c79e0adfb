"""The study's free-flight campaign for one configuration: from logs to a representative model.

Steps (docs/background.md section 5): cut and pre-process the manoeuvres (:mod:`manoeuvres`); identify a
model per manoeuvre (:mod:`manoeuvre_models`); drop diverged fits; simulate each model on its
measured input and flag it (:mod:`validation`); split the accepted manoeuvres 70/30 with the seed;
build the mean, covariance-weighted and time-averaged-response models on the 70 %
(:mod:`averaged_models`); score each on every validation manoeuvre (the 30 %) by normalised RMS
error and mean Pearson correlation; the representative model is chosen by the campaign's
selection rule (:func:`validation.select_representative`: by default the model that scores best
on the most validation manoeuvres, on both criteria).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.flight.averaged_models import AveragedModel, averaged_models
from ornitail.flight.campaign_file import CampaignSpec, ConfigurationSpec
from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.identification_result import ModeEstimate
from ornitail.flight.manoeuvre_models import (
    ManoeuvreModel,
    MassProperties,
    fit_manoeuvre_model,
    simulate_parameters,
    trim_constants,
)
from ornitail.flight.manoeuvres import (
    DEFAULT_GLITCH_RULE,
    Manoeuvre,
    SteadyState,
    cut_manoeuvres,
)
from ornitail.flight.model_file import StateSpaceModelSpec, load_model
from ornitail.flight.result_assembly import mode_estimates
from ornitail.flight.validation import (
    DEFAULT_SELECTION_RULE,
    RejectionFlags,
    ValidationScores,
    mean_pcc,
    normalised_rms,
    rejection_flags,
    select_representative,
    split_training_validation,
)
from ornitail.sim.configuration import VehicleConfiguration
from ornitail.sim.dynamics import LinearisedModel, TrimNotFoundError, linearise
from ornitail.sim.free_flight import FlightPlan, simulate_flight

ProgressCallback = Callable[[float, str], None]  # (fraction of this configuration done, note)
MINIMUM_ACCEPTED_MANOEUVRES = 3  # 2 to average on, 1 to validate on


@dataclass(frozen=True)
class ValidationResponse:
    """A validation manoeuvre and the representative model's simulated outputs on it."""

    manoeuvre: Manoeuvre
    measured: np.ndarray
    simulated: np.ndarray


@dataclass(frozen=True)
class ConfigurationResult:
    """Everything the campaign found for one configuration.

    ``models`` are the converged manoeuvre models (``flags`` rows follow them); ``accepted`` and
    ``training``/``validation`` are indices into ``models``; ``scores`` the mean normalised RMS
    of each averaged model on the validation manoeuvres (lower is better), ``validation_scores``
    the scores per manoeuvre; ``selection_rule`` picked ``representative``, ``glitch_rule``
    found the elevator glitches and ``colored_sigma`` names the fits' standard-error formula.
    """

    configuration: ConfigurationSpec
    mass: MassProperties
    steady_state: SteadyState
    spec: StateSpaceModelSpec
    manoeuvre_count: int
    glitches_removed: int
    models: tuple[ManoeuvreModel, ...]
    diverged: tuple[Manoeuvre, ...]
    flags: RejectionFlags
    accepted: np.ndarray
    training: np.ndarray
    validation: np.ndarray
    averaged: tuple[AveragedModel, ...]
    scores: dict[str, float]
    validation_scores: ValidationScores
    selection_rule: str
    glitch_rule: str
    representative: AveragedModel
    representative_modes: list[ModeEstimate]
    representative_eigenvalues: np.ndarray
    validation_responses: tuple[ValidationResponse, ...]
    simulator_reference: LinearisedModel | None = None
    colored_sigma: str = "morelli"

    @property
    def rejected_count(self) -> int:
        return int(np.count_nonzero(self.flags.rejected))


@dataclass(frozen=True)
class ConfigurationData:
    """Manoeuvres of a configuration, its mass properties, the simulator's linear model when
    the flights were simulated, and the glitch rule the manoeuvres were cut with.
    """

    manoeuvres: tuple[Manoeuvre, ...]
    mass: MassProperties
    simulator_reference: LinearisedModel | None = None
    glitch_rule: str = DEFAULT_GLITCH_RULE


def simulated_configuration_data(
    configuration: ConfigurationSpec, seed: int, glitch_rule: str = DEFAULT_GLITCH_RULE
) -> ConfigurationData:
    """Fly ``configuration.simulated_manoeuvres`` doublets in the simulator (one flight, 8 s per
    manoeuvre) and cut them; mass and effective pitch inertia from the simulator's vehicle.
    """
    vehicle = VehicleConfiguration(
        tail=configuration.geometry, x_h_m=configuration.x_h_m, name=configuration.label
    )
    try:
        reference = linearise(vehicle)
    except TrimNotFoundError as error:
        raise UserInputError(configuration.label, str(error)) from error
    period_s = FlightPlan().manoeuvre_period_s
    plan = FlightPlan(duration_s=configuration.simulated_manoeuvres * period_s)
    log = simulate_flight(vehicle, plan=plan, seed=seed)
    manoeuvres = cut_manoeuvres(
        log, f"simulated {configuration.label} (seed {seed})", glitch_rule=glitch_rule
    )
    mass = MassProperties(reference.mass_kg, reference.iyy_kg_m2)
    return ConfigurationData(tuple(manoeuvres), mass, reference, glitch_rule)


def logged_configuration_data(
    configuration: ConfigurationSpec, glitch_rule: str = DEFAULT_GLITCH_RULE
) -> ConfigurationData:
    """Read and cut every flight log of ``configuration`` (mass properties must be given)."""
    if configuration.mass_kg is None or configuration.iyy_kg_m2 is None:
        raise UserInputError(
            configuration.label,
            "flight logs need the vehicle's mass_kg and iyy_kg_m2 (in the campaign file or given with the logs)",
        )
    manoeuvres: list[Manoeuvre] = []
    for source in configuration.logs:
        log = read_flight_log(source.path)
        manoeuvres += cut_manoeuvres(
            log, str(source.path), source.time_range_s, glitch_rule=glitch_rule
        )
    return ConfigurationData(
        tuple(manoeuvres),
        MassProperties(configuration.mass_kg, configuration.iyy_kg_m2),
        glitch_rule=glitch_rule,
    )


def mean_steady_state(manoeuvres: Sequence[Manoeuvre]) -> SteadyState:
    """Means of the manoeuvres' pre-input steady states (airspeed from the mean velocities)."""
    theta = float(np.mean([m.steady_state.theta_rad for m in manoeuvres]))
    u = float(np.mean([m.steady_state.u_m_s for m in manoeuvres]))
    w = float(np.mean([m.steady_state.w_m_s for m in manoeuvres]))
    frequency = float(np.mean([m.steady_state.flapping_frequency_hz for m in manoeuvres]))
    return SteadyState(theta, u, w, math.hypot(u, w), frequency)


def analyse_configuration(
    configuration: ConfigurationSpec,
    data: ConfigurationData,
    spec: StateSpaceModelSpec,
    seed: int,
    progress: ProgressCallback | None = None,
    selection_rule: str = DEFAULT_SELECTION_RULE,
    colored_sigma: str = "morelli",
) -> ConfigurationResult:
    """Run the campaign procedure on one configuration's manoeuvres (module docstring)."""
    report = progress or (lambda fraction, note: None)
    steady = mean_steady_state(data.manoeuvres)
    trimmed_spec = spec.with_constants(trim_constants(spec, steady, data.mass))
    models: list[ManoeuvreModel] = []
    diverged: list[Manoeuvre] = []
    total = len(data.manoeuvres)
    for number, manoeuvre in enumerate(data.manoeuvres, start=1):
        report(0.9 * (number - 1) / total, f"{configuration.label}: manoeuvre {number}/{total}")
        model = fit_manoeuvre_model(spec, manoeuvre, data.mass, colored_sigma)
        if model.converged:
            models.append(model)
        else:
            diverged.append(manoeuvre)
    if len(models) < MINIMUM_ACCEPTED_MANOEUVRES:
        raise UserInputError(
            configuration.label,
            f"only {len(models)} of {total} manoeuvres gave a converged model "
            f"(need {MINIMUM_ACCEPTED_MANOEUVRES})",
        )
    flags = rejection_flags(
        np.array([model.errors.rms for model in models]),
        np.array([model.errors.pcc for model in models]),
        np.array([model.relative_sigmas for model in models]),
    )
    accepted = np.flatnonzero(~flags.rejected)
    if accepted.size < MINIMUM_ACCEPTED_MANOEUVRES:
        raise UserInputError(
            configuration.label,
            f"only {accepted.size} manoeuvre models pass validation "
            f"(need {MINIMUM_ACCEPTED_MANOEUVRES})",
        )
    training_positions, validation_positions = split_training_validation(accepted.size, seed)
    training, validation = accepted[training_positions], accepted[validation_positions]
    report(0.9, f"{configuration.label}: averaged models")
    averaged = averaged_models(trimmed_spec, [models[index] for index in training], colored_sigma)
    scores = score_on_validation(
        trimmed_spec, averaged, [models[index].manoeuvre for index in validation]
    )
    best = select_representative(scores, selection_rule, configuration.label)
    representative = next(candidate for candidate in averaged if candidate.name == best)
    responses = tuple(
        ValidationResponse(
            models[index].manoeuvre,
            *simulate_parameters(
                trimmed_spec, representative.parameter_values(), models[index].manoeuvre.deviations
            ),
        )
        for index in validation
    )
    eigenvalues, modes = representative_modes(trimmed_spec, representative)
    report(1.0, f"{configuration.label}: done")
    return ConfigurationResult(
        configuration=configuration,
        mass=data.mass,
        steady_state=steady,
        spec=trimmed_spec,
        manoeuvre_count=total,
        glitches_removed=sum(manoeuvre.glitches_removed for manoeuvre in data.manoeuvres),
        models=tuple(models),
        diverged=tuple(diverged),
        flags=flags,
        accepted=accepted,
        training=training,
        validation=validation,
        averaged=tuple(averaged),
        scores=scores.mean_rms(),
        validation_scores=scores,
        selection_rule=selection_rule,
        glitch_rule=data.glitch_rule,
        representative=representative,
        representative_modes=modes,
        representative_eigenvalues=eigenvalues,
        validation_responses=responses,
        simulator_reference=data.simulator_reference,
        colored_sigma=colored_sigma,
    )


def score_on_validation(
    spec: StateSpaceModelSpec,
    candidates: Sequence[AveragedModel],
    manoeuvres: Sequence[Manoeuvre],
) -> ValidationScores:
    """Normalised RMS error and mean PCC of each candidate simulated on each manoeuvre."""
    rms = np.empty((len(candidates), len(manoeuvres)))
    pcc = np.empty_like(rms)
    for row, candidate in enumerate(candidates):
        for column, manoeuvre in enumerate(manoeuvres):
            measured, simulated = simulate_parameters(
                spec, candidate.parameter_values(), manoeuvre.deviations
            )
            rms[row, column] = normalised_rms(measured, simulated)
            pcc[row, column] = mean_pcc(measured, simulated)
    return ValidationScores(tuple(candidate.name for candidate in candidates), rms, pcc)


def representative_modes(
    spec: StateSpaceModelSpec, model: AveragedModel
) -> tuple[np.ndarray, list[ModeEstimate]]:
    """Eigenvalues of the averaged model's A and its modes with delta-method standard errors.

    The averaged model has one covariance (already corrected for colored residuals where it
    comes from fits), so both sigma sets of each :class:`ModeEstimate` are computed from it.
    """
    values = {**spec.start_values(), **model.parameter_values()}
    all_parameters = np.array([values[name] for name in spec.parameter_names])
    constants = np.array([spec.constants[name] for name in spec.constant_names])
    indices = np.array([spec.parameter_names.index(name) for name in model.parameter_names])
    covariance = model.estimate.covariance
    return mode_estimates(spec, all_parameters, constants, indices, covariance, covariance)


def configuration_data(
    configuration: ConfigurationSpec, seed: int, glitch_rule: str = DEFAULT_GLITCH_RULE
) -> ConfigurationData:
    """The manoeuvres of a configuration: simulated when it asks for simulated manoeuvres."""
    if configuration.simulated_manoeuvres:
        return simulated_configuration_data(configuration, seed, glitch_rule)
    return logged_configuration_data(configuration, glitch_rule)


def run_campaign(
    campaign: CampaignSpec,
    progress: Callable[[int, float, str], None] | None = None,
) -> list[ConfigurationResult]:
    """Analyse every configuration of ``campaign``; ``progress(index, fraction, note)``.

    Configuration ``i`` (0-based) of a simulated campaign flies with seed ``campaign.seed + i``;
    every configuration's 70/30 split uses ``campaign.seed``. ``campaign.input_hold``, when
    given, replaces the model's input hold for every fit and simulation; every fit's standard
    errors use ``campaign.colored_sigma``.
    """
    spec = load_model(campaign.model)
    if campaign.input_hold is not None:
        spec = spec.with_input_hold(campaign.input_hold)
    results = []
    for index, configuration in enumerate(campaign.configurations):
        if progress:
            progress(index, 0.0, f"{configuration.label}: reading data")
        data = configuration_data(configuration, campaign.seed + index, campaign.glitch_rule)

        def report(fraction: float, note: str, index: int = index) -> None:
            if progress:
                progress(index, fraction, note)

        results.append(
            analyse_configuration(
                configuration,
                data,
                spec,
                campaign.seed,
                report,
                campaign.selection_rule,
                campaign.colored_sigma,
            )
        )
    return results
