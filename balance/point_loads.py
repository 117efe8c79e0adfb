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
    tare_volts_covariance: np.ndarray | None = None,
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
    tare_volts_covariance : numpy.ndarray, optional
        Covariance of the tare's mean gauge voltages, shape (6, 6), V^2 (see :func:`tare_volts_and_covariance`);
        propagated through the calibration matrix into ``tare_standard_error``. Default: the tare is taken as
        exact.
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
        standard_error=standard_error_of_cycle_mean(
            per_cycle, adjacent, 0.5 * (cycles.start_s + cycles.end_s)
        ),
        flapping_frequency_hz=cycles.mean_frequency_hz,
        rejected_cycles=cycles.rejected_count,
        tare_standard_error=propagated_standard_error(calibration, tare_volts_covariance),
    )


def standard_error_of_cycle_mean(
    per_cycle: np.ndarray, adjacent: np.ndarray, cycle_centres_s: np.ndarray | None = None
) -> np.ndarray:
    """Standard error of the mean over cycles, allowing for correlation between neighbouring cycles and for the
    balance's drift across the record.

    A cycle boundary timed a little late leaves a bit of flap ripple in one cycle and takes it from the next,
    so neighbouring cycle means are negatively correlated and their errors cancel in the mean over a run of
    adjacent cycles; ``spread / sqrt(n)`` then overstates the error (by 3x for M in the simulator). The
    variance of the mean is estimated as ``(c0 + 2 c1) / n`` with ``c0`` the variance over cycles and ``c1``
    the lag-1 autocovariance over pairs of adjacent cycles (``adjacent[i]``: cycle i + 1 starts where cycle i
    ends), floored at ``c0 / n**2`` (the error if only the two outer boundaries counted).

    With ``cycle_centres_s`` the deviations are taken from a straight line in time rather than from the mean: a
    balance warming over the 2 s of a record adds a ramp to the cycle means (about 0.4 mN in X on the simulated
    rig, thirty times the noise) that the zero interpolated between bracketing tares to the record's middle
    removes from the mean (docs/processed-tables.md), so it must not count as scatter (it made the stated error
    of a sweep point 3-5x too large).

    Parameters
    ----------
    per_cycle : numpy.ndarray
        Shape (n_cycles, n_loads), any unit.
    adjacent : numpy.ndarray
        Shape (n_cycles - 1,), bool.
    cycle_centres_s : numpy.ndarray, optional
        Shape (n_cycles,): the middle of each cycle, s.
    """
    count = len(per_cycle)
    if cycle_centres_s is None or count < 4:
        deviations = per_cycle - per_cycle.mean(axis=0)
        fitted = 1
    else:
        design = np.column_stack([np.ones(count), cycle_centres_s - np.mean(cycle_centres_s)])
        coefficients, *_ = np.linalg.lstsq(design, per_cycle, rcond=None)
        deviations = per_cycle - design @ coefficients
        fitted = 2
    variance = (deviations**2).sum(axis=0) / (count - fitted)
    lag_one = (deviations[:-1] * deviations[1:])[np.asarray(adjacent, dtype=bool)].sum(
        axis=0
    ) / count
    long_run_variance = np.maximum(variance + 2.0 * lag_one, variance / count)
    return np.sqrt(long_run_variance / count)


TARE_BATCHES = 40
"""Batches a tare record is cut into to estimate the covariance of its mean (batch means, 39 degrees of freedom)."""


def tare_volts_and_covariance(tare_gauge_volts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean of a wind-off tare record, shape (6,), V, and the covariance of that mean, shape (6, 6), V^2.

    The covariance is that of the means of :data:`TARE_BATCHES` consecutive batches divided by their number, so
    noise correlated in time (mains pick-up, slow wander) is counted, and so is noise the six gauges share: the
    gauges of a Nano-17 read one strain field, and a load-space noise maps through the inverse calibration into
    strongly correlated gauge voltages. Treating the gauges as independent overstated the tare's error in X
    and Z by 35-90 % on the simulated rig (and would understate it for other correlations). Records shorter than
    two samples per batch use the sample covariance over ``n`` (white noise assumed).
    """
    samples = np.asarray(tare_gauge_volts, dtype=float)
    count = len(samples)
    if count < 2:
        raise UserInputError("tare", f"a tare needs at least 2 samples, got {count}")
    batch_size = count // TARE_BATCHES
    if batch_size >= 2:
        batch_means = (
            samples[: batch_size * TARE_BATCHES].reshape(TARE_BATCHES, batch_size, -1).mean(axis=1)
        )
        covariance = np.cov(batch_means, rowvar=False) / TARE_BATCHES
    else:
        covariance = np.cov(samples, rowvar=False) / count
    return samples.mean(axis=0), covariance


def propagated_standard_error(
    calibration: AtiCalibration, volts_covariance: np.ndarray | None
) -> np.ndarray:
    """Standard error of the six loads (N, N m) from the covariance of the six gauge voltages (V^2, (6, 6))."""
    if volts_covariance is None:
        return np.zeros(6)
    matrix = calibration.matrix_si
    return np.sqrt(
        np.clip(np.diag(matrix @ np.asarray(volts_covariance, float) @ matrix.T), 0, None)
    )
