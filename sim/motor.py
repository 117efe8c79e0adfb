"""Throttle-to-flapping-frequency model of the DelFly's DC motor under aerodynamic load.

The motor's frequency falls linearly with load torque; the wings' torque grows as f^2 times a load
factor ``L = 1 + k_in w_wing / v_tip + k_x (u_wing / v_tip)^2`` (inflow along -z_b, w_wing < 0,
unloads the wings; cross-flow loads them), ``v_tip = 2 pi f Phi R`` the wing-tip flapping speed.
Hence ``f = f_nl throttle - a L f^2``, solved in closed form for f at a given L.
"""

from __future__ import annotations

import math

from ornitail.sim.parameters import VehicleParameters


def load_factor(
    u_wing_m_s: float,
    w_wing_m_s: float,
    flapping_frequency_hz: float,
    parameters: VehicleParameters,
) -> float:
    """Aerodynamic load factor L (1 in hover) at wing velocities u, w (m/s) and frequency f (Hz)."""
    tip_speed = (
        2.0
        * math.pi
        * max(flapping_frequency_hz, 1.0)
        * parameters.flap_amplitude_rad
        * (parameters.wing_semi_span_m)
    )
    return (
        1.0
        + parameters.load_inflow_sensitivity * w_wing_m_s / tip_speed
        + parameters.load_crossflow_sensitivity * (u_wing_m_s / tip_speed) ** 2
    )


def throttle_for_frequency(
    flapping_frequency_hz: float, load: float, parameters: VehicleParameters
) -> float:
    """Throttle (0-1) that holds flapping frequency f (Hz) at load factor L."""
    f = flapping_frequency_hz
    return (f + parameters.load_frequency_drop_coefficient * load * f * f) / (
        parameters.no_load_frequency_at_full_throttle_hz
    )


def frequency_at_throttle(
    throttle: float,
    u_wing_m_s: float,
    w_wing_m_s: float,
    parameters: VehicleParameters,
    guess_hz: float,
) -> float:
    """Flapping frequency (Hz) the motor settles at for a throttle and wing velocities (m/s)."""
    drive = parameters.no_load_frequency_at_full_throttle_hz * throttle
    f = guess_hz
    for _ in range(
        4
    ):  # the load factor depends weakly on f through v_tip: a few fixed-point passes
        slope = parameters.load_frequency_drop_coefficient * load_factor(
            u_wing_m_s, w_wing_m_s, f, parameters
        )
        f = (-1.0 + math.sqrt(1.0 + 4.0 * slope * drive)) / (2.0 * slope)
    return f
