"""Horizontal-tail force by strip integration over the planform in the flapping wake.

For each span-wise strip (chord c(y), width dy, aerodynamic centre at z = z_ac relative to the CG)
the local air velocity relative to the tail is

- along x_b: ``U_x = -(u + q z_ac) - q l(y) v(y)`` (pitch rotation, plus the lag of the wake's
  direction: the jet reaching the tail left the wings ``tau = distance / (k_conv v_jet)`` earlier,
  when the body was rotated by ``-q tau``; ``l = v tau``),
- along z_b: ``U_z = -w + v(y)`` (free stream plus induced velocity of :mod:`ornitail.sim.wake`).

The tail plane is set at incidence ``i_t`` to the fuselage (leading edge towards -x_b), which adds
``i_t U_z`` to U_x (small-angle rotation). Angle of attack ``alpha = atan2(U_x, U_z)``; normal-force
coefficient of a low-aspect-ratio flat plate ``C_N = N_att + C_Dc sin(alpha)|sin(alpha)| + a tau_e
delta_e`` (elevator term on the base-tail strips only), where the attached-flow part ``N_att = a
sin(alpha) cos(alpha) / sqrt(1 + (sin(alpha) / s_sep)^2)`` has Helmbold's lift slope ``a = 2 pi AR
/ (2 + sqrt(AR^2 + 4))`` at small angles and saturates past the separation angle ``asin(s_sep)``
(low-Reynolds-number plate). The separation angle does not depend on AR, so a higher-AR tail
carries a proportionally larger attached normal force (its advantage over a low-AR tail of the same
area). The normal force acts along the plate's normal ``(1, i_t)`` in (x_b, z_b): a tail pushed
towards +x_b also pulls the vehicle slightly forward (-z_b), which the wings' thrust need not supply.
The friction drag ``C_D0`` acts along the local flow. Positive elevator deflection pushes the tail
towards +x_b, i.e. gives a nose-down (positive) moment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ornitail.sim.parameters import AIR_DENSITY_KG_M3, VehicleParameters
from ornitail.vehicle.geometry import TailGeometry


def helmbold_lift_slope(aspect_ratio: float) -> float:
    """Lift-curve slope (1/rad) of a low-aspect-ratio wing (Helmbold)."""
    return 2.0 * math.pi * aspect_ratio / (2.0 + math.sqrt(aspect_ratio**2 + 4.0))


@dataclass(frozen=True)
class TailStrips:
    """Span-wise strips of a planform placed on the vehicle (arrays of equal length)."""

    spanwise_position_m: np.ndarray
    chord_m: np.ndarray
    width_m: np.ndarray
    centre_station_m: np.ndarray  # station of each strip's quarter-chord point
    distance_from_wings_m: np.ndarray  # from the wing trailing edge to the quarter-chord point
    elevator_mask: np.ndarray
    lift_slope_per_rad: float


def tail_strips(
    tail: TailGeometry, leading_edge_station_m: float, parameters: VehicleParameters
) -> TailStrips:
    """Divide ``tail`` into ``parameters.tail_strip_count`` equal-width strips (midpoint rule)."""
    count = parameters.tail_strip_count
    width = tail.span_m / count
    y = -tail.span_m / 2 + width * (np.arange(count) + 0.5)
    chord = tail.chord_at(y)
    quarter_chord = leading_edge_station_m + tail.leading_edge_setback_at(y) + chord / 4
    return TailStrips(
        spanwise_position_m=y,
        chord_m=chord,
        width_m=np.full(count, width),
        centre_station_m=quarter_chord,
        distance_from_wings_m=quarter_chord - parameters.wing_root_chord_m,
        elevator_mask=(np.abs(y) <= parameters.elevator_half_span_m).astype(float),
        lift_slope_per_rad=helmbold_lift_slope(tail.aspect_ratio),
    )


@dataclass(frozen=True)
class TailFlowModifier:
    """Changes of the flow at the tail by the surroundings (strut interference): speed factor, angle
    (rad).
    """

    velocity_factor: float = 1.0
    flow_angle_bias_rad: float = 0.0


def tail_loads(
    strips: TailStrips,
    u_m_s: float,
    w_m_s: float,
    q_rad_s: float,
    induced_velocity_m_s: np.ndarray,
    wing_inflow_m_s: float,
    cg_station_m: float,
    elevator_rad: float,
    parameters: VehicleParameters,
    flow: TailFlowModifier,
) -> tuple[float, float, float]:
    """Tail X, Z (N) and M about the CG (N m, positive nose-down), body frame."""
    arm = strips.centre_station_m - cg_station_m
    jet = induced_velocity_m_s + max(wing_inflow_m_s, 0.0)
    lag_length = (
        strips.distance_from_wings_m
        / parameters.wake_convection_fraction
        * induced_velocity_m_s
        / np.maximum(jet, 1e-3)
    )
    flow_x = -(u_m_s + q_rad_s * arm) - q_rad_s * lag_length
    flow_z = -w_m_s + induced_velocity_m_s
    flow_x = flow_x + parameters.tail_incidence_rad * flow_z
    flow_x, flow_z = (
        flow.velocity_factor * (flow_x + flow.flow_angle_bias_rad * flow_z),
        flow.velocity_factor * flow_z,
    )
    speed_squared = flow_x * flow_x + flow_z * flow_z
    speed = np.sqrt(speed_squared) + 1e-12
    sin_alpha = flow_x / speed
    cos_alpha = flow_z / speed
    attached = (
        strips.lift_slope_per_rad
        * sin_alpha
        * cos_alpha
        / np.sqrt(1.0 + (sin_alpha / parameters.tail_separation_sine) ** 2)
    )
    normal_coefficient = (
        attached
        + parameters.tail_crossflow_drag_coefficient * sin_alpha * np.abs(sin_alpha)
        + strips.lift_slope_per_rad
        * parameters.elevator_effectiveness
        * elevator_rad
        * strips.elevator_mask
    )
    pressure_area = 0.5 * AIR_DENSITY_KG_M3 * speed_squared * strips.chord_m * strips.width_m
    friction = pressure_area * parameters.tail_friction_drag_coefficient
    normal_force = pressure_area * normal_coefficient
    strip_x = normal_force + friction * sin_alpha
    strip_z = parameters.tail_incidence_rad * normal_force + friction * cos_alpha
    return float(strip_x.sum()), float(strip_z.sum()), float(arm @ strip_x)
