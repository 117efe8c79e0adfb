"""Mass, centre of gravity and pitch inertia of the DelFly II as functions of tail planform and x_h.

Point-mass model along the fuselage (stations s aft of the wing leading edge): front assembly
(motor, gears, wings), battery and electronics at x_e, a uniform fuselage rod reaching the tail's
trailing edge, the fixed tail assembly (vertical tail, actuators), the horizontal base tail and the
planform (areal density times S, at its centroid). Moving the tail 57 -> 126 mm moves the CG ~15 mm
aft and raises I_yy ~150 % (docs/background.md section 1).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ornitail.sim.configuration import VehicleConfiguration
from ornitail.sim.effects import EffectSet
from ornitail.vehicle.geometry import TailGeometry


@dataclass(frozen=True)
class MassProperties:
    """Rigid-body mass properties: mass (kg), CG station (m aft of wing LE), I_yy about the CG (kg
    m^2).
    """

    mass_kg: float
    cg_station_m: float
    iyy_kg_m2: float


def tail_leading_edge_station_m(configuration: VehicleConfiguration) -> float:
    """Station of the base tail's leading edge: wing trailing edge plus x_h."""
    return configuration.parameters.wing_root_chord_m + configuration.x_h_m


def planform_centroid_aft_of_leading_edge_m(tail: TailGeometry, samples: int = 401) -> float:
    """Distance of the planform's area centroid aft of its root leading edge (m)."""
    y = np.linspace(-tail.span_m / 2, tail.span_m / 2, samples)
    chord = tail.chord_at(y)
    midpoint = tail.leading_edge_setback_at(y) + chord / 2
    return float(np.trapezoid(chord * midpoint, y) / np.trapezoid(chord, y))


def _point_masses(configuration: VehicleConfiguration) -> tuple[np.ndarray, np.ndarray, float]:
    """Masses (kg), stations (m) and the sum of own inertias (kg m^2) of the vehicle's parts."""
    p = configuration.parameters
    tail_le = tail_leading_edge_station_m(configuration)
    rod_end = tail_le + (configuration.tail.root_chord_m if configuration.tail else 0.048)
    rod_length = rod_end - p.fuselage_start_station_m
    masses = [p.front_mass_kg, p.electronics_mass_kg, p.fuselage_linear_density_kg_m * rod_length]
    stations = [
        p.front_station_m,
        p.electronics_station_m,
        p.fuselage_start_station_m + rod_length / 2,
    ]
    own_inertia = (
        p.front_own_iyy_kg_m2 + p.electronics_own_iyy_kg_m2 + masses[2] * rod_length**2 / 12.0
    )
    masses.append(p.tail_fixed_mass_kg)
    stations.append(tail_le + p.tail_fixed_offset_m)
    if configuration.tail is not None:
        masses += [p.base_tail_mass_kg, p.planform_areal_density_kg_m2 * configuration.tail.area_m2]
        stations += [
            tail_le + 0.024,
            tail_le + planform_centroid_aft_of_leading_edge_m(configuration.tail),
        ]
    return np.array(masses), np.array(stations), own_inertia


def rigid_body_mass_properties(configuration: VehicleConfiguration) -> MassProperties:
    """Mass properties of this build with its own fuselage length (no effects applied)."""
    masses, stations, own_inertia = _point_masses(configuration)
    mass = float(masses.sum())
    cg = float(masses @ stations / mass)
    iyy = float(masses @ (stations - cg) ** 2) + own_inertia
    return MassProperties(mass_kg=mass, cg_station_m=cg, iyy_kg_m2=iyy)


def mass_properties(configuration: VehicleConfiguration, effects: EffectSet) -> MassProperties:
    """Mass properties seen by the dynamics.

    With the ``cg_shift_with_x_h`` effect off, the CG station and I_yy are those of the same build
    at the effect's reference x_h (98 mm); the mass stays that of the actual build.
    """
    actual = rigid_body_mass_properties(configuration)
    shift = effects.cg_shift_with_x_h
    if shift.enabled:
        return actual
    reference = rigid_body_mass_properties(
        dataclasses.replace(configuration, x_h_m=shift.reference_x_h_m)
    )
    return MassProperties(
        mass_kg=actual.mass_kg, cg_station_m=reference.cg_station_m, iyy_kg_m2=reference.iyy_kg_m2
    )
