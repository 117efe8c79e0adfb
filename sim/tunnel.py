"""The DelFly clamped on the Nano-17 in the wind tunnel: the raw signals the instruments would see.

The vehicle is held at pitch theta in a horizontal stream V at flapping frequency f (motor rpm = f *
60 * 21.33). The balance feels every load on the vehicle except its own reaction: the cycle-averaged
aerodynamic loads (environment "tunnel": strut interference, clamping), the wings' flap-phase
harmonics (through the balance/strut resonance if that effect is on) and the weight, which rotates
with theta in the sensor frame. Loads about the CG are moved to the sensor origin and rotated into
the sensor axes given by the configuration's :class:`~ornitail.sim.configuration.BalanceMounting`,
then turned into six gauge voltages through the inverse of the real Nano-17 calibration matrix
(``calibration/data/FT8884.cal``, read by ``ornitail.calibration``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from ornitail.calibration.signal_channels import TUNNEL_SIGNAL_CHANNELS
from ornitail.core.errors import UserInputError, require_finite
from ornitail.sim.configuration import VehicleConfiguration, default_configuration
from ornitail.sim.effects import EffectSet
from ornitail.sim.instruments import (
    BalanceGauges,
    TunnelConditions,
    balance_calibration_matrix_si,
    hall_voltage,
    hotwire_bridge_voltage,
    thermocouple_voltage,
)
from ornitail.sim.model import PreparedVehicle
from ornitail.sim.wings import periodic_wing_loads
from ornitail.vehicle.constants import DELFLY_GEAR_RATIO, STANDARD_GRAVITY_M_S2

CHANNELS = TUNNEL_SIGNAL_CHANNELS
_FREQUENCY_JITTER_FRACTION = 0.002  # motor speed wander, AR(1) with 0.2 s time constant (estimate)
_FREQUENCY_JITTER_TIME_S = 0.2
_RPM_NOISE = 10.0  # rpm, tachometer noise (estimate)


def sensor_frame_loads(
    x_n: np.ndarray, z_n: np.ndarray, m_n_m: np.ndarray, vehicle: PreparedVehicle
) -> np.ndarray:
    """Total loads about the CG (body frame) moved to the sensor origin and rotated to sensor axes.

    Returns an (n, 6) array [Fx, Fy, Fz (N), Tx, Ty, Tz (N m)] in the sensor frame.
    """
    mounting = vehicle.configuration.mounting
    x_n, z_n, m_n_m = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(v, float)) for v in (x_n, z_n, m_n_m))
    )
    dx = -mounting.sensor_origin_x_m  # CG relative to the sensor origin, body axes
    dz = vehicle.mass.cg_station_m - mounting.sensor_origin_station_m
    zeros = np.zeros_like(x_n)
    force_body = np.stack([x_n, zeros, z_n], axis=1)
    moment_body = np.stack([zeros, m_n_m + dz * x_n - dx * z_n, zeros], axis=1)
    rotation = mounting.rotation_matrix()
    return np.hstack([force_body @ rotation.T, moment_body @ rotation.T])


def body_weight_components(mass_kg: float, pitch_rad: float) -> tuple[float, float]:
    """Weight along x_b and z_b (N) at pitch theta (docs/frames.md)."""
    weight = mass_kg * STANDARD_GRAVITY_M_S2
    return -weight * math.sin(pitch_rad), weight * math.cos(pitch_rad)


@dataclass(frozen=True)
class TunnelPointTruth:
    """True cycle-averaged loads at a tunnel point.

    ``aero_*`` and ``tail_*``: aerodynamic loads about the CG in the body frame (N, N m; positive M
    nose-down), without weight. ``weight_*``: weight components (N). ``sensor_loads``: mean total
    load at the sensor origin in the sensor frame [Fx, Fy, Fz (N), Tx, Ty, Tz (N m)] including
    weight.
    """

    aero_x_n: float
    aero_z_n: float
    aero_m_n_m: float
    tail_x_n: float
    tail_z_n: float
    tail_m_n_m: float
    weight_x_n: float
    weight_z_n: float
    sensor_loads: np.ndarray
    mass_kg: float
    cg_station_m: float


def _point_loads(
    vehicle: PreparedVehicle, pitch_rad: float, velocity_m_s: float, frequency_hz: float
) -> TunnelPointTruth:
    u, w = -velocity_m_s * math.cos(pitch_rad), -velocity_m_s * math.sin(pitch_rad)
    loads = vehicle.loads(u, w, 0.0, frequency_hz, 0.0)
    weight_x, weight_z = body_weight_components(vehicle.mass_kg, pitch_rad)
    sensor = sensor_frame_loads(loads.x_n + weight_x, loads.z_n + weight_z, loads.m_n_m, vehicle)[0]
    return TunnelPointTruth(
        aero_x_n=loads.x_n,
        aero_z_n=loads.z_n,
        aero_m_n_m=loads.m_n_m,
        tail_x_n=loads.tail_x_n,
        tail_z_n=loads.tail_z_n,
        tail_m_n_m=loads.tail_m_n_m,
        weight_x_n=weight_x,
        weight_z_n=weight_z,
        sensor_loads=sensor,
        mass_kg=vehicle.mass_kg,
        cg_station_m=vehicle.mass.cg_station_m,
    )


def true_cycle_average(
    configuration: VehicleConfiguration | None,
    effects: EffectSet | None,
    pitch_rad: float,
    tunnel_velocity_m_s: float,
    flapping_frequency_hz: float,
    tail_attached: bool = True,
) -> TunnelPointTruth:
    """The exact cycle-averaged loads the tunnel signals of this point are generated from."""
    configuration = configuration or default_configuration()
    if not tail_attached:
        configuration = configuration.without_tail()
    vehicle = PreparedVehicle(configuration, effects or EffectSet(), "tunnel")
    return _point_loads(vehicle, pitch_rad, tunnel_velocity_m_s, flapping_frequency_hz)


def resonance_gains(
    frequency_hz: float, harmonic_count: int, effects: EffectSet
) -> np.ndarray | None:
    """Complex gain of the balance/strut resonance at harmonics k f (None if the effect is off)."""
    resonance = effects.structural_resonance
    if not resonance.enabled:
        return None
    ratio = np.arange(1, harmonic_count + 1) * frequency_hz / resonance.natural_frequency_hz
    return 1.0 / (1.0 - ratio**2 + 2j * resonance.damping_ratio * ratio)


def check_operating_point(
    *,
    pitch_rad: float | None = None,
    tunnel_velocity_m_s: float | None = None,
    flapping_frequency_hz: float | None = None,
    tail_attached: bool | None = None,
) -> None:
    """Refuse a pitch (rad) outside +-pi/2, a tunnel velocity outside 0-20 m/s or a flapping frequency outside
    0-30 Hz (None: not changed).

    Raises
    ------
    UserInputError
        Naming the value and its range.
    """
    checks = {
        "pitch_rad": (pitch_rad, -math.pi / 2, math.pi / 2),
        "tunnel_velocity_m_s": (tunnel_velocity_m_s, 0.0, 20.0),
        "flapping_frequency_hz": (flapping_frequency_hz, 0.0, 30.0),
    }
    for name, (value, low, high) in checks.items():
        if value is None:
            continue
        require_finite(name, value)
        if not low <= value <= high:
            raise UserInputError(name, f"value {value!r} is outside {low:g}..{high:g}")


class TunnelSignalSource:
    """Streams the raw tunnel signals of a clamped DelFly block by block.

    Starts wind-off and motor-off at zero pitch with the tail attached. Time and flap phase run on
    continuously across blocks and set-point changes (the phase integrates the frequency).
    """

    CHANNELS: tuple[str, ...] = CHANNELS

    def __init__(
        self,
        configuration: VehicleConfiguration | None = None,
        effects: EffectSet | None = None,
        seed: int = 0,
        sample_rate_hz: float = 10_000.0,
    ) -> None:
        require_finite("sample_rate_hz", sample_rate_hz)
        if sample_rate_hz <= 0:
            raise UserInputError("sample_rate_hz", f"must be positive, got {sample_rate_hz!r}")
        self.configuration = configuration or default_configuration()
        self.effects = effects or EffectSet()
        self.sample_rate_hz = float(sample_rate_hz)
        self.conditions = TunnelConditions()
        self._generator = np.random.default_rng(seed)
        self._vehicles = {
            True: PreparedVehicle(self.configuration, self.effects, "tunnel"),
            False: PreparedVehicle(self.configuration.without_tail(), self.effects, "tunnel"),
        }
        self.gauges = BalanceGauges(
            balance_calibration_matrix_si(),
            self.effects.balance_resolution,
            self.effects.balance_thermal_drift,
            self._generator,
        )
        self._time_s = 0.0
        self._phase_rad = 0.0
        self._motor_on_time_s = 0.0
        self._jitter_state = 0.0
        self._turbulence_state = 0.0
        self.pitch_rad = 0.0
        self.tunnel_velocity_m_s = 0.0
        self.flapping_frequency_hz = 0.0
        self.tail_attached = True
        self._truth = self._compute_truth()

    def mount_vehicle(self, configuration: VehicleConfiguration) -> None:
        """Put another vehicle on the same balance (same sensor, bias and clock; the tail state is kept)."""
        self.configuration = configuration
        self._vehicles = {
            True: PreparedVehicle(configuration, self.effects, "tunnel"),
            False: PreparedVehicle(configuration.without_tail(), self.effects, "tunnel"),
        }
        self._truth = self._compute_truth()

    def set_operating_point(
        self,
        *,
        pitch_rad: float | None = None,
        tunnel_velocity_m_s: float | None = None,
        flapping_frequency_hz: float | None = None,
        tail_attached: bool | None = None,
    ) -> None:
        """Change any of pitch (rad), tunnel velocity (m/s), flapping frequency (Hz, 0 = motor off),
        tail.
        """
        check_operating_point(
            pitch_rad=pitch_rad,
            tunnel_velocity_m_s=tunnel_velocity_m_s,
            flapping_frequency_hz=flapping_frequency_hz,
        )
        if pitch_rad is not None:
            self.pitch_rad = float(pitch_rad)
        if tunnel_velocity_m_s is not None:
            self.tunnel_velocity_m_s = float(tunnel_velocity_m_s)
        if flapping_frequency_hz is not None:
            self.flapping_frequency_hz = float(flapping_frequency_hz)
        if tail_attached is not None:
            self.tail_attached = bool(tail_attached)
        self._truth = self._compute_truth()

    def _compute_truth(self) -> TunnelPointTruth:
        vehicle = self._vehicles[self.tail_attached]
        return _point_loads(
            vehicle, self.pitch_rad, self.tunnel_velocity_m_s, self.flapping_frequency_hz
        )

    @property
    def true_cycle_average(self) -> TunnelPointTruth:
        """Exact cycle-averaged loads at the current operating point."""
        return self._truth

    @property
    def time_s(self) -> float:
        return self._time_s

    @property
    def motor_rpm(self) -> float:
        """Current motor rpm including speed wander and tachometer noise."""
        rpm = self.flapping_frequency_hz * (1.0 + self._jitter_state) * 60.0 * DELFLY_GEAR_RATIO
        if self.flapping_frequency_hz <= 0:
            return 0.0
        return float(rpm + self._generator.normal(0.0, _RPM_NOISE))

    def _ar1(
        self, count: int, time_constant_s: float, sigma: float, state: float
    ) -> tuple[np.ndarray, float]:
        decay = math.exp(-1.0 / (self.sample_rate_hz * time_constant_s))
        drive = self._generator.standard_normal(count) * sigma * math.sqrt(1.0 - decay**2)
        series, final = lfilter([1.0], [1.0, -decay], drive, zi=[decay * state])
        return series, float(final[0] / decay) if decay > 0 else float(series[-1])

    def next_block(self, n_samples: int) -> np.ndarray:
        """The next ``n_samples`` samples of every channel, shape (n_samples, 9), volts."""
        volts, _ = self._generate(int(n_samples))
        return volts

    def _generate(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        if count <= 0:
            raise UserInputError("n_samples", f"must be a positive integer, got {count!r}")
        rate = self.sample_rate_hz
        times = self._time_s + np.arange(count) / rate
        vehicle = self._vehicles[self.tail_attached]
        motor_on = self.flapping_frequency_hz > 0
        jitter, self._jitter_state = self._ar1(
            count, _FREQUENCY_JITTER_TIME_S, _FREQUENCY_JITTER_FRACTION, self._jitter_state
        )
        frequency = self.flapping_frequency_hz * (1.0 + jitter) if motor_on else np.zeros(count)
        phase = (
            self._phase_rad + 2 * np.pi * np.cumsum(frequency) / rate - 2 * np.pi * frequency / rate
        )
        self._phase_rad = float(phase[-1] + 2 * np.pi * frequency[-1] / rate)
        truth = self._truth
        x = np.full(count, truth.aero_x_n + truth.weight_x_n)
        z = np.full(count, truth.aero_z_n + truth.weight_z_n)
        m = np.full(count, truth.aero_m_n_m)
        if motor_on:
            thrust = -truth.aero_z_n + truth.tail_z_n
            ripple_x, ripple_z, ripple_m = periodic_wing_loads(
                phase,
                frequency,
                thrust,
                vehicle.wing_arm_m,
                vehicle.parameters,
                resonance_gains(
                    self.flapping_frequency_hz,
                    len(vehicle.parameters.thrust_harmonics),
                    self.effects,
                ),
            )
            x, z, m = x + ripple_x, z + ripple_z, m + ripple_m
        motor_time = self._motor_on_time_s + (
            np.arange(1, count + 1) / rate if motor_on else np.zeros(count)
        )
        self._motor_on_time_s = float(motor_time[-1])
        gauges = self.gauges.voltages(
            sensor_frame_loads(x, z, m, vehicle), motor_time, self._generator
        )
        turbulence, self._turbulence_state = self._ar1(
            count,
            self.conditions.turbulence_time_constant_s,
            self.conditions.turbulence_intensity,
            self._turbulence_state,
        )
        velocity = self.tunnel_velocity_m_s * (1.0 + turbulence)
        flow_temperature = self.conditions.flow_temperature_c(times)
        noise = self._generator.standard_normal((count, 3))
        hotwire = (
            hotwire_bridge_voltage(
                velocity, flow_temperature, self.conditions, self.effects.hotwire_temperature
            )
            + self.conditions.hotwire_noise_v * noise[:, 0]
        )
        thermocouple = (
            thermocouple_voltage(flow_temperature)
            + self.conditions.thermocouple_noise_v * noise[:, 1]
        )
        hall = hall_voltage(phase) + self.conditions.hall_noise_v * noise[:, 2]
        self._time_s = float(times[-1] + 1.0 / rate)
        rpm = frequency * 60.0 * DELFLY_GEAR_RATIO
        if motor_on:
            rpm = rpm + self._generator.normal(0.0, _RPM_NOISE, count)
        return np.column_stack([gauges, hotwire, thermocouple, hall]), rpm


def record_tunnel_point(
    configuration: VehicleConfiguration | None,
    effects: EffectSet | None,
    pitch_rad: float,
    tunnel_velocity_m_s: float,
    flapping_frequency_hz: float,
    tail_attached: bool,
    duration_s: float = 2.0,
    sample_rate_hz: float = 10_000.0,
    seed: int = 0,
) -> pd.DataFrame:
    """One tunnel point as a table: ``time_s``, the nine channels (V) and ``motor_rpm``."""
    require_finite("duration_s", duration_s)
    if duration_s <= 0:
        raise UserInputError("duration_s", f"must be positive, got {duration_s!r}")
    source = TunnelSignalSource(configuration, effects, seed=seed, sample_rate_hz=sample_rate_hz)
    source.set_operating_point(
        pitch_rad=pitch_rad,
        tunnel_velocity_m_s=tunnel_velocity_m_s,
        flapping_frequency_hz=flapping_frequency_hz,
        tail_attached=tail_attached,
    )
    count = int(round(duration_s * sample_rate_hz))
    volts, rpm = source._generate(count)
    table = pd.DataFrame(volts, columns=list(CHANNELS))
    table.insert(0, "time_s", np.arange(count) / sample_rate_hz)
    table["motor_rpm"] = rpm
    return table
