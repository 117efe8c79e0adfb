"""Physical parameters of the simulated DelFly II, in SI units, with where each value comes from.

Stations ``s`` are distances in metres along the fuselage, measured aft (along +z_b) from the
flapping wings' root leading edge. Marks in the comments: *study* = docs/background.md / the study's tables;
*estimate* = chosen from general DelFly knowledge; *calibrated* = tuned so that the simulator
reproduces the study's steady states, eigenstructure and derivative orders (see docs/simulator.md).
"""

from __future__ import annotations

from dataclasses import dataclass

AIR_DENSITY_KG_M3 = 1.20


@dataclass(frozen=True)
class VehicleParameters:
    """Every physical constant of the vehicle model (see the module docstring for sources)."""

    # --- layout -------------------------------------------------------------------------------
    wing_root_chord_m: float = 0.080  # estimate: DelFly II wing chord; x_h counts from its TE
    wing_semi_span_m: float = 0.140  # study: 280 mm span
    # --- mass model (stations s from the wing leading edge) ------------------------------------
    front_mass_kg: float = 0.0083  # estimate: motor, gearbox, crank, wings
    front_station_m: float = 0.004  # estimate
    front_own_iyy_kg_m2: float = 0.5e-6  # estimate: wings and mechanism spread about their centre
    electronics_mass_kg: float = 0.0087  # estimate: battery, autopilot, receiver
    electronics_station_m: float = 0.052  # study: x_e ~ 52 mm
    electronics_own_iyy_kg_m2: float = 0.5e-6  # estimate
    fuselage_start_station_m: float = -0.010  # estimate: rod starts 10 mm ahead of the wing LE
    fuselage_linear_density_kg_m: float = 0.011  # estimate: carbon rod with wiring
    tail_fixed_mass_kg: float = 0.0024  # estimate: vertical tail, rudder and elevator actuators
    tail_fixed_offset_m: float = 0.012  # estimate: aft of the base-tail leading edge
    base_tail_mass_kg: float = 0.0004  # estimate: horizontal base tail with elevator
    planform_areal_density_kg_m2: float = 0.0765  # calibrated: foil and frame, 0.77 g/100 cm^2
    # --- flapping wings (cycle-averaged) -------------------------------------------------------
    thrust_coefficient_n_per_hz2: float = 1.038e-3  # calibrated: T = k f^2 (+ inflow terms below)
    thrust_inflow_coefficient: float = 7.0e-4  # calibrated: dT = k_w f w_wing, N/(Hz m/s)
    thrust_crossflow_coefficient: float = 2.42e-3  # calibrated: translational lift k_u f u_wing^2
    counter_force_coefficient: float = 6.0e-3  # calibrated: X = -c f u_wing, N s/(m Hz)
    counter_force_inflow_sensitivity: float = 4.0  # calibrated: gives the study's X_w, M_w orders
    wing_pressure_centre_station_m: float = 0.0218  # study: wing arm 38 mm at 57 mm (+40 %)
    thrust_line_offset_m: float = 0.0086  # calibrated: thrust line along +x_b of the CG
    wing_pitch_damping_coefficient: float = 2.57e-5  # calibrated: flapping counter torque, N m s/Hz
    # relative amplitudes of flap-phase harmonics 1..6 of thrust, counter force and moment
    thrust_harmonics: tuple[float, ...] = (0.35, 0.80, 0.30, 0.15, 0.08, 0.04)
    thrust_harmonic_phases_rad: tuple[float, ...] = (0.3, 1.1, -0.7, 2.0, 0.5, -1.4)
    x_force_harmonic_n_per_hz2: tuple[float, ...] = (1.5e-4, 6.0e-5, 3.0e-5, 1.5e-5, 8e-6, 4e-6)
    x_force_harmonic_phases_rad: tuple[float, ...] = (1.2, -0.4, 0.9, -1.8, 0.2, 1.5)
    # --- flapping wake -------------------------------------------------------------------------
    wake_disk_area_m2: float = 0.054  # calibrated: ~280 mm span x 190 mm swept stroke
    wake_decay_length_m: float = 0.70  # calibrated: e-folding distance of the jet's peak velocity
    wake_convection_fraction: float = 0.266  # calibrated: wake travels at ~27 % of jet speed
    # --- tail aerodynamics ---------------------------------------------------------------------
    tail_incidence_rad: float = -0.121  # calibrated: tail leading edge set 6.9 deg towards -x_b
    tail_separation_sine: float = 0.117  # calibrated: attached flow saturates past ~6.7 deg, any AR
    tail_crossflow_drag_coefficient: float = 1.0  # estimate: flat plate normal-force at 90 deg
    tail_friction_drag_coefficient: float = 0.0235  # estimate: Blasius, both sides, Re ~ 1.3e4
    elevator_effectiveness: float = 0.45  # estimate: flap chord ratio ~0.35 (tau)
    elevator_half_span_m: float = 0.040  # study: base tail 80 mm span
    tail_strip_count: int = 48
    # --- motor ---------------------------------------------------------------------------------
    no_load_frequency_at_full_throttle_hz: float = 40.0  # estimate
    load_frequency_drop_coefficient: float = 0.025  # estimate: f drop = a f^2 per unit load, 1/Hz
    load_inflow_sensitivity: float = 0.2  # estimate: load factor change per (w_wing / v_tip)
    load_crossflow_sensitivity: float = 2.0  # estimate: load factor change per (u_wing / v_tip)^2
    flap_amplitude_rad: float = 0.75  # estimate: half stroke angle of the DelFly II
