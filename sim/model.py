"""The assembled cycle-averaged force model of one vehicle build in one environment (flight or
tunnel).

:class:`PreparedVehicle` computes once what does not change with the motion (mass properties, arms,
tail strips, wake profile, effect offsets) and then evaluates the cycle-averaged loads quickly; it
is what the trim, the linearisation, the flight integrator and the tunnel signal source all call.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ornitail.sim.configuration import VehicleConfiguration
from ornitail.sim.effects import EffectSet
from ornitail.sim.motor import frequency_at_throttle
from ornitail.sim.parameters import AIR_DENSITY_KG_M3
from ornitail.sim.tail import TailFlowModifier, TailStrips, tail_loads, tail_strips
from ornitail.sim.vehicle import MassProperties, mass_properties, tail_leading_edge_station_m
from ornitail.sim.wake import decay_at, far_wake_induced_velocity_m_s, spanwise_profile
from ornitail.sim.wings import WingScaling, cycle_averaged_wing_loads

Environment = Literal["flight", "tunnel"]


@dataclass(frozen=True)
class BodyLoads:
    """Cycle-averaged loads about the CG, body frame: X, Z (N), M (N m, positive nose-down)."""

    x_n: float
    z_n: float
    m_n_m: float
    thrust_n: float
    tail_x_n: float
    tail_z_n: float
    tail_m_n_m: float


def day_offsets(effects: EffectSet) -> WingScaling:
    """The wing model's per-day scale factors drawn from the ``day_to_day_drift`` effect's seed and
    day.
    """
    drift = effects.day_to_day_drift
    if not drift.enabled:
        return WingScaling()
    generator = np.random.default_rng([drift.seed, drift.day])
    thrust, counter, offset = generator.standard_normal(3)
    return WingScaling(
        thrust_scale=1.0 + drift.thrust_scale_sigma * thrust,
        counter_force_scale=1.0 + drift.counter_force_scale_sigma * counter,
        thrust_line_offset_change_m=drift.thrust_line_offset_sigma_m * offset,
    )


def strut_flow_modifier(
    x_h_m: float, effects: EffectSet, environment: Environment
) -> TailFlowModifier:
    """Flow change at the tail by the balance strut (tunnel only, when the effect is on)."""
    strut = effects.strut_interference
    if environment != "tunnel" or not strut.enabled:
        return TailFlowModifier()
    deficit = strut.deficit_at_57mm * math.exp(-(x_h_m - 0.057) / strut.deficit_decay_length_m)
    return TailFlowModifier(
        velocity_factor=1.0 - deficit,
        flow_angle_bias_rad=strut.bias_rad_per_m * (x_h_m - strut.bias_zero_x_h_m),
    )


class PreparedVehicle:
    """Cycle-averaged loads of one configuration under one effect set in one environment."""

    def __init__(
        self, configuration: VehicleConfiguration, effects: EffectSet, environment: Environment
    ) -> None:
        self.configuration = configuration
        self.effects = effects
        self.environment = environment
        self.parameters = configuration.parameters
        self.mass: MassProperties = mass_properties(configuration, effects)
        self.wing_arm_m = self.parameters.wing_pressure_centre_station_m - self.mass.cg_station_m
        scaling = day_offsets(effects)
        clamped = environment == "tunnel" and effects.clamping.enabled
        self.wing_scaling = WingScaling(
            thrust_scale=scaling.thrust_scale,
            counter_force_scale=scaling.counter_force_scale,
            thrust_line_offset_change_m=scaling.thrust_line_offset_change_m,
            oscillation_damping_fraction=0.0
            if clamped
            else effects.clamping.free_flight_damping_fraction,
        )
        self.tail_flow = strut_flow_modifier(configuration.x_h_m, effects, environment)
        self.strips: TailStrips | None = None
        self.wake_shape = np.zeros(0)
        if configuration.tail is not None:
            self.strips = tail_strips(
                configuration.tail, tail_leading_edge_station_m(configuration), self.parameters
            )
            self.wake_shape = decay_at(configuration.x_h_m, self.parameters) * spanwise_profile(
                self.strips.spanwise_position_m,
                configuration.x_h_m,
                effects.wake_profile,
                self.parameters.wing_semi_span_m,
            )
        self.added_pitch_inertia_kg_m2 = self._added_pitch_inertia()

    @property
    def mass_kg(self) -> float:
        return self.mass.mass_kg

    @property
    def effective_iyy_kg_m2(self) -> float:
        """Rigid-body I_yy plus the added pitch inertia (flight, when the effect is on)."""
        return self.mass.iyy_kg_m2 + self.added_pitch_inertia_kg_m2

    def _added_pitch_inertia(self) -> float:
        added = self.effects.added_mass
        if self.environment != "flight" or not added.enabled:
            return 0.0
        plate = AIR_DENSITY_KG_M3 * math.pi / 4.0 * added.coefficient
        # the wing plates' added mass acts at their mid-chord (m), not at the counter force's point
        wing_mid_chord_arm = added.wing_chord_m / 2.0 - self.mass.cg_station_m
        wings = (
            plate
            * added.wing_count
            * added.wing_chord_m**2
            * added.wing_span_m
            * (wing_mid_chord_arm**2 + added.wing_chord_m**2 / 32.0)
        )
        if self.strips is None:
            return wings
        strips = self.strips
        mid_chord = strips.centre_station_m + strips.chord_m / 4 - self.mass.cg_station_m
        tail = plate * float(
            np.sum(strips.chord_m**2 * strips.width_m * (mid_chord**2 + strips.chord_m**2 / 32.0))
        )
        return wings + tail

    def loads(
        self,
        u_m_s: float,
        w_m_s: float,
        q_rad_s: float,
        flapping_frequency_hz: float,
        elevator_rad: float,
    ) -> BodyLoads:
        """Cycle-averaged loads at body velocities (m/s), pitch rate (rad/s), frequency (Hz),
        elevator (rad).
        """
        wing = cycle_averaged_wing_loads(
            u_m_s,
            w_m_s,
            q_rad_s,
            flapping_frequency_hz,
            self.wing_arm_m,
            self.parameters,
            self.wing_scaling,
        )
        if self.strips is None:
            return BodyLoads(wing.x_n, wing.z_n, wing.m_n_m, wing.thrust_n, 0.0, 0.0, 0.0)
        inflow = -w_m_s
        induced = (
            far_wake_induced_velocity_m_s(wing.thrust_n, inflow, self.parameters) * self.wake_shape
        )
        tail_x, tail_z, tail_m = tail_loads(
            self.strips,
            u_m_s,
            w_m_s,
            q_rad_s,
            induced,
            inflow,
            self.mass.cg_station_m,
            elevator_rad,
            self.parameters,
            self.tail_flow,
        )
        return BodyLoads(
            wing.x_n + tail_x,
            wing.z_n + tail_z,
            wing.m_n_m + tail_m,
            wing.thrust_n,
            tail_x,
            tail_z,
            tail_m,
        )

    def motor_frequency(
        self, throttle: float, u_m_s: float, w_m_s: float, q_rad_s: float, guess_hz: float
    ) -> float:
        """Flapping frequency (Hz) at a throttle for the current wing velocities."""
        return frequency_at_throttle(
            throttle, u_m_s + q_rad_s * self.wing_arm_m, w_m_s, self.parameters, guess_hz
        )
