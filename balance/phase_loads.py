"""Phase-averaged body-frame loads over the flap cycle of one set point (for plots of the flapping loads).

Gauge voltages are resampled onto phase bins per cycle (:func:`~ornitail.balance.cycle_averages.phase_average`),
tare-corrected and turned into body-frame loads about the rig's reference point by the calibration with its tool
transform (linear, so binning before the matrix is exact); then mean and spread over cycles per bin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ornitail.balance.cycle_averages import phase_average
from ornitail.balance.hall_cycles import HallEdgeSettings, flap_cycles
from ornitail.balance.point_loads import BODY_LOAD_NAMES
from ornitail.calibration.ati_calibration import AtiCalibration


@dataclass(frozen=True)
class PhaseAveragedLoads:
    """Body-frame loads over the flap cycle.

    Attributes
    ----------
    phase : numpy.ndarray
        Bin centres as a fraction of the cycle (0 = Hall edge), shape (n_bins,).
    mean, spread : numpy.ndarray
        Mean and sample standard deviation over cycles per bin, shape (n_bins, 6), columns
        :data:`~ornitail.balance.point_loads.BODY_LOAD_NAMES` (N, N m; body frame, M positive nose-down).
    cycle_count : int
        Accepted cycles averaged.
    flapping_frequency_hz : float
        Mean Hall frequency of those cycles, Hz.
    """

    phase: np.ndarray
    mean: np.ndarray
    spread: np.ndarray
    cycle_count: int
    flapping_frequency_hz: float

    def load(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Mean and spread of one load by its name in ``BODY_LOAD_NAMES`` (e.g. ``"x_n"``)."""
        index = BODY_LOAD_NAMES.index(name)
        return self.mean[:, index], self.spread[:, index]


def phase_averaged_loads(
    gauge_volts: np.ndarray,
    hall_v: np.ndarray,
    sample_rate_hz: float,
    tare_volts: np.ndarray,
    calibration: AtiCalibration,
    n_bins: int = 50,
    hall_settings: HallEdgeSettings | None = None,
) -> PhaseAveragedLoads:
    """Tare-corrected body-frame loads of one record over the flap cycle.

    Parameters
    ----------
    gauge_volts : numpy.ndarray
        Raw gauge voltages, shape (n_samples, 6), V.
    hall_v : numpy.ndarray
        Hall line, shape (n_samples,), V.
    sample_rate_hz : float
        Sampling rate, Hz.
    tare_volts : numpy.ndarray
        Wind-off tare at the same pitch and tail state, shape (6,), V.
    calibration : AtiCalibration
        Calibration with the tool transform to the body frame at the reference point.
    n_bins : int
        Phase bins per cycle (each needs at least one sample: at 10 kHz and 17 Hz, up to 588).
    hall_settings : HallEdgeSettings, optional
        Hall edge detection settings.
    """
    cycles = flap_cycles(hall_v, sample_rate_hz, hall_settings)
    averaged = phase_average(np.asarray(gauge_volts, dtype=float), cycles, sample_rate_hz, n_bins)
    n_cycles = averaged.per_cycle.shape[0]
    volts = averaged.per_cycle.reshape(n_cycles * n_bins, 6)
    loads = calibration.forces_from_voltages(volts, np.asarray(tare_volts, dtype=float)).reshape(
        n_cycles, n_bins, 6
    )
    spread = loads.std(axis=0, ddof=1) if n_cycles > 1 else np.zeros((n_bins, 6))
    return PhaseAveragedLoads(
        phase=averaged.phase,
        mean=loads.mean(axis=0),
        spread=spread,
        cycle_count=n_cycles,
        flapping_frequency_hz=cycles.mean_frequency_hz,
    )


def phase_average_table(by_tail_state: dict[bool, PhaseAveragedLoads | None]) -> pd.DataFrame:
    """Phase-averaged loads as a table, one row per phase bin and tail state (``<cfg>-phase-average.csv``).

    Columns: ``tailed``, ``phase`` (bin centre, fraction of the cycle from the Hall edge), ``cycles``,
    ``f_hall_hz`` (Hz), and for each load of ``BODY_LOAD_NAMES`` its mean (N or N m) and ``<load>_std``, the
    standard deviation over cycles (same unit).
    """
    frames = []
    for tailed, loads in by_tail_state.items():
        if loads is None:
            continue
        columns: dict[str, object] = {
            "tailed": tailed,
            "phase": loads.phase,
            "cycles": loads.cycle_count,
            "f_hall_hz": loads.flapping_frequency_hz,
        }
        for index, name in enumerate(BODY_LOAD_NAMES):
            columns[name] = loads.mean[:, index]
            columns[f"{name}_std"] = loads.spread[:, index]
        frames.append(pd.DataFrame(columns))
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
