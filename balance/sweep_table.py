"""The cycle-averaged table of a tunnel sweep: one row per measured set point, tare-corrected, body frame.

Everything needed comes from the recordings themselves: the raw voltages, the set-point table, the balance
calibration file named in the run metadata (its content hash is checked) and the rig's tool transform. Each
measurement uses the newest wind-off tare taken before it at the same pitch and tail state, searched across all
runs of the sweep (a resumed sweep may have its tare in an earlier run); when the plan bracketed the point with a
second tare after it in the same run, the gauge zero is interpolated linearly in time between the two
(:mod:`ornitail.balance.tare_drift`), which corrects the balance's drift between them.

Records the data cannot support are refused, each in one line naming the run and the set point: a record with
samples lost inside it (counter gaps), and a record with samples saturated at the ADC limit or over the sensor's
rated load (``keep_saturated=True`` keeps those, flagged in the table). A lossy record that a later run of the
same sweep chain (``resumed_from_run_id``) recorded again is replaced by the new record.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.acquisition.calibration_copies import (
    CalibrationSources,
    ResolvedCalibrationFile,
    resolve_calibration_file,
)
from ornitail.acquisition.counter_gaps import find_counter_gaps
from ornitail.acquisition.recording_layout import SetPointRecord
from ornitail.acquisition.recording_reader import Recording, load_recording
from ornitail.acquisition.sweep_plan import RETURN_TO_REFERENCE_SWEEP
from ornitail.balance.condition_correction import REFERENCE_COLUMNS
from ornitail.balance.hall_cycles import HallEdgeSettings
from ornitail.balance.point_covariance import (
    generalised_least_squares,
    point_covariance,
    record_to_record_variance,
)
from ornitail.balance.point_loads import (
    BODY_LOAD_NAMES,
    CycleAveragedLoads,
    cycle_averaged_loads,
    propagated_standard_error,
    tare_volts_and_covariance,
)
from ornitail.balance.run_drift_fit import RunDriftFit, fit_run_drift, zero_correction
from ornitail.balance.tare_drift import (
    RecordedTare,
    RunningClock,
    TareCorrection,
    middle_sample_index,
    running_clock_of,
)
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.flapping_frequency_check import (
    check_flapping_frequency,
)
from ornitail.calibration.signal_channels import GAUGE_CHANNELS
from ornitail.calibration.tool_transform import ToolTransform
from ornitail.core.errors import UserInputError
from ornitail.vehicle.constants import DELFLY_GEAR_RATIO, STANDARD_GRAVITY_M_S2

SATURATION_COLUMNS = (
    "saturated_samples",
    "over_range_samples",
    "tare_saturated_samples",
    "tare_over_range_samples",
)
BALANCE_RESOLUTION_N = 0.149e-3 * STANDARD_GRAVITY_M_S2
"""Nano-17 force resolution, 0.149 gram-force (docs/background.md section 3), N."""
MEASURED_CONDITION_COLUMNS = ("v_measured_m_s", "theta_measured_deg")
"""Columns of the conditions read during each record (tunnel velocity, m/s; pitch, deg)."""


def balance_calibration_of(
    recording: Recording, sources: CalibrationSources | None = None
) -> tuple[AtiCalibration, ResolvedCalibrationFile]:
    """The balance calibration the run was recorded with (found by content hash, or the user's override in
    ``sources``) with the rig's tool transform, and where it was found."""
    resolved = resolve_calibration_file(
        recording.run_directory, recording.metadata, "balance", sources
    )
    transform_values = recording.metadata.get("rig", {}).get("tool_transform_mm_deg", [0.0] * 6)
    calibration = AtiCalibration.from_file(resolved.path).with_tool_transform(
        ToolTransform.from_mm_deg(*transform_values)
    )
    return calibration, resolved


@dataclass(frozen=True)
class _RecordedPoint:
    recording: Recording
    record: SetPointRecord
    row: pd.Series
    order: tuple[str, int]


@dataclass(frozen=True)
class MeasuredSetPoint:
    """One measured (not tare) set point with the tare and calibration that turn it into body loads.

    Attributes
    ----------
    recording : Recording
        The run the point was recorded in.
    row : pandas.Series
        The point's row of :meth:`Recording.set_points_frame` (set values in SI, ``sweep``, ``motor_rpm_mean``).
    tare_volts, tare_volts_covariance : numpy.ndarray
        The gauges' zero subtracted from the point (see ``tare``), shape (6,), V, and its covariance, shape (6, 6),
        V^2.
    calibration : AtiCalibration
        Balance calibration with the rig's tool transform (body frame at the rig's reference point).
    tare_id : str
        ``<run id>#<plan point index>`` of the tare used (points sharing it share its error).
    flags : dict of str to int
        ``saturated_samples`` and ``over_range_samples`` of the point's record and ``tare_saturated_samples``
        and ``tare_over_range_samples`` of its tare's (-1: the recording did not check); non-zero only when
        flagged records were kept (``keep_saturated=True``).
    tare : TareCorrection, optional
        The point's zero as a weighted sum of its run's tares (from the run's drift fit, or the tare before alone);
        ``tare_volts`` and ``tare_volts_covariance`` are that zero and its covariance.
    drift_fit : RunDriftFit, optional
        The drift fit of the point's run (its statement goes to the ``drift_check`` column).
    calibration_file : ResolvedCalibrationFile, optional
        Where the balance calibration file was found (and the warning of an override with other content).
    """

    recording: Recording
    row: pd.Series
    tare_volts: np.ndarray
    tare_volts_covariance: np.ndarray
    calibration: AtiCalibration
    tare_id: str
    flags: dict[str, int] = field(default_factory=dict)
    tare: TareCorrection | None = None
    drift_fit: RunDriftFit | None = None
    calibration_file: ResolvedCalibrationFile | None = None

    def tare_columns(self) -> dict[str, float | str]:
        """The point's zero in table columns (:func:`tare_term_columns`)."""
        correction = self.tare or TareCorrection(
            RecordedTare(self.tare_id, "", 0.0, self.tare_volts, self.tare_volts_covariance),
            (),
        )
        return tare_term_columns(correction, self.calibration, self.drift_fit)

    def gauge_and_hall_volts(self) -> tuple[np.ndarray, np.ndarray]:
        """Raw gauge voltages (n, 6) and Hall line (n,) of the point, V; a record with lost samples is refused
        (cycle timing is taken from the row spacing)."""
        frame = self.recording.set_point_frame(int(self.row["set_point_index"]))
        gaps = find_counter_gaps(frame["sample_counter"].to_numpy())
        if gaps:
            raise UserInputError(
                f"{self.recording.run_directory}: set point {int(self.row['plan_point_index'])}",
                f"{sum(gap.missing_samples for gap in gaps)} samples lost inside the record "
                f"({len(gaps)} sample counter gap(s)); record the point again",
            )
        return (
            frame[list(GAUGE_CHANNELS)].to_numpy(dtype=float),
            frame["hall_v"].to_numpy(dtype=float),
        )

    def loads(self, hall_settings: HallEdgeSettings | None = None) -> CycleAveragedLoads:
        """Tare-corrected cycle-averaged body loads of the point."""
        gauge_volts, hall_v = self.gauge_and_hall_volts()
        try:
            return cycle_averaged_loads(
                gauge_volts,
                hall_v,
                self.recording.sample_rate_hz,
                self.tare_volts,
                self.calibration,
                hall_settings,
                tare_volts_covariance=self.tare_volts_covariance,
            )
        except UserInputError as error:
            raise UserInputError(
                f"{self.recording.run_directory}: set point {int(self.row['plan_point_index'])}",
                error.problem,
            ) from None


def _recorded_points(run_directories: Iterable[Path]) -> list[_RecordedPoint]:
    points = []
    for directory in run_directories:
        recording = load_recording(directory)
        table = recording.set_points_frame()
        for record, (_, row) in zip(recording.set_points, table.iterrows(), strict=True):
            points.append(
                _RecordedPoint(
                    recording,
                    record,
                    row,
                    (recording.metadata["start_time_utc"], int(row["set_point_index"])),
                )
            )
    return sorted(_without_superseded(points), key=lambda point: point.order)


def _without_superseded(points: list[_RecordedPoint]) -> list[_RecordedPoint]:
    """Drop records whose plan point a later run of the same chain recorded again (a resumed sweep): every
    earlier record of a measurement (a resume records a measurement again only when its record or the tare that
    zeroes it lost samples), and lossy records of a tare (a whole tare recorded again to zero a resumed point
    still zeroes the points of its own run)."""
    resumed_from = {
        point.recording.run_id: point.recording.metadata.get("configuration", {}).get(
            "resumed_from_run_id"
        )
        for point in points
    }

    def continues(later_run_id: str, earlier_run_id: str) -> bool:
        run_id = resumed_from.get(later_run_id)
        while run_id is not None:
            if run_id == earlier_run_id:
                return True
            run_id = resumed_from.get(run_id)
        return False

    recorded_in: dict[int, set[str]] = {}
    for point in points:
        recorded_in.setdefault(point.record.plan_point_index, set()).add(point.recording.run_id)
    kept = []
    for point in points:
        run_id = point.recording.run_id
        later = recorded_in[point.record.plan_point_index] - {run_id}
        superseded = point.record.kind != "tare" or point.record.samples_missing_in_record
        if superseded and any(continues(other, run_id) for other in later):
            continue
        kept.append(point)
    return kept


def _flag_counts(record: SetPointRecord, prefix: str = "") -> dict[str, int]:
    return {
        f"{prefix}saturated_samples": -1
        if record.saturated_samples is None
        else int(record.saturated_samples),
        f"{prefix}over_range_samples": -1
        if record.over_range_samples is None
        else int(record.over_range_samples),
    }


def _refuse_flagged(point: _RecordedPoint) -> None:
    record = point.record
    raise UserInputError(
        f"{point.recording.run_directory}: set point {record.plan_point_index}",
        f"{record.saturated_samples or 0} of "
        f"{record.last_sample_index - record.first_sample_index + 1} samples saturated (a channel at the "
        f"ADC limit or the board's over-range flag) and {record.over_range_samples or 0} over the sensor's "
        f"rated load in the {record.kind}'s record; its loads are clipped: record it again within range, or "
        "process it with saturated records kept, flagged",
        remedy_parameter="keep_saturated",
    )


def _tare_key(point: _RecordedPoint) -> tuple[bool, float]:
    """Tail state and pitch: a tare serves measurements with the same weight and gravity direction."""
    return bool(point.row["tail_attached"]), round(float(point.row["pitch_rad"]), 9)


def _tare_record(tare: RecordedTare) -> SetPointRecord:
    assert tare.record is not None  # tares read from a recording always carry their record
    return tare.record


def tare_term_columns(
    correction: TareCorrection, calibration: AtiCalibration, drift_fit: RunDriftFit | None
) -> dict[str, float | str]:
    """``tare_terms`` (``<tare id>=<weight>`` of every tare in the zero, ``;``-separated; the tare before with
    weight 1 when there are no terms), ``drift_model``, ``drift_check`` (the run's drift fit statement) and, per body
    load, ``<load>_tare_terms_se``: the standard error of each of those tares alone (inflated as the zero's), in the
    same order (N, N m; for the covariance of points sharing one)."""
    terms = correction.terms or ((correction.before, 1.0),)
    errors = [
        propagated_standard_error(
            calibration, correction.covariance_inflation * tare.volts_covariance
        )
        for tare, _ in terms
    ]
    columns: dict[str, float | str] = {
        "tare_terms": ";".join(f"{tare.tare_id}={weight:.12g}" for tare, weight in terms),
        "drift_model": correction.drift_model if correction.terms else "",
    }
    for index, name in enumerate(BODY_LOAD_NAMES):
        columns[f"{name}_tare_terms_se"] = ";".join(f"{float(se[index]):.9g}" for se in errors)
    columns["drift_check"] = "" if drift_fit is None else drift_fit.statement()
    return columns


def _recorded_tare(point: _RecordedPoint, clock: RunningClock) -> RecordedTare:
    frame = point.recording.set_point_frame(int(point.row["set_point_index"]))
    volts, volts_covariance = tare_volts_and_covariance(
        frame[list(GAUGE_CHANNELS)].to_numpy(dtype=float)
    )
    return RecordedTare(
        tare_id=f"{point.recording.run_id}#{int(point.row['plan_point_index'])}",
        run_id=point.recording.run_id,
        running_time=clock.at(middle_sample_index(point.record)),
        volts=volts,
        volts_covariance=volts_covariance,
        record=point.record,
    )


def _keyed_tares_by_run(
    points: list[_RecordedPoint], recorded_tares: dict[int, RecordedTare]
) -> dict[str, list[tuple[tuple[bool, float], RecordedTare]]]:
    """Each run's tares with their tail state and pitch, in recording order."""
    grouped: dict[str, list[tuple[tuple[bool, float], RecordedTare]]] = {}
    for position, tare in sorted(recorded_tares.items()):
        grouped.setdefault(tare.run_id, []).append((_tare_key(points[position]), tare))
    return grouped


def measured_set_points(
    run_directories: Iterable[Path | str],
    keep_saturated: bool = False,
    calibration_sources: CalibrationSources | None = None,
) -> list[MeasuredSetPoint]:
    """Every measured set point of the given runs in recording order, each paired with its tare.

    Parameters
    ----------
    run_directories : iterable of path
        The runs (e.g. a sweep chain, oldest first).
    keep_saturated : bool
        Keep records with saturated or over-range samples (their counts go to :attr:`MeasuredSetPoint.flags`)
        instead of refusing them.
    calibration_sources : CalibrationSources, optional
        Search folders and overrides for the balance calibration file (besides the run folder's copy and the
        recorded path; :func:`~ornitail.acquisition.calibration_copies.resolve_calibration_file`).

    Raises
    ------
    UserInputError
        If a measurement has no earlier tare at its pitch and tail state in its run, no file with the recorded balance
        calibration's content is found, or (unless
        ``keep_saturated``) a measurement or tare has saturated or over-range samples.
    """
    points = _recorded_points(Path(directory) for directory in run_directories)
    calibrations: dict[str, tuple[AtiCalibration, ResolvedCalibrationFile]] = {}
    clocks: dict[str, RunningClock] = {}
    for point in points:
        run_id = point.recording.run_id
        if run_id not in clocks:
            clocks[run_id] = running_clock_of(
                point.recording.set_points, point.recording.counter_gaps()
            )
    recorded_tares = {
        position: _recorded_tare(point, clocks[point.recording.run_id])
        for position, point in enumerate(points)
        if point.row["kind"] == "tare"
    }
    fits = {
        run_id: fit_run_drift(run_id, keyed)
        for run_id, keyed in _keyed_tares_by_run(points, recorded_tares).items()
    }
    tares: dict[
        tuple[str, tuple[bool, float]], RecordedTare
    ] = {}  # (run, tail state and pitch) -> newest
    measured = []
    for position, point in enumerate(points):
        row = point.row
        key = _tare_key(point)
        if point.record.is_flagged and not keep_saturated:
            _refuse_flagged(point)
        run_id = point.recording.run_id
        if row["kind"] == "tare":
            tares[run_id, key] = recorded_tares[position]
            continue
        before = tares.get((run_id, key))
        if before is None:
            raise UserInputError(
                f"{point.recording.run_directory}: set point {int(row['plan_point_index'])}",
                f"no wind-off tare at theta = {math.degrees(row['pitch_rad']):.2f} deg "
                f"({'tailed' if key[0] else 'tailless'}) was recorded before it in its run (a tare of another "
                "run zeroes another stream, taken minutes or hours apart: the balance's drift since would be in "
                "the loads); record it again with its tare (a resumed sweep records them)",
            )
        if run_id not in calibrations:
            calibrations[run_id] = balance_calibration_of(point.recording, calibration_sources)
        calibration, calibration_file = calibrations[run_id]
        fit = fits.get(run_id)
        correction = zero_correction(
            fit, key, clocks[run_id].at(middle_sample_index(point.record)), before
        )
        flags = {**_flag_counts(point.record), **_flag_counts(_tare_record(before), "tare_")}
        measured.append(
            MeasuredSetPoint(
                point.recording,
                row,
                correction.volts,
                correction.volts_covariance,
                calibration,
                before.tare_id,
                flags,
                correction,
                fit,
                calibration_file,
            )
        )
    return measured


def recorded_gear_ratio(recording: Recording) -> float:
    """The motor's gear ratio the run was recorded with (``run.json`` ``rig.gear_ratio``; runs recorded before it
    was stored: the DelFly II's 21.33)."""
    value = recording.metadata.get("rig", {}).get("gear_ratio")
    return DELFLY_GEAR_RATIO if value is None else float(value)


def frequency_cross_check_record(
    hall_frequency_hz: float, motor_rpm: float | None, gear_ratio: float = DELFLY_GEAR_RATIO
) -> dict[str, float | bool]:
    """Hall against motor flapping frequency for one point: ``motor_rpm``, ``f_motor_hz`` (rpm / 60 /
    ``gear_ratio``), ``f_disagreement`` ((Hall - motor) / motor) and ``f_disagrees`` (beyond 2 %); no rpm reading
    gives NaN and no flag."""
    if motor_rpm is None or not math.isfinite(float(motor_rpm)):
        return {
            "motor_rpm": math.nan,
            "f_motor_hz": math.nan,
            "f_disagreement": math.nan,
            "f_disagrees": False,
            "gear_ratio": gear_ratio,
        }
    check = check_flapping_frequency(hall_frequency_hz, float(motor_rpm), gear_ratio=gear_ratio)
    return {
        "gear_ratio": gear_ratio,
        "motor_rpm": float(motor_rpm),
        "f_motor_hz": float(check.motor_frequency_hz),
        "f_disagreement": float(check.relative_disagreement),
        "f_disagrees": bool(check.disagrees),
    }


def cycle_averaged_table(
    run_directories: Iterable[Path | str], keep_saturated: bool = False
) -> pd.DataFrame:
    """One row per measured set point of the given runs, in recording order (see :func:`table_of_points`)."""
    return table_of_points(measured_set_points(run_directories, keep_saturated))


def table_of_points(
    points: list[MeasuredSetPoint], on_point: Callable[[int, int], None] | None = None
) -> pd.DataFrame:
    """One row per measured set point, in the order given.

    Columns: ``run_id``, ``tail_id``, ``x_h_mm``, ``plan_point_index``, ``sweep``, ``tailed``, ``repeat``,
    ``theta_deg``, ``v_m_s``, ``f_set_hz``, ``tare_id`` (``<run id>#<plan point index>`` of the tare before),
    ``tare_terms`` (``<tare id>=<weight>`` of every tare in the zero, ``;``-separated), ``drift_model`` (how the
    drift between tares was treated), ``drift_check`` (the run's drift fit),
    ``f_hall_hz``, ``cycles``, ``rejected_cycles``, ``saturated_samples``, ``over_range_samples``,
    ``tare_saturated_samples``, ``tare_over_range_samples`` (rows of the record and of its tare flagged at the
    ADC limit / over the rated load; -1: not checked), the flapping
    frequency cross-check ``motor_rpm``, ``f_motor_hz`` (= rpm / 60 / 21.33), ``f_disagreement`` ((Hall - motor) /
    motor) and ``f_disagrees`` (beyond 2 %), and for each body load of
    :data:`~ornitail.balance.point_loads.BODY_LOAD_NAMES` its mean, ``_2sigma`` (2 sigma over cycles), ``_se``
    (standard error of the mean over cycles), ``_tare_se`` (standard error of the subtracted zero) and
    ``_tare_terms_se`` (of each tare of ``tare_terms``, unweighted: for the covariance of points sharing one).
    Loads are in N and N m, body frame, about the rig's reference point.

    ``on_point(done, total)`` is called after each point (progress display).

    Raises
    ------
    UserInputError
        If a record holds too few flapping cycles.
    """
    rows = []
    for done, point in enumerate(points, start=1):
        row = point.row
        loads = point.loads()
        configuration = point.recording.metadata.get("configuration", {})
        x_h_m = configuration.get("x_h_m")
        rows.append(
            {
                "run_id": point.recording.run_id,
                "tail_id": configuration.get("tail_id") or "",
                "x_h_mm": math.nan if x_h_m is None else 1000.0 * float(x_h_m),
                "plan_point_index": int(row["plan_point_index"]),
                "sweep": row.get("sweep", ""),
                "tailed": bool(row["tail_attached"]),
                "repeat": int(row["repeat_index"]),
                "theta_deg": math.degrees(float(row["pitch_rad"])),
                "v_m_s": float(row["tunnel_velocity_m_s"]),
                "f_set_hz": float(row["flapping_frequency_hz"]),
                **measured_conditions_record(row),
                "tare_id": point.tare_id,
                **point.tare_columns(),
                **{name: point.flags.get(name, -1) for name in SATURATION_COLUMNS},
                **loads.as_record(),
                **frequency_cross_check_record(
                    loads.flapping_frequency_hz,
                    row.get("motor_rpm_mean"),
                    recorded_gear_ratio(point.recording),
                ),
            }
        )
        if on_point is not None:
            on_point(done, len(points))
    return pd.DataFrame(rows)


def measured_conditions_record(row: pd.Series) -> dict[str, float]:
    """The conditions read during the record (``v_measured_m_s``, ``theta_measured_deg``); NaN for runs
    recorded before the sweep read them (and for manual recordings), whose set values then stand in."""
    velocity = row.get("tunnel_velocity_mean_m_s", math.nan)
    pitch = row.get("pitch_mean_rad", math.nan)
    return {
        "v_measured_m_s": math.nan if velocity is None else float(velocity),
        "theta_measured_deg": math.nan if pitch is None else math.degrees(float(pitch)),
    }


def saturation_warnings(table: pd.DataFrame) -> list[str]:
    """One line per kept set point whose record or tare has saturated or over-range samples."""
    lines = []
    for _, row in table.iterrows():
        counts = {name: int(row.get(name, -1)) for name in SATURATION_COLUMNS}
        if any(count > 0 for count in counts.values()):
            lines.append(
                f"warning: {row['run_id']} set point {int(row['plan_point_index'])} ({row['sweep']}) kept "
                f"with saturated samples: {max(counts['saturated_samples'], 0)} at the ADC limit and "
                f"{max(counts['over_range_samples'], 0)} over the rated load in its record, "
                f"{max(counts['tare_saturated_samples'], 0)} and "
                f"{max(counts['tare_over_range_samples'], 0)} in its tare; its loads are clipped"
            )
    return lines


def frequency_check_warnings(table: pd.DataFrame) -> list[str]:
    """One line per set point whose Hall and motor flapping frequencies disagree by more than 2 %."""
    lines = []
    for _, row in table[table["f_disagrees"].astype(bool)].iterrows():
        lines.append(
            f"warning: {row['run_id']} set point {int(row['plan_point_index'])} ({row['sweep']}): Hall "
            f"{row['f_hall_hz']:.3f} Hz vs motor {row['f_motor_hz']:.3f} Hz (rpm / 60 / "
            f"{row.get('gear_ratio', DELFLY_GEAR_RATIO):g}), {100 * row['f_disagreement']:+.1f} %: slipping "
            "gear, missed Hall "
            "edges or a wrong rpm channel"
        )
    return lines


def _pooled_repeats(group: pd.DataFrame, name: str, record_variance: float) -> pd.Series:
    """Mean of the repeat means of one load, its standard error with ``record_variance`` (unit of ``name``
    squared) added to every repeat, and the repeatability check's figures (see :func:`tail_contribution`)."""
    means = group[name].to_numpy(dtype=float)
    count = len(means)
    covariance = point_covariance(group, name)
    chi_square = 0.0
    if count > 1:
        # Generalised least squares: the repeats' scatter about their best common value in their own errors.
        chi_square = generalised_least_squares(np.ones((count, 1)), means, covariance)[3]
    standard_error = math.sqrt(float(covariance.sum())) / count
    extra = record_variance if math.isfinite(record_variance) else 0.0
    with_scatter = math.sqrt(float(covariance.sum()) + count * extra) / count
    return pd.Series(
        {
            name: float(means.mean()),
            f"{name}_se": with_scatter,
            f"{name}_repeat_chi_square": chi_square,
            f"{name}_repeat_inflation": with_scatter / standard_error,
            f"{name}_cycle_2sigma": float(group[f"{name}_2sigma"].mean()),
            **{
                column: float(group[column].mean()) if column in group else math.nan
                for column in MEASURED_CONDITION_COLUMNS + REFERENCE_COLUMNS
            },
            "repeats": count,
            "cycles": int(group["cycles"].sum()),
        }
    )


def _repeat_record_variance(repeats: pd.DataFrame, name: str) -> float:
    """Record-to-record variance of ``name`` (unit squared) from the repeats of one set point, tailed and tailless
    together (one common value per tail state): Paule-Mandel, NaN when no state has two repeats."""
    states = repeats["tailed"].astype(bool).to_numpy()
    design = np.column_stack([states, ~states]).astype(float)
    design = design[:, design.any(axis=0)]
    return record_to_record_variance(
        design, repeats[name].to_numpy(dtype=float), point_covariance(repeats, name)
    )


def tail_contribution(table: pd.DataFrame) -> pd.DataFrame:
    """Tailed minus tailless at every set point measured both ways, with propagated uncertainty.

    The difference is taken between the tail states' own repeats, which the plan interleaves in time (T, T-less,
    T, ...) so that the balance's drift falls on both alike. The returns to the steady state after each sweep
    (``sweep == "reference"``) are left out: all of them fall in the first tailed run, and with them four of six
    tailed records shared that run's zero against three tailless records in three runs (on the simulated rig the
    tail's X then covered the truth in 0.85 of 40 sweeps, RMS z 1.21; without them 0.95 and 1.00). They serve
    the derivative fit, whose record scatter they help measure.

    Repeats are pooled: the mean of the repeat means. Its standard error is propagated from the repeats'
    covariance (:func:`~ornitail.balance.point_covariance.point_covariance`: cycle scatter and the tares they
    share, with their weights) plus a record-to-record variance ``s**2`` on each repeat, ``sqrt(1' (C + s**2 I) 1)
    / n``. The repeatability check measures ``s**2`` on the repeats of both tail states at the set point together
    (each state its own common value, so 2 + 2 degrees of freedom with three repeats each): the Paule-Mandel value
    that brings their generalised chi-square to its degrees of freedom, 0 when the repeats agree with their
    errors (``<load>_record_scatter``, unit of the load; ``<load>_repeat_chi_square_tailed`` / ``_tailless``: each
    state's chi-square in its own errors; ``<load>_repeat_inflation_...``: the factor its sigma grew by, 1 when
    not). On the simulated rig repeats scatter beyond their errors by about a fifth, which a test at p = 0.01
    on each state's two degrees of freedom (before stop 20) let through: the tail's X covered the truth in 0.85
    of 40 sweeps. Always taking the larger of the propagated error and the repeats' ``std / sqrt(n)`` (earlier
    still) overstated the error: with three repeats that scatter is a two-degree-of-freedom guess, larger than the
    truth half the time. ``<load>_sigma`` is the standard error of the difference
    (tailed and tailless independent); ``<load>_resolvable`` says whether the difference exceeds both twice that
    sigma and, for forces, the balance resolution (moments: twice sigma alone); ``<load>_cycle_2sigma_tailed`` and
    ``_tailless`` are the single-cycle scatter (2 sigma over cycles). Loads about the rig's reference point, so
    tailed and tailless moments are about the same point.
    """
    keys = ["theta_deg", "v_m_s", "f_set_hz"]
    if "sweep" in table:
        table = table[table["sweep"].astype(str) != RETURN_TO_REFERENCE_SWEEP]
    rounded = table.assign(**{key: table[key].round(6) for key in keys})
    record_variances = {
        point: {name: _repeat_record_variance(repeats, name) for name in BODY_LOAD_NAMES}
        for point, repeats in rounded.groupby(keys)
    }
    pooled = {}
    for tailed, group in rounded.groupby("tailed"):
        pooled[bool(tailed)] = {
            name: group.groupby(keys)[list(group.columns)].apply(
                lambda repeats, name=name: _pooled_repeats(
                    repeats, name, record_variances[repeats.name][name]
                )
            )
            for name in BODY_LOAD_NAMES
        }
    if True not in pooled or False not in pooled:
        return pd.DataFrame()
    common = pooled[True][BODY_LOAD_NAMES[0]].index.intersection(
        pooled[False][BODY_LOAD_NAMES[0]].index
    )
    result = pd.DataFrame(index=common)
    for state, label in ((True, "tailed"), (False, "tailless")):
        first_load = pooled[state][BODY_LOAD_NAMES[0]].loc[common]
        result[f"repeats_{label}"] = first_load["repeats"].astype(int)
        result[f"cycles_{label}"] = first_load["cycles"].astype(int)
        for column in MEASURED_CONDITION_COLUMNS:
            result[f"{column}_{label}"] = first_load[column]
    for column in REFERENCE_COLUMNS:
        result[column] = pooled[True][BODY_LOAD_NAMES[0]].loc[common, column]
    for name in BODY_LOAD_NAMES:
        tailed, tailless = pooled[True][name].loc[common], pooled[False][name].loc[common]
        difference = tailed[name] - tailless[name]
        sigma = np.hypot(tailed[f"{name}_se"], tailless[f"{name}_se"])
        threshold = np.maximum(2 * sigma, BALANCE_RESOLUTION_N if name.endswith("_n") else 0.0)
        result[name] = difference
        result[f"{name}_sigma"] = sigma
        result[f"{name}_resolvable"] = np.abs(difference) > threshold
        result[f"{name}_cycle_2sigma_tailed"] = tailed[f"{name}_cycle_2sigma"]
        result[f"{name}_cycle_2sigma_tailless"] = tailless[f"{name}_cycle_2sigma"]
        result[f"{name}_record_scatter"] = [
            math.sqrt(record_variances[point][name]) for point in common
        ]
        for label, pooled_state in (("tailed", tailed), ("tailless", tailless)):
            for quantity in ("repeat_chi_square", "repeat_inflation"):
                result[f"{name}_{quantity}_{label}"] = pooled_state[f"{name}_{quantity}"]
    return result.reset_index()
