"""The wind-off reference a measurement subtracts, corrected for the balance's drift between bracketing tares.

A strain-gauge balance drifts (warm-up, creep): a wind-off tare taken a minute before a point no longer gives the
gauges' zero at the point. When the plan brackets a block of points with wind-off tares at the same pitch and tail
state (``[protocol] bracketing_tares``, docs/sweep-plan.md), the zero at a point is interpolated linearly in time
between the tare before and the tare after it:

    V0(t) = (1 - lambda) V_before + lambda V_after,   lambda = (t - t_before) / (t_after - t_before)

with t the middle of each record in the run's sample counter (one continuous stream per run, so the counter is
the run's clock). The two tares' errors are independent, so the variance of V0 is
``(1 - lambda)^2 se_before^2 + lambda^2 se_after^2``; points that share a tare share its error in proportion to
their weights on it (``balance.derivatives.weighted_tare_covariance``). Without a tare after the point in the
same run, the last tare before it is used as it is ("constant since the last tare": its drift since then is not
corrected).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ornitail.acquisition.recording_layout import SetPointRecord

DRIFT_MODEL_LINEAR = "linear in time between bracketing tares"
DRIFT_MODEL_CONSTANT = "constant since the last tare (no tare after the point in its run)"


@dataclass(frozen=True)
class RecordedTare:
    """One wind-off tare record: its mean gauge voltages and their standard error (V, shape (6,))."""

    tare_id: str
    run_id: str
    middle_sample_index: float
    volts: np.ndarray
    volts_standard_error: np.ndarray
    record: SetPointRecord | None = None


def middle_sample_index(record: SetPointRecord) -> float:
    """The middle of a record on its run's sample counter."""
    return 0.5 * (record.first_sample_index + record.last_sample_index)


@dataclass(frozen=True)
class TareCorrection:
    """The zero subtracted from a measurement: the tare before it, and the tare after it with ``after_weight``."""

    before: RecordedTare
    after: RecordedTare | None = None
    after_weight: float = 0.0

    @property
    def volts(self) -> np.ndarray:
        """Interpolated gauge zero at the measurement, V."""
        if self.after is None:
            return self.before.volts
        return (1.0 - self.after_weight) * self.before.volts + self.after_weight * self.after.volts

    @property
    def volts_standard_error(self) -> np.ndarray:
        """Standard error of :attr:`volts`, V (the two tares independent)."""
        if self.after is None:
            return self.before.volts_standard_error
        return np.hypot(
            (1.0 - self.after_weight) * self.before.volts_standard_error,
            self.after_weight * self.after.volts_standard_error,
        )

    @property
    def drift_model(self) -> str:
        """How the drift between the tares was modelled, in words for the output."""
        return DRIFT_MODEL_CONSTANT if self.after is None else DRIFT_MODEL_LINEAR


def tare_correction(
    before: RecordedTare, after: RecordedTare | None, middle_sample: float, run_id: str
) -> TareCorrection:
    """Bracket a record whose middle is ``middle_sample`` on run ``run_id``'s counter between ``before`` and
    ``after`` when both are in its run; else the tare before alone."""
    if after is None or before.run_id != run_id or after.run_id != run_id:
        return TareCorrection(before)
    span = after.middle_sample_index - before.middle_sample_index
    if span <= 0:
        return TareCorrection(before)
    weight = (middle_sample - before.middle_sample_index) / span
    return TareCorrection(before, after, float(np.clip(weight, 0.0, 1.0)))
