"""Switchable physical effects of the simulator (docs/background.md section 7), each with its own parameters.

Every effect is a small frozen dataclass with ``enabled`` and its parameters; :class:`EffectSet`
holds one of each. Later work switches effects by name::

    EffectSet.all_on().without("strut_interference")
    EffectSet.none().with_enabled("wake_profile")
    EffectSet.only("wake_profile", "added_mass")
    effects.replace_effect("day_to_day_drift", day=3)

``EFFECT_SCOPES`` says where each effect acts: ``"tunnel"`` (the clamped model on the balance),
``"flight"`` (free flight) or ``"both"``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from ornitail.core.errors import UserInputError


@dataclass(frozen=True)
class StrutInterference:
    """Tunnel: the strut's wake slows and turns the flow over the tail (x_h-dependent, *estimate*).

    Velocity deficit at the tail ``d = deficit_at_57mm * exp(-(x_h - 0.057 m) /
    deficit_decay_length_m)`` and a flow-angle bias ``beta = bias_rad_per_m * (x_h -
    bias_zero_x_h_m)`` that changes sign between tail positions (the study saw tailed-minus-tailless
    trends flip sign).
    """

    enabled: bool = True
    deficit_at_57mm: float = 0.08
    deficit_decay_length_m: float = 0.060
    bias_rad_per_m: float = -4.0
    bias_zero_x_h_m: float = 0.100


@dataclass(frozen=True)
class Clamping:
    """Tunnel: the clamped model cannot pitch-oscillate at the flapping frequency.

    In free flight the body rocks with the flapping moment, which adds an x_b damping force equal to
    ``free_flight_damping_fraction`` times the wings' counter force (*estimate*). With clamping on,
    the balance lacks that part; with it off, the tunnel reports the free-flight force.
    """

    enabled: bool = True
    free_flight_damping_fraction: float = 0.25


@dataclass(frozen=True)
class WakeProfile:
    """Both: span-wise bell profile of the wake's induced velocity at the tail.

    ``p(y) = floor + (1 - floor) exp(-((|y| - y_peak) / width)^2)`` with ``y_peak = peak_fraction *
    140 mm`` and ``width`` falling from ``width_at_57mm_m`` to ``width_at_126mm_m`` as
    ``((x_h - 57 mm) / 69 mm)^narrowing_exponent`` (the high-velocity region narrows slowly at
    first, then faster downstream). Off: uniform, equal to the profile's mean over the wing span at
    that x_h (so only S and AR matter).
    """

    enabled: bool = True
    peak_fraction_of_semi_span: float = 0.65  # study: peak at 60-70 % of the wing span
    width_at_57mm_m: float = 0.0347  # calibrated (docs/simulator.md)
    width_at_126mm_m: float = 0.013  # calibrated
    floor: float = 0.481  # calibrated
    narrowing_exponent: float = 2.5  # calibrated: S1, AR1 keep their damping to 98 mm


@dataclass(frozen=True)
class AddedMass:
    """Flight: flat-plate added mass of tail and wings in pitch, ``rho pi/4 int c^2 (z^2 + c^2/32)
    dy``.

    Adds to the effective I_yy (it acts like an M_qdot term). Wings: ``wing_count`` flat plates of
    chord ``wing_chord_m`` and span ``wing_span_m`` centred at the wings' mid-chord.
    """

    enabled: bool = True
    wing_chord_m: float = 0.080
    wing_span_m: float = 0.140
    wing_count: int = 2
    coefficient: float = 1.0  # multiplies the flat-plate value


@dataclass(frozen=True)
class CgShiftWithXh:
    """Both: CG and I_yy follow the fuselage length. Off: fixed at their values for
    ``reference_x_h_m``.
    """

    enabled: bool = True
    reference_x_h_m: float = 0.098


@dataclass(frozen=True)
class FlappingFrequencyCoupling:
    """Flight: at fixed throttle the flapping frequency follows the aerodynamic load (inflow, pitch
    rate).

    Off: frequency frozen at its trim value during manoeuvres. ``gain`` scales the deviation from
    trim.
    """

    enabled: bool = True
    gain: float = 1.0


@dataclass(frozen=True)
class DayToDayDrift:
    """Both: seeded per-day offsets of thrust, counter force and thrust-line offset (the vehicle
    changes).
    """

    enabled: bool = True
    day: int = 0
    seed: int = 2018
    thrust_scale_sigma: float = 0.03
    counter_force_scale_sigma: float = 0.05
    thrust_line_offset_sigma_m: float = 0.0005


@dataclass(frozen=True)
class BalanceResolution:
    """Tunnel: Nano-17 noise at its resolution and 16-bit quantisation of the gauge voltages.

    ``quantise`` says whether the gauge voltages are digitised here (a standalone recording, whose ADC this is).
    A simulated acquisition board that digitises them itself (the ORNI-DAQ9 and NETCANOEM simulators) sets it
    False: a signal quantised twice on two slightly different grids (20 V / 2^16 here, 20.48 V / 2^16 on the
    boards) keeps a rounding error of up to half a step that the noise does not average out when the signal is
    static, as in a wind-off tare (about 2 mN in X).
    """

    enabled: bool = True
    force_noise_n: float = 1.46e-3  # study: 0.149 gram-force
    torque_noise_n_m: float = 1.56e-5  # estimate: Nano-17 SI-50-0.5 torque resolution 1/64 N mm
    daq_bits: int = 16
    daq_range_v: float = 10.0
    quantise: bool = True


@dataclass(frozen=True)
class BalanceThermalDrift:
    """Tunnel: gauge offsets drift as the sensor warms while the motor runs (*estimate*)."""

    enabled: bool = True
    warm_up_kelvin: float = 3.0
    warm_up_time_constant_s: float = 180.0
    gauge_drift_sigma_v_per_kelvin: float = 2.0e-3


@dataclass(frozen=True)
class HotwireTemperature:
    """Tunnel: the hot-wire bridge voltage follows the flow temperature (which differs from the
    calibration temperature and drifts, see ``instruments.TunnelConditions``). Off: the bridge
    voltage is that at the calibration temperature. ``E^2 = (A + B U^n) (T_w - T_flow) / (T_w -
    T_cal)``.
    """

    enabled: bool = True
    wire_temperature_c: float = 250.0


@dataclass(frozen=True)
class StructuralResonance:
    """Tunnel: balance and strut resonate near the third flapping harmonic (*estimate*)."""

    enabled: bool = True
    natural_frequency_hz: float = 41.0
    damping_ratio: float = 0.04


EFFECT_SCOPES: dict[str, str] = {
    "strut_interference": "tunnel",
    "clamping": "tunnel",
    "wake_profile": "both",
    "added_mass": "flight",
    "cg_shift_with_x_h": "both",
    "flapping_frequency_coupling": "flight",
    "day_to_day_drift": "both",
    "balance_resolution": "tunnel",
    "balance_thermal_drift": "tunnel",
    "hotwire_temperature": "tunnel",
    "structural_resonance": "tunnel",
}
EFFECT_NAMES: tuple[str, ...] = tuple(EFFECT_SCOPES)


@dataclass(frozen=True)
class EffectSet:
    """One instance of every effect; by default every effect is on with default parameters."""

    strut_interference: StrutInterference = field(default_factory=StrutInterference)
    clamping: Clamping = field(default_factory=Clamping)
    wake_profile: WakeProfile = field(default_factory=WakeProfile)
    added_mass: AddedMass = field(default_factory=AddedMass)
    cg_shift_with_x_h: CgShiftWithXh = field(default_factory=CgShiftWithXh)
    flapping_frequency_coupling: FlappingFrequencyCoupling = field(
        default_factory=FlappingFrequencyCoupling
    )
    day_to_day_drift: DayToDayDrift = field(default_factory=DayToDayDrift)
    balance_resolution: BalanceResolution = field(default_factory=BalanceResolution)
    balance_thermal_drift: BalanceThermalDrift = field(default_factory=BalanceThermalDrift)
    hotwire_temperature: HotwireTemperature = field(default_factory=HotwireTemperature)
    structural_resonance: StructuralResonance = field(default_factory=StructuralResonance)

    @classmethod
    def all_on(cls) -> EffectSet:
        return cls()

    @classmethod
    def none(cls) -> EffectSet:
        return cls().without(*EFFECT_NAMES)

    @classmethod
    def only(cls, *names: str) -> EffectSet:
        return cls.none().with_enabled(*names)

    def without(self, *names: str) -> EffectSet:
        return self._switched(names, enabled=False)

    def with_enabled(self, *names: str) -> EffectSet:
        return self._switched(names, enabled=True)

    def replace_effect(self, name: str, **parameters: object) -> EffectSet:
        """A copy with effect ``name``'s parameters (or ``enabled``) replaced."""
        _check_names((name,))
        current = getattr(self, name)
        valid = {item.name for item in dataclasses.fields(current)}
        unknown = sorted(set(parameters) - valid)
        if unknown:
            raise UserInputError(f"effect {name}", f"unknown parameter(s) {', '.join(unknown)}")
        return dataclasses.replace(self, **{name: dataclasses.replace(current, **parameters)})

    def is_on(self, name: str) -> bool:
        _check_names((name,))
        return bool(getattr(self, name).enabled)

    def enabled_names(self) -> tuple[str, ...]:
        return tuple(name for name in EFFECT_NAMES if getattr(self, name).enabled)

    def _switched(self, names: tuple[str, ...], enabled: bool) -> EffectSet:
        _check_names(names)
        changes = {
            name: dataclasses.replace(getattr(self, name), enabled=enabled) for name in names
        }
        return dataclasses.replace(self, **changes)


def _check_names(names: tuple[str, ...]) -> None:
    for name in names:
        if name not in EFFECT_SCOPES:
            raise UserInputError(
                "effect name", f"unknown effect {name!r}; known effects: {', '.join(EFFECT_NAMES)}"
            )
