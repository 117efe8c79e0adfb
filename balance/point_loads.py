"""Cycle-averaged loads of one tunnel set point, in the body frame.

Gauge voltages are averaged over each flapping cycle first (the calibration is linear, so averaging before the
matrix is exact and ten times cheaper), the wind-off tare voltages of the same pitch and tail state are subtracted
(this removes the weight, which rotates with pitch, and the gauges' zero offsets), and the calibration with its
tool transform (sensor centre -> vehicle reference point, sensor axes -> body axes of docs/frames.md) gives
forces and moments. Spread is over cycles: the study's error bars are 2 sigma over cycles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.balance.cycle_averages import cycle_means
from ornitail.balance.hall_cycles import HallEdgeSettings, flap_cycles
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.core.errors import UserInputError

BODY_LOAD_NAMES = ("x_n", "y_n", "z_n", "l_n_m", "m_n_m", "n_n_m")
"""Body-frame forces X, Y, Z (N) and moments L, M, N (N m) about the reference point; M positive nose-down."""


@dataclass(frozen=True)
class CycleAveragedLoads:
    """Loads of one set point averaged over each accepted flapping cycle.

    Attributes
    ----------
    per_cycle : numpy.ndarray
        Shape (n_cycles, 6): X, Y, Z (N) and L, M, N (N m) of each cycle, body frame (``BODY_LOAD_NAMES``).
    mean, spread, standard_error : numpy.ndarray
        Shape (6,): mean over cycles, sample standard deviation over cycles, and standard error of the mean
        (see :func:`standard_error_of_cycle_mean`).
    flapping_frequency_hz : float
        Mean flapping frequency over the accepted cycles, from the Hall line.
    rejected_cycles : int
        Cycles rejected by the period check.
    tare_standard_error : numpy.ndarray
        Shape (6,): standard error of the subtracted tare (its sample noise), same units as ``mean``.
    """

    per_cycle: np.ndarray
    mean: np.ndarray
    spread: np.ndarray
    standard_error: np.ndarray
    flapping_frequency_hz: float
    rejected_cycles: int
    tare_standard_error: np.ndarray

    @property
    def total_standard_error(self) -> np.ndarray:
        """Standard error of the tare-corrected mean: cycle scatter and tare noise combined, shape (6,)."""
        return np.hypot(self.standard_error, self.tare_standard_error)

    @property
    def cycle_count(self) -> int:
        """Number of accepted cycles."""
        return len(self.per_cycle)

    @property
    def two_sigma(self) -> np.ndarray:
        """Twice the spread over cycles (the study's error bar)."""
        return 2.0 * self.spread

    def as_record(self) -> dict[str, float]:
        """Flat dictionary: ``<load>``, ``<load>_2sigma``, ``<load>_se``, ``<load>_tare_se``, cycles, frequency."""
        record: dict[str, float] = {
            "cycles": self.cycle_count,
            "f_hall_hz": self.flapping_frequency_hz,
            "rejected_cycles": self.rejected_cycles,
        }
        for index, name in enumerate(BODY_LOAD_NAMES):
            record[name] = float(self.mean[index])
            record[f"{name}_2sigma"] = float(self.two_sigma[index])
            record[f"{name}_se"] = float(self.standard_error[index])
            record[f"{name}_tare_se"] = float(self.tare_standard_error[index])
        return record


def cycle_averaged_loads(
    gauge_volts: np.ndarray,
    hall_v: np.ndarray,
    sample_rate_hz: float,
    tare_volts: np.ndarray,
    calibration: AtiCalibration,
    hall_settings: HallEdgeSettings | None = None,
    tare_volts_standard_error: np.ndarray | None = None,
) -> CycleAveragedLoads:
    """Tare-corrected, cycle-averaged body-frame loads of one record.

    Parameters
    ----------
    gauge_volts : numpy.ndarray
        Raw gauge voltages, shape (n_samples, 6), V.
    hall_v : numpy.ndarray
        Hall line, shape (n_samples,), V.
    sample_rate_hz : float
        Sampling rate, Hz.
    tare_volts : numpy.ndarray
        Mean gauge voltages of the wind-off, motor-off tare at the same pitch and tail state, shape (6,), V.
    calibration : AtiCalibration
        Balance calibration whose tool transform gives the body frame at the vehicle reference point.
    hall_settings : HallEdgeSettings, optional
        Hall edge detection settings.
    tare_volts_standard_error : numpy.ndarray, optional
        Standard error of each tare voltage mean, shape (6,), V (see :func:`tare_volts_and_error`); propagated
        through the calibration matrix into ``tare_standard_error``. Default: the tare is taken as exact.
    """
    cycles = flap_cycles(hall_v, sample_rate_hz, hall_settings)
    volts_per_cycle = cycle_means(np.asarray(gauge_volts, dtype=float), cycles, sample_rate_hz)
    per_cycle = calibration.forces_from_voltages(
        volts_per_cycle, np.asarray(tare_volts, dtype=float)
    )
    spread = per_cycle.std(axis=0, ddof=1)
    adjacent = np.isclose(cycles.start_s[1:], cycles.end_s[:-1], rtol=0.0, atol=1e-9)
    return CycleAveragedLoads(
        per_cycle=per_cycle,
        mean=per_cycle.mean(axis=0),
        spread=spread,
        standard_error=standard_error_of_cycle_mean(per_cycle, adjacent),
        flapping_frequency_hz=float(cycles.frequency_hz.mean()),
        rejected_cycles=cycles.rejected_count,
        tare_standard_error=propagated_standard_error(calibration, tare_volts_standard_error),
    )


def standard_error_of_cycle_mean(per_cycle: np.ndarray, adjacent: np.ndarray) -> np.ndarray:
    """Standard error of the mean over cycles, allowing for correlation between neighbouring cycles.

    A cycle boundary timed a little late leaves a bit of flap ripple in one cycle and takes it from the next,
    so neighbouring cycle means are negatively correlated and their errors cancel in the mean over a run of
    adjacent cycles; ``spread / sqrt(n)`` then overstates the error (by 3x for M in the simulator). The
    variance of the mean is estimated as ``(c0 + 2 c1) / n`` with ``c0`` the variance over cycles and ``c1``
    the lag-1 autocovariance over pairs of adjacent cycles (``adjacent[i]``: cycle i + 1 starts where cycle i
    ends), floored at ``c0 / n**2`` (the error if only the two outer boundaries counted).

    Parameters
    ----------
    per_cycle : numpy.ndarray
        Shape (n_cycles, n_loads), any unit.
    adjacent : numpy.ndarray
        Shape (n_cycles - 1,), bool.
    """
    count = len(per_cycle)
    deviations = per_cycle - per_cycle.mean(axis=0)
    variance = (deviations**2).sum(axis=0) / (count - 1)
    lag_one = (deviations[:-1] * deviations[1:])[np.asarray(adjacent, dtype=bool)].sum(
        axis=0
    ) / count
    long_run_variance = np.maximum(variance + 2.0 * lag_one, variance / count)
    return np.sqrt(long_run_variance / count)


def tare_volts_and_error(tare_gauge_volts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean of a wind-off tare record and its standard error, each shape (6,), V.

    The motor is off during a tare, so the samples carry only gauge noise, taken as independent.
    """
    samples = np.asarray(tare_gauge_volts, dtype=float)
    if len(samples) < 2:
        raise UserInputError("tare", f"a tare needs at least 2 samples, got {len(samples)}")
    return samples.mean(axis=0), samples.std(axis=0, ddof=1) / np.sqrt(len(samples))


def propagated_standard_error(
    calibration: AtiCalibration, volts_standard_error: np.ndarray | None
) -> np.ndarray:
    """Standard error of the six loads (N, N m) from independent errors of the six gauge voltages (V)."""
    if volts_standard_error is None:
        return np.zeros(6)
    matrix = calibration.matrix_si
    variance = (matrix**2) @ (np.asarray(volts_standard_error, dtype=float) ** 2)
    return np.sqrt(variance)
