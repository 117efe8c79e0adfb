"""Forces and moment of the flapping wings: a cycle-averaged quasi-steady part plus flap-phase
harmonics.

Cycle-averaged part (body frame of docs/frames.md, about the CG):

- thrust along -z_b: ``T = k_T s_T f^2 + k_w f w + k_u f u_wing^2`` (inflow along the fuselage,
  w < 0, reduces it; cross-flow raises it: translational lift, the wings meet more air per stroke);
- flapping counter force along x_b: ``X = -c_X s_X (1 + kappa) (1 - k_ax w / v_tip) f u_wing`` with
  ``u_wing = u + q z_wing`` the x_b airspeed at the wings' pressure centre; axial inflow along the
  fuselage (w < 0) strengthens it (the wing sections meet the cross-flow at a higher total speed;
  v_tip = 2 pi f Phi R); ``kappa`` is the free-flight body-oscillation damping that a clamped model
  lacks (see ``effects.Clamping``);
- pitching moment ``M = e_T T + z_wing X - c_Mq f q`` (thrust-line offset e_T along +x_b of the CG:
  nose-down; counter force acting z_wing < 0 above the CG: nose-up in forward flight; flapping
  counter torque).

Periodic part: harmonics k = 1..6 of the flap phase phi, thrust ripple ``T_mean a_k cos(k phi +
psi_k)`` and counter-force ripple ``b_k f^2 cos(k phi + chi_k)``, both acting at the wings' pressure
centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.sim.parameters import VehicleParameters


@dataclass(frozen=True)
class WingScaling:
    """Per-build scale factors and offsets of the wing model (day-to-day drift, clamping)."""

    thrust_scale: float = 1.0
    counter_force_scale: float = 1.0
    thrust_line_offset_change_m: float = 0.0
    oscillation_damping_fraction: float = 0.0


@dataclass(frozen=True)
class WingLoads:
    """Cycle-averaged wing loads about the CG: X, Z (N, body axes), M (N m, positive nose-down)."""

    x_n: float
    z_n: float
    m_n_m: float
    thrust_n: float


def cycle_averaged_wing_loads(
    u_m_s: float,
    w_m_s: float,
    q_rad_s: float,
    flapping_frequency_hz: float,
    wing_arm_m: float,
    parameters: VehicleParameters,
    scaling: WingScaling,
) -> WingLoads:
    """Cycle-averaged wing loads for body velocities u, w (m/s), pitch rate q (rad/s), frequency f
    (Hz).

    ``wing_arm_m`` is the pressure centre's z_b coordinate relative to the CG (negative: above the
    CG).
    """
    f = flapping_frequency_hz
    u_wing = u_m_s + q_rad_s * wing_arm_m
    thrust = (
        parameters.thrust_coefficient_n_per_hz2 * scaling.thrust_scale * f * f
        + parameters.thrust_inflow_coefficient * f * w_m_s
        + parameters.thrust_crossflow_coefficient * f * u_wing * u_wing
    )
    tip_speed = (
        2.0 * np.pi * max(f, 1.0) * parameters.flap_amplitude_rad * parameters.wing_semi_span_m
    )
    inflow_gain = 1.0 - parameters.counter_force_inflow_sensitivity * w_m_s / tip_speed
    counter = (
        -parameters.counter_force_coefficient
        * scaling.counter_force_scale
        * (1.0 + scaling.oscillation_damping_fraction)
        * inflow_gain
        * f
        * u_wing
    )
    offset = parameters.thrust_line_offset_m + scaling.thrust_line_offset_change_m
    moment = (
        offset * thrust
        + wing_arm_m * counter
        - parameters.wing_pitch_damping_coefficient * f * q_rad_s
    )
    return WingLoads(x_n=counter, z_n=-thrust, m_n_m=moment, thrust_n=thrust)


def periodic_wing_loads(
    flap_phase_rad: np.ndarray,
    flapping_frequency_hz: np.ndarray | float,
    mean_thrust_n: np.ndarray | float,
    wing_arm_m: float,
    parameters: VehicleParameters,
    harmonic_gains: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Zero-mean flap-phase content (X, Z in N; M in N m about the CG) at the given phases.

    Each load is ``Re(sum_k G_k A_k exp(i k phi))`` over k = 1..6, with ``A_k`` the thrust ripple
    (proportional to the mean thrust) or counter-force ripple (proportional to f^2).
    ``harmonic_gains`` (complex, shape (..., 6), default 1) lets a transfer function (e.g. a
    structural resonance) act per harmonic. Arrays broadcast over samples.
    """
    phase = np.asarray(flap_phase_rad, dtype=float)[..., None]
    k = np.arange(1, len(parameters.thrust_harmonics) + 1)
    rotation = np.exp(1j * k * phase)
    if harmonic_gains is not None:
        rotation = rotation * harmonic_gains
    thrust_unit = np.array(parameters.thrust_harmonics) * np.exp(
        1j * np.array(parameters.thrust_harmonic_phases_rad)
    )
    x_unit = np.array(parameters.x_force_harmonic_n_per_hz2) * np.exp(
        1j * np.array(parameters.x_force_harmonic_phases_rad)
    )
    f = np.asarray(flapping_frequency_hz, dtype=float)
    thrust_ripple = np.asarray(mean_thrust_n) * np.real(rotation @ thrust_unit)
    x_ripple = f * f * np.real(rotation @ x_unit)
    moment_ripple = parameters.thrust_line_offset_m * thrust_ripple + wing_arm_m * x_ripple
    return x_ripple, -thrust_ripple, moment_ripple
