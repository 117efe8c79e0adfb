"""The cycle-averaged table of a tunnel sweep: one row per measured set point, tare-corrected, body frame.

Everything needed comes from the recordings themselves: the raw voltages, the set-point table, the balance
calibration file named in the run metadata (its content hash is checked) and the rig's tool transform. Each
measurement uses the newest wind-off tare taken before it at the same pitch and tail state, searched across all
runs of the sweep (a resumed sweep may have its tare in an earlier run).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.acquisition.recording_reader import Recording, load_recording
from ornitail.balance.point_loads import BODY_LOAD_NAMES, cycle_averaged_loads
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.tool_transform import ToolTransform
from ornitail.core.errors import UserInputError
from ornitail.core.hashing import content_hash_of_file

GAUGE_CHANNELS = tuple(f"gauge_{index}_v" for index in range(6))
BALANCE_RESOLUTION_N = 0.149e-3 * 9.80665
"""Nano-17 force resolution, 0.149 gram-force (domain.md section 3), N."""


def balance_calibration_of(recording: Recording) -> AtiCalibration:
    """The calibration the run names, with the rig's tool transform; refuses a changed calibration file."""
    files = recording.metadata.get("calibration_files", {})
    entry = files.get("balance")
    where = f"{recording.run_directory / 'run.json'}: calibration_files.balance"
    if not entry:
        raise UserInputError(where, "the run names no balance calibration")
    path = Path(entry["path"])
    if content_hash_of_file(path) != entry["hash"]:
        raise UserInputError(
            str(path),
            f"content differs from the calibration run {recording.run_id} was recorded with",
        )
    transform_values = recording.metadata.get("rig", {}).get("tool_transform_mm_deg", [0.0] * 6)
    return AtiCalibration.from_file(path).with_tool_transform(
        ToolTransform.from_mm_deg(*transform_values)
    )


@dataclass(frozen=True)
class _RecordedPoint:
    recording: Recording
    row: pd.Series
    order: tuple[str, int]


def _recorded_points(run_directories: Iterable[Path]) -> list[_RecordedPoint]:
    points = []
    for directory in run_directories:
        recording = load_recording(directory)
        table = recording.set_points_frame()
        for _, row in table.iterrows():
            points.append(
                _RecordedPoint(
                    recording,
                    row,
                    (recording.metadata["start_time_utc"], int(row["set_point_index"])),
                )
            )
    return sorted(points, key=lambda point: point.order)


def _mean_gauge_volts(point: _RecordedPoint) -> np.ndarray:
    frame = point.recording.set_point_frame(int(point.row["set_point_index"]))
    return frame[list(GAUGE_CHANNELS)].to_numpy(dtype=float).mean(axis=0)


def cycle_averaged_table(run_directories: Iterable[Path | str]) -> pd.DataFrame:
    """One row per measured set point of the given runs, in recording order.

    Columns: ``run_id``, ``plan_point_index``, ``sweep``, ``tailed``, ``repeat``, ``theta_deg``, ``v_m_s``,
    ``f_set_hz``, ``f_hall_hz``, ``cycles``, ``rejected_cycles``, and for each body load of
    :data:`~ornitail.balance.point_loads.BODY_LOAD_NAMES` its mean, ``_2sigma`` (2 sigma over cycles) and ``_se``
    (standard error of the mean). Loads are in N and N m, body frame, about the rig's reference point.

    Raises
    ------
    UserInputError
        If a measurement has no earlier tare at its pitch and tail state, or a calibration file changed.
    """
    points = _recorded_points(Path(directory) for directory in run_directories)
    tares: dict[tuple[bool, float], np.ndarray] = {}
    calibrations: dict[str, AtiCalibration] = {}
    rows = []
    for point in points:
        row = point.row
        tailed = bool(row["tail_attached"])
        pitch_key = round(float(row["pitch_rad"]), 9)
        if row["kind"] == "tare":
            tares[(tailed, pitch_key)] = _mean_gauge_volts(point)
            continue
        tare = tares.get((tailed, pitch_key))
        if tare is None:
            raise UserInputError(
                f"{point.recording.run_directory}: set point {int(row['plan_point_index'])}",
                f"no wind-off tare at theta = {math.degrees(row['pitch_rad']):.2f} deg "
                f"({'tailed' if tailed else 'tailless'}) was recorded before it",
            )
        run_id = point.recording.run_id
        if run_id not in calibrations:
            calibrations[run_id] = balance_calibration_of(point.recording)
        frame = point.recording.set_point_frame(int(row["set_point_index"]))
        loads = cycle_averaged_loads(
            frame[list(GAUGE_CHANNELS)].to_numpy(dtype=float),
            frame["hall_v"].to_numpy(dtype=float),
            point.recording.sample_rate_hz,
            tare,
            calibrations[run_id],
        )
        rows.append(
            {
                "run_id": run_id,
                "plan_point_index": int(row["plan_point_index"]),
                "sweep": row.get("sweep", ""),
                "tailed": tailed,
                "repeat": int(row["repeat_index"]),
                "theta_deg": math.degrees(float(row["pitch_rad"])),
                "v_m_s": float(row["tunnel_velocity_m_s"]),
                "f_set_hz": float(row["flapping_frequency_hz"]),
                **loads.as_record(),
            }
        )
    return pd.DataFrame(rows)


def tail_contribution(table: pd.DataFrame) -> pd.DataFrame:
    """Tailed minus tailless at every set point measured both ways, with propagated uncertainty.

    Repeats are pooled: the mean of the repeat means, with standard error from the per-repeat standard errors
    (``sqrt(sum se^2) / n``). ``<load>_sigma`` is the standard error of the difference; ``<load>_resolvable``
    says whether the difference exceeds both twice that sigma and the balance resolution (forces only; moments
    use twice sigma alone).
    """
    keys = ["theta_deg", "v_m_s", "f_set_hz"]
    rounded = table.assign(**{key: table[key].round(6) for key in keys})
    pooled = {}
    for tailed, group in rounded.groupby("tailed"):
        aggregations = {}
        for name in BODY_LOAD_NAMES:
            aggregations[name] = group.groupby(keys)[name].mean()
            aggregations[f"{name}_se"] = group.groupby(keys)[f"{name}_se"].apply(
                lambda se: float(np.sqrt((se**2).sum()) / len(se))
            )
        pooled[bool(tailed)] = pd.DataFrame(aggregations)
    if True not in pooled or False not in pooled:
        return pd.DataFrame()
    common = pooled[True].index.intersection(pooled[False].index)
    result = pd.DataFrame(index=common)
    for name in BODY_LOAD_NAMES:
        difference = pooled[True].loc[common, name] - pooled[False].loc[common, name]
        sigma = np.hypot(
            pooled[True].loc[common, f"{name}_se"], pooled[False].loc[common, f"{name}_se"]
        )
        threshold = np.maximum(2 * sigma, BALANCE_RESOLUTION_N if name.endswith("_n") else 0.0)
        result[name] = difference
        result[f"{name}_sigma"] = sigma
        result[f"{name}_resolvable"] = np.abs(difference) > threshold
    return result.reset_index()
