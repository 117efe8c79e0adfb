"""Repeats of one set point moved to one common condition before they are pooled and differenced.

The rig reaches a set velocity only within the settle tolerance, and from a different side depending on what came
before (from below after a wind-off tare, from above after the velocity sweep's top point), so repeats of "the same"
set point sit a few mm/s apart: with Xu about -0.1 N/(m/s) that is several of a point's sigmas, and the tailed and
tailless states do not even share their offset. Each repeat's loads are moved along the configuration's fitted
derivatives (the tailed fit: ``Lu du + Lw dw``, the tangent at the steady state) from the pitch and velocity read
during its record to the *reference condition* of its set point: the mean read during the tailless repeats (their
own slopes are not measured, so they move least), else the set values.

The tailless repeats move with the tailed derivatives, which include the tail's share (about a tenth of Xu); over
their spread of about 0.5 mm/s that is below 0.01 of a point's sigma. The moved loads keep their errors (the
derivatives' own uncertainty times an offset of mm/s is far below them).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ornitail.balance.derivatives import LOADS, StabilityDerivatives, measured_or_set

REFERENCE_COLUMNS = ("theta_reference_deg", "v_reference_m_s")
"""The condition each row's loads were moved to: pitch (deg) and tunnel velocity (m/s)."""
SET_POINT_KEYS = ["theta_deg", "v_m_s", "f_set_hz"]


def at_reference_conditions(
    table: pd.DataFrame, derivatives: StabilityDerivatives | None
) -> pd.DataFrame:
    """A copy of ``table`` with every load moved to its set point's reference condition (module notes).

    Without derivatives in u and w (no pitch and velocity sweeps), or without conditions read during the records,
    the loads stay as measured and ``theta_reference_deg`` / ``v_reference_m_s`` are NaN.
    """
    moved = table.copy()
    for column in REFERENCE_COLUMNS:
        moved[column] = np.nan
    if (
        derivatives is None
        or not {"u", "w"} <= set(derivatives.variables)
        or "v_measured_m_s" not in table
        or not np.isfinite(table["v_measured_m_s"].to_numpy(dtype=float)).any()
    ):
        return moved
    theta = measured_or_set(table, "theta_measured_deg", "theta_deg")
    velocity = measured_or_set(table, "v_measured_m_s", "v_m_s")
    rounded = table[SET_POINT_KEYS].round(6)
    for _, group in table.groupby([rounded[key] for key in SET_POINT_KEYS]):
        tailless = ~group["tailed"].astype(bool).to_numpy()
        rows = table.index.get_indexer(group.index)
        source = tailless if tailless.any() else np.ones(len(group), dtype=bool)
        reference_theta = float(theta[rows][source].mean())
        reference_velocity = float(velocity[rows][source].mean())
        frequency = group["f_set_hz"].to_numpy(dtype=float)
        at_reference = derivatives.predict(
            np.full(len(group), reference_theta),
            np.full(len(group), reference_velocity),
            frequency,
            linear_only=True,
        )
        as_read = derivatives.predict(theta[rows], velocity[rows], frequency, linear_only=True)
        for load, name, _ in LOADS:
            moved.loc[group.index, name] = group[name].to_numpy(dtype=float) + (
                at_reference[load] - as_read[load]
            )
        moved.loc[group.index, "theta_reference_deg"] = reference_theta
        moved.loc[group.index, "v_reference_m_s"] = reference_velocity
    return moved
