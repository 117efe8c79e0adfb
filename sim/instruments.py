"""Simulated tunnel instruments: hot-wire bridge, thermocouple amplifier, Hall sensor, balance
gauges.

Voltages and their laws (all *estimates* of typical hardware, documented in docs/simulator.md):

- hot-wire (constant-temperature anemometer): King's law ``E^2 = (A + B U^n) (T_w - T_flow)/(T_w -
  T_cal)`` (temperature factor only with the ``hotwire_temperature`` effect), A = 2.0 V^2, B = 1.2
  V^2 (s/m)^n, n = 0.45, noise 0.5 mV;
- thermocouple amplifier (AD8495 type): ``V = 1.25 V + 5 mV/degC * T``, noise 0.5 mV;
- Hall sensor: 3.3 V while the flap phase is within the first 5 % of a cycle (one pulse per flap),
  else 0 V, noise 5 mV;
- balance: gauge voltages ``v = C^-1 [F; T] + bias (+ thermal drift)``, noise equal to the sensor's
  resolution mapped through C^-1, 16-bit quantisation over +-10 V (``balance_resolution`` effect).
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

import numpy as np

from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.sim.effects import BalanceResolution, BalanceThermalDrift, HotwireTemperature

HALL_HIGH_V = 3.3
HALL_PULSE_FRACTION = 0.05
THERMOCOUPLE_OFFSET_V = 1.25
THERMOCOUPLE_V_PER_C = 0.005


def balance_calibration_matrix_si() -> np.ndarray:
    """Working matrix (V -> N, N m, sensor frame) of the simulated rig's real Nano-17 calibration.

    Reads ``calibration/data/FT8884.cal`` (package data of ``ornitail.calibration``) with the
    project's ATI parser: ``Axis`` rows over ``scale`` in SI with the file's ``BasicTransform``.
    """
    calibration_file = resources.files("ornitail.calibration").joinpath("data/FT8884.cal")
    with resources.as_file(calibration_file) as path:
        return AtiCalibration.from_file(path).matrix_si


@dataclass(frozen=True)
class TunnelConditions:
    """Air and hot-wire constants of the simulated tunnel (temperatures in degC)."""

    calibration_temperature_c: float = 20.0
    flow_temperature_offset_k: float = 1.5
    flow_warming_k_per_s: float = 0.005
    turbulence_intensity: float = 0.01
    turbulence_time_constant_s: float = 0.02
    king_a_v2: float = 2.0
    king_b_v2: float = 1.2
    king_exponent: float = 0.45
    hotwire_noise_v: float = 5e-4
    thermocouple_noise_v: float = 5e-4
    hall_noise_v: float = 5e-3

    def flow_temperature_c(self, time_s: np.ndarray) -> np.ndarray:
        return (
            self.calibration_temperature_c
            + self.flow_temperature_offset_k
            + (self.flow_warming_k_per_s * np.asarray(time_s))
        )


def hotwire_bridge_voltage(
    velocity_m_s: np.ndarray,
    flow_temperature_c: np.ndarray,
    conditions: TunnelConditions,
    effect: HotwireTemperature,
) -> np.ndarray:
    """Noise-free CTA bridge voltage (V) for velocity U (m/s) by King's law."""
    speed = np.maximum(np.asarray(velocity_m_s, dtype=float), 0.0)
    squared = conditions.king_a_v2 + conditions.king_b_v2 * speed**conditions.king_exponent
    if effect.enabled:
        squared = (
            squared
            * (effect.wire_temperature_c - flow_temperature_c)
            / (effect.wire_temperature_c - conditions.calibration_temperature_c)
        )
    return np.sqrt(squared)


def thermocouple_voltage(temperature_c: np.ndarray) -> np.ndarray:
    """Thermocouple amplifier output (V) for a temperature (degC)."""
    return THERMOCOUPLE_OFFSET_V + THERMOCOUPLE_V_PER_C * np.asarray(temperature_c)


def hall_voltage(flap_phase_rad: np.ndarray) -> np.ndarray:
    """Hall line (V): high for the first 5 % of every flap cycle (phase counted from the magnet)."""
    cycle_fraction = np.mod(np.asarray(flap_phase_rad) / (2 * np.pi), 1.0)
    return np.where(cycle_fraction < HALL_PULSE_FRACTION, HALL_HIGH_V, 0.0)


class BalanceGauges:
    """Nano-17 gauge voltages from sensor-frame loads, with bias, thermal drift, noise and
    quantisation.
    """

    def __init__(
        self,
        matrix_si: np.ndarray,
        resolution: BalanceResolution,
        thermal: BalanceThermalDrift,
        generator: np.random.Generator,
    ) -> None:
        self.matrix_si = matrix_si
        self.inverse = np.linalg.inv(matrix_si)
        self.resolution = resolution
        self.thermal = thermal
        self.bias_v = generator.uniform(-0.08, 0.08, size=6)
        self.drift_v_per_k = generator.normal(0.0, thermal.gauge_drift_sigma_v_per_kelvin, size=6)
        self._noise_sigma = np.array(
            [resolution.force_noise_n] * 3 + [resolution.torque_noise_n_m] * 3
        )

    def sensor_warming_k(self, motor_on_time_s: np.ndarray) -> np.ndarray:
        """Sensor temperature rise (K) after a given accumulated motor-on time (s)."""
        if not self.thermal.enabled:
            return np.zeros_like(np.asarray(motor_on_time_s, dtype=float))
        return self.thermal.warm_up_kelvin * (
            1.0 - np.exp(-np.asarray(motor_on_time_s) / self.thermal.warm_up_time_constant_s)
        )

    def voltages(
        self, sensor_loads: np.ndarray, motor_on_time_s: np.ndarray, generator: np.random.Generator
    ) -> np.ndarray:
        """Gauge voltages (n, 6) for sensor-frame loads (n, 6) [N, N, N, N m, N m, N m]."""
        loads = np.asarray(sensor_loads, dtype=float)
        if self.resolution.enabled:
            loads = loads + generator.standard_normal(loads.shape) * self._noise_sigma
        volts = loads @ self.inverse.T + self.bias_v
        volts = volts + self.sensor_warming_k(motor_on_time_s)[:, None] * self.drift_v_per_k
        if self.resolution.enabled and self.resolution.quantise:
            step = 2 * self.resolution.daq_range_v / 2**self.resolution.daq_bits
            volts = np.clip(
                np.round(volts / step) * step,
                -self.resolution.daq_range_v,
                self.resolution.daq_range_v,
            )
        return volts
