"""Simulated free flights: trim, elevator doublets, turns, and a 512 Hz on-board log.

A flight is a sequence of manoeuvres. Each manoeuvre period starts level at trim; after ``lead_s``
an elevator doublet of ``doublet_fraction`` of the full deflection (+ then -, ``pulse_s`` each) is
flown; the response runs free until a rudder turn (``rudder_cmd`` = +-1 for ``turn_s``) ends the
manoeuvre; the turn disturbs the pitch motion (a random pitching-moment pulse) and the vehicle
settles before the next one.

The cycle-averaged nonlinear rigid-body equations (:mod:`ornitail.sim.dynamics`) are integrated with
fixed step RK4 at ``integration_rate_hz`` with small random pitch-moment gusts, interpolated to the
log rate; then the flapping content is added: the rigid body's response to each flap harmonic k of
the wing loads (u_k = X_k / (m i k w), w_k = Z_k / (m i k w), q_k = M_k / (I i k w), theta_k = q_k /
(i k w)), and finally sensor noise of the on-board state estimate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter

from ornitail.core.errors import UserInputError, require_finite
from ornitail.sim.configuration import VehicleConfiguration
from ornitail.sim.dynamics import FlightDynamics, TrimState
from ornitail.sim.effects import EffectSet
from ornitail.sim.wings import periodic_wing_loads

LOG_COLUMNS = (
    "time_s",
    "q_rad_s",
    "u_m_s",
    "w_m_s",
    "theta_rad",
    "elevator_cmd",
    "elevator_rad",
    "throttle",
    "flapping_frequency_hz",
    "rudder_cmd",
)


@dataclass(frozen=True)
class FlightPlan:
    """Timing and sizes of the manoeuvres of a simulated flight (SI units)."""

    duration_s: float = 60.0
    manoeuvre_period_s: float = 8.0
    lead_s: float = 1.0
    pulse_s: float = 0.33
    doublet_fraction: float = 0.65
    elevator_limit_rad: float = math.radians(20.0)
    turn_after_doublet_s: float = 4.0
    turn_s: float = 1.0
    turn_moment_n_m: float = 3e-4
    gust_moment_n_m: float = 2e-5
    log_rate_hz: float = 512.0
    integration_rate_hz: float = 128.0
    elevator_time_constant_s: float = 0.02
    q_noise_rad_s: float = 0.03
    velocity_noise_m_s: float = 0.02
    theta_noise_rad: float = 0.003

    def validate(self) -> FlightPlan:
        for name, value in vars(self).items():
            require_finite(name, value)
        if self.duration_s <= 0 or self.manoeuvre_period_s <= 0:
            raise UserInputError(
                "duration_s", "flight duration and manoeuvre period must be positive"
            )
        if not 0 < self.doublet_fraction <= 1:
            raise UserInputError(
                "doublet_fraction", f"must be in (0, 1], got {self.doublet_fraction!r}"
            )
        if self.elevator_limit_rad <= 0:
            raise UserInputError("elevator_limit_rad", "must be positive")
        if self.lead_s + 2 * self.pulse_s > self.turn_after_doublet_s + self.lead_s:
            raise UserInputError("turn_after_doublet_s", "the turn must come after the doublet")
        return self


def elevator_command(time_s: np.ndarray, plan: FlightPlan) -> np.ndarray:
    """Elevator command, fraction of full deflection (-1..1): one doublet per manoeuvre period."""
    local = np.mod(np.asarray(time_s, dtype=float), plan.manoeuvre_period_s) - plan.lead_s
    command = np.where((local >= 0) & (local < plan.pulse_s), plan.doublet_fraction, 0.0)
    return np.where(
        (local >= plan.pulse_s) & (local < 2 * plan.pulse_s), -plan.doublet_fraction, command
    )


def rudder_command(time_s: np.ndarray, plan: FlightPlan, turn_signs: np.ndarray) -> np.ndarray:
    """Rudder command (-1, 0, +1): a turn ``turn_after_doublet_s`` after each doublet's start."""
    time_s = np.asarray(time_s, dtype=float)
    index = np.floor(time_s / plan.manoeuvre_period_s).astype(int)
    local = np.mod(time_s, plan.manoeuvre_period_s) - plan.lead_s - plan.turn_after_doublet_s
    active = (local >= 0) & (local < plan.turn_s)
    return np.where(active, turn_signs[np.clip(index, 0, len(turn_signs) - 1)], 0.0)


def _lagged(signal: np.ndarray, rate_hz: float, time_constant_s: float) -> np.ndarray:
    """First-order actuator lag applied to a sampled signal, starting settled at its first value."""
    decay = math.exp(-1.0 / (rate_hz * time_constant_s))
    output, _ = lfilter([1.0 - decay], [1.0, -decay], signal, zi=[decay * signal[0]])
    return output


def simulate_flight(
    configuration: VehicleConfiguration,
    effects: EffectSet | None = None,
    plan: FlightPlan | None = None,
    seed: int = 0,
) -> pd.DataFrame:
    """Fly ``plan`` from trim and return the 512 Hz flight log (columns :data:`LOG_COLUMNS`)."""
    effects = effects or EffectSet()
    plan = (plan or FlightPlan()).validate()
    generator = np.random.default_rng(seed)
    dynamics = FlightDynamics(configuration, effects)
    trim = dynamics.trim()
    vehicle = dynamics.vehicle

    step = 1.0 / plan.integration_rate_hz
    steps = int(math.ceil(plan.duration_s / step))
    grid = np.arange(steps + 1) * step
    manoeuvres = int(math.ceil(plan.duration_s / plan.manoeuvre_period_s)) + 1
    turn_signs = generator.choice([-1.0, 1.0], size=manoeuvres)
    turn_moments = plan.turn_moment_n_m * generator.standard_normal(manoeuvres)
    gusts = plan.gust_moment_n_m * generator.standard_normal(steps + 1)

    fine_rate = plan.integration_rate_hz * 2  # half-step samples needed by RK4
    fine_time = np.arange(2 * steps + 2) / fine_rate
    deflection = _lagged(
        elevator_command(fine_time, plan) * plan.elevator_limit_rad,
        fine_rate,
        plan.elevator_time_constant_s,
    )
    turning = rudder_command(fine_time, plan, turn_signs) != 0
    turn_index = np.clip(
        np.floor(fine_time / plan.manoeuvre_period_s).astype(int), 0, manoeuvres - 1
    )
    disturbance = np.where(turning, turn_moments[turn_index], 0.0)
    inertia = vehicle.effective_iyy_kg_m2

    def derivative(
        state: np.ndarray, fine_index: int, gust: float, frequency_hz: float | None = None
    ) -> np.ndarray:
        rate = dynamics.state_derivative(state, deflection[fine_index], trim, frequency_hz)
        rate[0] += (disturbance[fine_index] + gust) / inertia
        return rate

    states = np.empty((steps + 1, 4))
    frequencies = np.empty(steps + 1)
    state = dynamics.trim_state_vector(trim)
    for index in range(steps + 1):
        states[index] = state
        frequencies[index] = frequency = dynamics.frequency(state, trim)
        if index == steps:
            break
        gust, half = gusts[index], 2 * index
        k1 = derivative(state, half, gust, frequency)
        k2 = derivative(state + 0.5 * step * k1, half + 1, gust)
        k3 = derivative(state + 0.5 * step * k2, half + 1, gust)
        k4 = derivative(state + step * k3, half + 2, gust)
        state = state + step / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        if not np.all(np.isfinite(state)) or abs(state[3]) > 1.5:
            raise UserInputError(
                configuration.name or "configuration",
                f"vehicle departed from controlled flight at t = {grid[index]:.2f} s",
            )

    log_time = np.arange(int(round(plan.duration_s * plan.log_rate_hz))) / plan.log_rate_hz
    smooth = CubicSpline(grid, states, axis=0)(log_time)
    frequency = np.interp(log_time, grid, frequencies)
    flapping = _flapping_response(log_time, frequency, trim, dynamics, generator)
    logged = smooth + flapping
    noise = generator.standard_normal((len(log_time), 4)) * np.array(
        [plan.q_noise_rad_s, plan.velocity_noise_m_s, plan.velocity_noise_m_s, plan.theta_noise_rad]
    )
    logged = logged + noise
    command = elevator_command(log_time, plan)
    return pd.DataFrame(
        {
            "time_s": log_time,
            "q_rad_s": logged[:, 0],
            "u_m_s": logged[:, 1],
            "w_m_s": logged[:, 2],
            "theta_rad": logged[:, 3],
            "elevator_cmd": command,
            "elevator_rad": np.interp(log_time, fine_time, deflection),
            "throttle": np.full(len(log_time), trim.throttle),
            "flapping_frequency_hz": frequency,
            "rudder_cmd": rudder_command(log_time, plan, turn_signs),
        }
    )


def _flapping_response(
    time_s: np.ndarray,
    frequency_hz: np.ndarray,
    trim: TrimState,
    dynamics: FlightDynamics,
    generator: np.random.Generator,
) -> np.ndarray:
    """Rigid-body response [q, u, w, theta] to the wings' flap harmonics at the logged samples."""
    vehicle = dynamics.vehicle
    rate = 1.0 / (time_s[1] - time_s[0]) if len(time_s) > 1 else 1.0
    phase = generator.uniform(0, 2 * np.pi) + 2 * np.pi * np.cumsum(frequency_hz) / rate
    harmonics = np.arange(1, len(vehicle.parameters.thrust_harmonics) + 1)
    omega = 2 * np.pi * frequency_hz[:, None] * harmonics
    thrust = vehicle.loads(trim.u0_m_s, trim.w0_m_s, 0.0, trim.flapping_frequency_hz, 0.0).thrust_n
    velocity_gain = 1.0 / (vehicle.mass_kg * 1j * omega)
    rate_gain = 1.0 / (vehicle.effective_iyy_kg_m2 * 1j * omega)
    u_ripple, w_ripple, _ = periodic_wing_loads(
        phase, frequency_hz, thrust, vehicle.wing_arm_m, vehicle.parameters, velocity_gain
    )
    _, _, q_ripple = periodic_wing_loads(
        phase, frequency_hz, thrust, vehicle.wing_arm_m, vehicle.parameters, rate_gain
    )
    _, _, theta_ripple = periodic_wing_loads(
        phase,
        frequency_hz,
        thrust,
        vehicle.wing_arm_m,
        vehicle.parameters,
        rate_gain / (1j * omega),
    )
    return np.column_stack([q_ripple, u_ripple, w_ripple, theta_ripple])


def write_flight_log_csv(log: pd.DataFrame, path: str | Path) -> Path:
    """Write a flight log as CSV (columns :data:`LOG_COLUMNS`, SI units, full precision)."""
    path = Path(path)
    log.to_csv(path, index=False, float_format="%.9g")
    return path
