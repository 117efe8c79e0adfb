"""Induced velocity of the flapping wings' wake at the tail, along +z_b (from the wings towards the
tail).

Actuator-disk estimate of the far-wake induced velocity for thrust T and axial inflow V_in (air
arriving along +z_b at the wings, V_in = -w): ``v_far = sqrt(V_in^2 + 2 T / (rho A)) - V_in``. At
the tail it is ``v(y) = v_far exp(-x_h / L_decay) p(y)``, with the span-wise profile p of
:class:`effects.WakeProfile` (bell peaking at ~65 % of the wing semi-span, narrowing downstream
ever faster);
with that effect off the profile is uniform and equal to the bell's mean over the wing span at that
x_h.
"""

from __future__ import annotations

import math

import numpy as np

from ornitail.sim.effects import WakeProfile
from ornitail.sim.parameters import AIR_DENSITY_KG_M3, VehicleParameters

_X_H_FIRST_M = 0.057
_X_H_LAST_M = 0.126


def bell_profile(
    spanwise_position_m: np.ndarray, x_h_m: float, wake: WakeProfile, semi_span_m: float
) -> np.ndarray:
    """The bell-shaped span-wise profile p(y) at tail position x_h (dimensionless, peak 1)."""
    fraction = (x_h_m - _X_H_FIRST_M) / (_X_H_LAST_M - _X_H_FIRST_M)
    narrowing = math.copysign(abs(fraction) ** wake.narrowing_exponent, fraction)
    width = wake.width_at_57mm_m + narrowing * (wake.width_at_126mm_m - wake.width_at_57mm_m)
    width = max(width, 0.25 * wake.width_at_126mm_m)
    peak = wake.peak_fraction_of_semi_span * semi_span_m
    distance = (np.abs(np.asarray(spanwise_position_m, dtype=float)) - peak) / width
    return wake.floor + (1.0 - wake.floor) * np.exp(-(distance**2))


def spanwise_profile(
    spanwise_position_m: np.ndarray, x_h_m: float, wake: WakeProfile, semi_span_m: float
) -> np.ndarray:
    """Profile the simulator uses: the bell if the effect is on, else its wing-span mean."""
    y = np.asarray(spanwise_position_m, dtype=float)
    if wake.enabled:
        return bell_profile(y, x_h_m, wake, semi_span_m)
    across_wing = np.linspace(0.0, semi_span_m, 201)
    mean = float(
        np.trapezoid(bell_profile(across_wing, x_h_m, wake, semi_span_m), across_wing) / semi_span_m
    )
    return np.full_like(y, mean)


def far_wake_induced_velocity_m_s(
    thrust_n: float, inflow_m_s: float, parameters: VehicleParameters
) -> float:
    """Actuator-disk far-wake induced velocity (m/s) for thrust T (N) and inflow V_in (m/s)."""
    inflow = max(inflow_m_s, 0.0)
    loading = 2.0 * max(thrust_n, 0.0) / (AIR_DENSITY_KG_M3 * parameters.wake_disk_area_m2)
    return math.sqrt(inflow * inflow + loading) - inflow


def decay_at(x_h_m: float, parameters: VehicleParameters) -> float:
    """Downstream decay factor of the jet velocity at tail position x_h."""
    return math.exp(-x_h_m / parameters.wake_decay_length_m)
