"""Rigid-body longitudinal dynamics in the study's body frame: equations of motion, trim,
linearisation.

Equations (docs/frames.md), states [q, u, w, theta], elevator input::

    I_eff dq/dt = M,   m (du/dt + q w) = X - m g sin(theta),   m (dw/dt - q u) = Z + m g cos(theta)

I_eff is I_yy plus the added pitch inertia. Free-flight trim: elevator neutral, level flight at
constant throttle; solve theta, V and f for X = Z = M = 0, then the throttle that holds f under the
trim load.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import root

from ornitail.sim.configuration import VehicleConfiguration
from ornitail.sim.effects import EffectSet
from ornitail.sim.model import PreparedVehicle
from ornitail.sim.motor import load_factor, throttle_for_frequency
from ornitail.vehicle.constants import STANDARD_GRAVITY_M_S2

STATE_NAMES = ("q", "u", "w", "theta")
DERIVATIVE_NAMES = ("Mq", "Mu", "Mw", "Xq", "Xu", "Xw", "Zq", "Zu", "Zw", "Mde", "Xde", "Zde")


class TrimNotFoundError(RuntimeError):
    """The trim equations have no solution near the expected flight condition."""


@dataclass(frozen=True)
class TrimState:
    """Free-flight steady state: pitch (rad), airspeed (m/s), body velocities (m/s), frequency,
    controls.
    """

    theta_rad: float
    airspeed_m_s: float
    u0_m_s: float
    w0_m_s: float
    flapping_frequency_hz: float
    throttle: float
    elevator_rad: float = 0.0


def _floats(state: np.ndarray) -> list[float]:
    """The state's values as Python floats: the same numbers, with cheaper scalar arithmetic than
    numpy scalars (the integrator evaluates the model some 10^5 times per flight)."""
    return state.tolist() if isinstance(state, np.ndarray) else [float(value) for value in state]


class FlightDynamics:
    """Nonlinear cycle-averaged free-flight dynamics of one build (a :class:`PreparedVehicle`)."""

    def __init__(self, configuration: VehicleConfiguration, effects: EffectSet) -> None:
        self.vehicle = PreparedVehicle(configuration, effects, "flight")
        self.effects = effects

    def frequency(self, state: np.ndarray, trim: TrimState) -> float:
        """Flapping frequency during motion: motor response at trim throttle (coupling on) or trim
        value.
        """
        q, u, w, _ = _floats(state)
        return self._frequency(q, u, w, trim)

    def _frequency(self, q: float, u: float, w: float, trim: TrimState) -> float:
        coupling = self.effects.flapping_frequency_coupling
        if not coupling.enabled:
            return trim.flapping_frequency_hz
        settled = self.vehicle.motor_frequency(trim.throttle, u, w, q, trim.flapping_frequency_hz)
        return trim.flapping_frequency_hz + coupling.gain * (settled - trim.flapping_frequency_hz)

    def forces(self, state: np.ndarray, elevator_rad: float, trim: TrimState) -> np.ndarray:
        """[M, X, Z] cycle-averaged at a state [q, u, w, theta] (N m, N, N)."""
        return np.array(self._forces(*_floats(state)[:3], float(elevator_rad), trim, None))

    def _forces(
        self,
        q: float,
        u: float,
        w: float,
        elevator_rad: float,
        trim: TrimState,
        frequency_hz: float | None,
    ) -> tuple[float, float, float]:
        if frequency_hz is None:
            frequency_hz = self._frequency(q, u, w, trim)
        loads = self.vehicle.loads(u, w, q, frequency_hz, elevator_rad)
        return loads.m_n_m, loads.x_n, loads.z_n

    def state_derivative(
        self,
        state: np.ndarray,
        elevator_rad: float,
        trim: TrimState,
        frequency_hz: float | None = None,
    ) -> np.ndarray:
        """d/dt [q, u, w, theta] from the rigid-body equations; ``frequency_hz``, when given, is
        :meth:`frequency` at this state, already computed.
        """
        q, u, w, theta = _floats(state)
        moment, x, z = self._forces(q, u, w, float(elevator_rad), trim, frequency_hz)
        mass = self.vehicle.mass_kg
        return np.array(
            [
                moment / self.vehicle.effective_iyy_kg_m2,
                x / mass - STANDARD_GRAVITY_M_S2 * math.sin(theta) - q * w,
                z / mass + STANDARD_GRAVITY_M_S2 * math.cos(theta) + q * u,
                q,
            ]
        )

    def trim(self) -> TrimState:
        """Level-flight steady state at neutral elevator (see module docstring)."""
        vehicle = self.vehicle
        weight = vehicle.mass_kg * STANDARD_GRAVITY_M_S2

        def residual(unknowns: np.ndarray) -> np.ndarray:
            theta, speed, frequency = unknowns
            u, w = -speed * math.cos(theta), -speed * math.sin(theta)
            loads = vehicle.loads(u, w, 0.0, frequency, 0.0)
            return np.array(
                [
                    (loads.x_n - weight * math.sin(theta)) / weight,
                    (loads.z_n + weight * math.cos(theta)) / weight,
                    loads.m_n_m / (weight * 0.01),
                ]
            )

        for start in ((0.42, 0.8, 13.5), (0.25, 0.5, 13.5), (0.6, 1.2, 13.0), (0.15, 0.3, 14.0)):
            solution = root(residual, np.array(start), method="hybr", options={"xtol": 1e-12})
            theta, speed, frequency = solution.x
            if solution.success and 0.0 < theta < 1.4 and speed > 0.0 and frequency > 0.0:
                break
        else:
            raise TrimNotFoundError(
                f"no level-flight trim for {vehicle.configuration.name or 'this build'}"
            )
        u0, w0 = -speed * math.cos(theta), -speed * math.sin(theta)
        load = load_factor(u0, w0, frequency, vehicle.parameters)
        return TrimState(
            theta_rad=float(theta),
            airspeed_m_s=float(speed),
            u0_m_s=float(u0),
            w0_m_s=float(w0),
            flapping_frequency_hz=float(frequency),
            throttle=float(throttle_for_frequency(frequency, load, vehicle.parameters)),
        )

    def trim_state_vector(self, trim: TrimState) -> np.ndarray:
        return np.array([0.0, trim.u0_m_s, trim.w0_m_s, trim.theta_rad])


@dataclass(frozen=True)
class LinearisedModel:
    """Linear longitudinal model about a trim: dx/dt = A x + B delta_e, x = [q, u, w, theta]."""

    a_matrix: np.ndarray
    b_matrix: np.ndarray
    derivatives: dict[str, float]
    mass_kg: float
    iyy_kg_m2: float  # effective pitch inertia used in A (rigid body plus added inertia)
    trim: TrimState
    rigid_body_iyy_kg_m2: float = 0.0
    state_names: tuple[str, ...] = field(default=STATE_NAMES)

    def eigenvalues(self) -> np.ndarray:
        values = np.linalg.eigvals(self.a_matrix)
        return values[np.argsort(values.real)]

    def oscillatory_eigenvalue(self) -> complex | None:
        """The pitch oscillation's eigenvalue (positive imaginary part); None if all are real."""
        complex_values = [value for value in self.eigenvalues() if value.imag > 1e-9]
        if not complex_values:
            return None
        return min(complex_values, key=lambda value: abs(value))

    def oscillatory_damping_ratio(self) -> float:
        value = self.oscillatory_eigenvalue()
        return math.nan if value is None else float(-value.real / abs(value))

    def oscillatory_natural_frequency_rad_s(self) -> float:
        value = self.oscillatory_eigenvalue()
        return math.nan if value is None else float(abs(value))

    def real_poles(self) -> np.ndarray:
        values = self.eigenvalues()
        return np.sort(values[np.abs(values.imag) <= 1e-9].real)


def a_matrix_from_derivatives(
    derivatives: dict[str, float], mass_kg: float, iyy_kg_m2: float, trim: TrimState
) -> np.ndarray:
    """The A matrix of docs/background.md section 5 built from dimensional derivatives and trim."""
    d, m, i = derivatives, mass_kg, iyy_kg_m2
    g, theta = STANDARD_GRAVITY_M_S2, trim.theta_rad
    return np.array(
        [
            [d["Mq"] / i, d["Mu"] / i, d["Mw"] / i, 0.0],
            [d["Xq"] / m - trim.w0_m_s, d["Xu"] / m, d["Xw"] / m, -g * math.cos(theta)],
            [d["Zq"] / m + trim.u0_m_s, d["Zu"] / m, d["Zw"] / m, -g * math.sin(theta)],
            [1.0, 0.0, 0.0, 0.0],
        ]
    )


_STATE_STEPS = np.array([1e-3, 1e-3, 1e-3, 1e-4])  # rad/s, m/s, m/s, rad: central-difference steps
_ELEVATOR_STEP_RAD = 1e-3


def linearise_dynamics(dynamics: FlightDynamics, trim: TrimState) -> LinearisedModel:
    """Central-difference linearisation of the cycle-averaged model about ``trim``."""
    x0 = dynamics.trim_state_vector(trim)
    a_numeric = np.zeros((4, 4))
    force_jacobian = np.zeros((3, 4))
    for column, step in enumerate(_STATE_STEPS):
        delta = np.zeros(4)
        delta[column] = step
        a_numeric[:, column] = (
            dynamics.state_derivative(x0 + delta, 0.0, trim)
            - dynamics.state_derivative(x0 - delta, 0.0, trim)
        ) / (2 * step)
        force_jacobian[:, column] = (
            dynamics.forces(x0 + delta, 0.0, trim) - dynamics.forces(x0 - delta, 0.0, trim)
        ) / (2 * step)
    b_numeric = (
        dynamics.state_derivative(x0, _ELEVATOR_STEP_RAD, trim)
        - dynamics.state_derivative(x0, -_ELEVATOR_STEP_RAD, trim)
    ) / (2 * _ELEVATOR_STEP_RAD)
    force_b = (
        dynamics.forces(x0, _ELEVATOR_STEP_RAD, trim)
        - dynamics.forces(x0, -_ELEVATOR_STEP_RAD, trim)
    ) / (2 * _ELEVATOR_STEP_RAD)
    derivatives = {}
    for row, axis in enumerate("MXZ"):
        for column, state in enumerate(("q", "u", "w")):
            derivatives[f"{axis}{state}"] = float(force_jacobian[row, column])
        derivatives[f"{axis}de"] = float(force_b[row])
    return LinearisedModel(
        a_matrix=a_numeric,
        b_matrix=b_numeric.reshape(4, 1),
        derivatives={name: derivatives[name] for name in DERIVATIVE_NAMES},
        mass_kg=dynamics.vehicle.mass_kg,
        iyy_kg_m2=dynamics.vehicle.effective_iyy_kg_m2,
        trim=trim,
        rigid_body_iyy_kg_m2=dynamics.vehicle.mass.iyy_kg_m2,
    )


def trim(configuration: VehicleConfiguration, effects: EffectSet | None = None) -> TrimState:
    """Free-flight trim of a build (elevator neutral, level flight)."""
    return FlightDynamics(configuration, effects or EffectSet()).trim()


def linearise(
    configuration: VehicleConfiguration,
    effects: EffectSet | None = None,
    trim_state: TrimState | None = None,
) -> LinearisedModel:
    """Linearised free-flight model about the trim of a build (trims it first unless given)."""
    dynamics = FlightDynamics(configuration, effects or EffectSet())
    return linearise_dynamics(dynamics, trim_state or dynamics.trim())
