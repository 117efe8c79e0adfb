"""Making "real" flight data with effects the baseline model leaves out (benchmark and examples).

The data come from the simulator's free flight (:func:`ornitail.sim.free_flight.simulate_flight`)
with the withheld effects active; the baseline model file switches the same simulator effects
off. Effects and their magnitude ``k`` (the unit the diagnosis reports it in):

| effect | how it enters the data | k |
|---|---|---|
| ``added_mass`` | simulator effect on, ``coefficient = k`` | x flat-plate value |
| ``flapping_frequency_coupling`` | simulator effect on, ``gain = k`` | gain |
| ``wake_profile`` | simulator effect on (default shape) | 1 |
| ``cg_shift_with_x_h`` | simulator effect on (needs x_h != 98 mm) | 1 |
| ``pitch_damping`` | wing pitch-damping coefficient times ``1 + factor`` | change of M_q, N m s/rad |
| ``input_delay`` | logged ``elevator_rad`` leads the true deflection by k | s |
| ``input_filter`` | logged ``elevator_rad`` is the deflection through a first-order low-pass of time constant k | s |
| ``theta_drift`` | logged ``theta_rad`` drifts by k per second of log time | rad/s |
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from ornitail.core.errors import UserInputError
from ornitail.gap.model_spec import BaselineSpec
from ornitail.sim.configuration import VehicleConfiguration, study_configuration
from ornitail.sim.dynamics import linearise
from ornitail.sim.effects import EffectSet
from ornitail.sim.free_flight import FlightPlan, simulate_flight

SWITCHED_EFFECTS = (
    "added_mass",
    "flapping_frequency_coupling",
    "wake_profile",
    "cg_shift_with_x_h",
)
WITHHELD_EFFECTS = (
    *SWITCHED_EFFECTS,
    "pitch_damping",
    "input_delay",
    "input_filter",
    "theta_drift",
)
_MAGNITUDE_PARAMETERS = {"added_mass": "coefficient", "flapping_frequency_coupling": "gain"}


@dataclass(frozen=True)
class WithheldCase:
    """A configuration, the withheld effects with their magnitudes, noise and flight length.

    Doublets are 30 % of the elevator limit (the study's size for T3): at the study's usual 65 %
    the tail's nonlinearity leaves a gap between the simulator and its own linearisation that a
    fitted pitch-damping change closes by about 20 % (see docs/gap-diagnosis.md).
    """

    tail: str
    x_h_mm: float
    effects: Mapping[str, float]
    manoeuvres: int = 20
    noise_scale: float = 1.0
    seed: int = 0
    doublet_fraction: float = 0.30

    def baseline_spec(self) -> BaselineSpec:
        """The baseline every case is diagnosed against: the simulator with the switchable
        effects of :data:`SWITCHED_EFFECTS` off (the effects in the data are not named)."""
        return BaselineSpec("simulator", self.tail, self.x_h_mm, effects_off=SWITCHED_EFFECTS)


def check_effects(effects: Mapping[str, float], where: str = "effects") -> None:
    for name, value in effects.items():
        if name not in WITHHELD_EFFECTS:
            raise UserInputError(
                where, f"unknown effect {name!r}; choose from {', '.join(WITHHELD_EFFECTS)}"
            )
        if not np.isfinite(value):
            raise UserInputError(f"{where} {name}", f"magnitude {value!r} is not finite")


def _truth_vehicle(case: WithheldCase) -> tuple[VehicleConfiguration, EffectSet]:
    configuration = study_configuration(case.tail, case.x_h_mm)
    effects = EffectSet().without(*SWITCHED_EFFECTS)
    for name, value in case.effects.items():
        if name in SWITCHED_EFFECTS:
            effects = effects.with_enabled(name)
            if name in _MAGNITUDE_PARAMETERS:
                effects = effects.replace_effect(name, **{_MAGNITUDE_PARAMETERS[name]: value})
    if "pitch_damping" in case.effects:
        parameters = configuration.parameters
        scaled = dataclasses.replace(
            parameters,
            wing_pitch_damping_coefficient=parameters.wing_pitch_damping_coefficient
            * (1.0 + case.effects["pitch_damping"]),
        )
        configuration = dataclasses.replace(configuration, parameters=scaled)
    return configuration, effects


def true_magnitudes(case: WithheldCase) -> dict[str, float]:
    """Each withheld effect's magnitude in the unit the diagnosis reports (see module table)."""
    magnitudes = {}
    for name, value in case.effects.items():
        if name in ("wake_profile", "cg_shift_with_x_h"):
            magnitudes[name] = 1.0
        elif name == "pitch_damping":
            configuration, effects = _truth_vehicle(WithheldCase(case.tail, case.x_h_mm, {}))
            plain = linearise(configuration, effects).derivatives["Mq"]
            configuration, effects = _truth_vehicle(
                WithheldCase(case.tail, case.x_h_mm, {"pitch_damping": value})
            )
            magnitudes[name] = linearise(configuration, effects).derivatives["Mq"] - plain
        else:
            magnitudes[name] = float(value)
    return magnitudes


def first_order_lowpass(values: np.ndarray, step_s: float, time_constant_s: float) -> np.ndarray:
    """``values`` (uniformly sampled every ``step_s`` s) through tau dy/dt + y = x, tau =
    ``time_constant_s``, starting at rest at the first value; exact for a signal linear between
    samples (the first-order hold the models use)."""
    ratio = time_constant_s / step_s
    pole = math.exp(-1.0 / ratio)
    now, before = 1.0 - ratio * (1.0 - pole), ratio * (1.0 - pole) - pole
    values = np.asarray(values, dtype=float)
    return lfilter([now, before], [1.0, -pole], values - values[0]) + values[0]


def simulate_withheld_log(case: WithheldCase) -> pd.DataFrame:
    """A flight log (docs/flight-campaign.md columns) with the case's withheld effects active."""
    check_effects(case.effects)
    configuration, effects = _truth_vehicle(case)
    base = FlightPlan()
    plan = dataclasses.replace(
        base,
        duration_s=case.manoeuvres * base.manoeuvre_period_s,
        doublet_fraction=case.doublet_fraction,
        q_noise_rad_s=base.q_noise_rad_s * case.noise_scale,
        velocity_noise_m_s=base.velocity_noise_m_s * case.noise_scale,
        theta_noise_rad=base.theta_noise_rad * case.noise_scale,
        gust_moment_n_m=base.gust_moment_n_m * case.noise_scale,
    )
    log = simulate_flight(configuration, effects, plan, seed=case.seed)
    time_s = log["time_s"].to_numpy(float)
    if "input_delay" in case.effects:
        delay = case.effects["input_delay"]
        log["elevator_rad"] = np.interp(time_s + delay, time_s, log["elevator_rad"].to_numpy(float))
    if "input_filter" in case.effects:
        log["elevator_rad"] = first_order_lowpass(
            log["elevator_rad"].to_numpy(float),
            float(np.median(np.diff(time_s))),
            case.effects["input_filter"],
        )
    if "theta_drift" in case.effects:
        log["theta_rad"] = log["theta_rad"] + case.effects["theta_drift"] * time_s
    return log
