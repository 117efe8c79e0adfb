"""The balance's drift over one run, fitted to all of the run's wind-off tares at once.

A strain-gauge balance's zero moves with its temperature and creep: one curve in the rig's running time, the same
for every pitch, since the gauges warm the same whatever the strut's angle. What does change with pitch (and tail)
is the weight's share on each gauge, a constant offset. So every tare ``j`` of a run (mean gauge voltages ``V_j``,
running time ``t_j``, pitch and tail state ``k_j``) is modelled, per gauge, as

    V_j = o_{k_j} + g(t_j),   g(t) = sum_{n=1..d} a_n P_n(s(t))

with ``P_n`` the Legendre polynomials of the running time scaled to [-1, 1] over the run's tares. The curve is
fitted by least squares to all the tares, the offsets to each pitch's; a point at pitch ``k`` and running time ``t``
gets the zero ``o_k + g(t)``: a weighted sum of the run's tares (weights summing to 1 over its own pitch's tares
and to 0 over every other pitch's), so its covariance and the errors points share follow from the tares' as before.

Why not the straight line between the two tares that bracket a point at its pitch: a balance warming up bends its
zero most in the first minutes, and a pitch with only two tares cannot show the bend. On the simulated rig the first
pitch points of a run were 4-6 of their sigmas off in X for it. The pitch that holds many tares (the steady state's)
shows the bend to all the others.

The degree is chosen by the tares themselves: the smallest ``d`` (straight first) whose residuals agree with the
tares' own noise (chi-square on ``6 x (tares - pitches - d)`` degrees of freedom, rejected below
:data:`DRIFT_FIT_SIGNIFICANCE`), up to :data:`MAX_DRIFT_DEGREE`. When none agrees (drift that is not shared between
pitches: creep under the load, a bumped balance), the highest degree is kept and every tare's covariance is inflated
by the reduced chi-square, and the statement says so.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Hashable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import legendre
from scipy.stats import chi2

from ornitail.balance.tare_drift import RecordedTare, TareCorrection

DRIFT_FIT_SIGNIFICANCE = 0.01
"""Chance of a false alarm of the drift fit's check: a degree is rejected below this p-value."""
MAX_DRIFT_DEGREE = 4
"""Highest degree of the drift curve in running time (a warm-up over a few minutes is well within a quartic)."""
DEGREE_NAMES = {1: "straight line", 2: "parabola", 3: "cubic", 4: "quartic"}


def drift_model_name(degree: int) -> str:
    """The ``drift_model`` text of a zero from a run's drift fit of this degree."""
    shape = "linear" if degree == 1 else f"polynomial of degree {degree}"
    return (
        f"{shape} in running time (motor on), one curve shared by all pitches of the run with an offset per pitch, "
        "fitted to all its tares"
    )


@dataclass(frozen=True)
class RunDriftFit:
    """A run's drift fitted to its tares (see the module's text). Attributes are plain results:

    ``tares`` and ``keys`` (pitch and tail state of each), ``degree`` of the curve, ``chi_square`` of the tares'
    residuals on ``degrees_of_freedom`` (0: nothing left to test it), ``p_value`` and ``covariance_inflation``
    (1, or the reduced chi-square when no degree agreed with the tares' noise).
    """

    run_id: str
    tares: tuple[RecordedTare, ...]
    keys: tuple[Hashable, ...]
    degree: int
    chi_square: float
    degrees_of_freedom: int
    p_value: float
    covariance_inflation: float
    rejected_degrees: tuple[int, ...]
    _offset_keys: tuple[Hashable, ...]
    _time_span: tuple[float, float]
    _solution: np.ndarray  # (pitches + degree, tares): parameters = solution @ tare volts

    def covers(self, running_time: float) -> bool:
        """Whether ``running_time`` lies within the run's tares (the curve is not extrapolated)."""
        return self._time_span[0] <= running_time <= self._time_span[1]

    def correction(
        self, key: Hashable, running_time: float, before: RecordedTare
    ) -> TareCorrection:
        """The zero of a point at pitch and tail state ``key`` and ``running_time`` (samples of the run's running
        clock); ``before`` is the newest tare before it at its pitch (named as its tare)."""
        row = np.zeros(len(self._offset_keys) + self.degree)
        row[self._offset_keys.index(key)] = 1.0
        row[len(self._offset_keys) :] = _curve_basis(
            np.array([running_time]), self._time_span, self.degree
        )[0]
        weights = row @ self._solution
        terms = tuple(
            (tare, float(weight))
            for tare, weight in zip(self.tares, weights, strict=True)
            if weight != 0.0
        )
        return TareCorrection(
            before, terms, drift_model_name(self.degree), self.covariance_inflation
        )

    def statement(self) -> str:
        """One line for the output: the curve chosen, the check, and any inflation."""
        pitches = len(self._offset_keys)
        # The same words for every run of two tares at one pitch, so the output says them once.
        if len(self.tares) == 2 and pitches == 1:
            return (
                "Drift fit (runs with two tares at one pitch): the straight line between them; no spare tare, so "
                "its shape is not tested."
            )
        head = (
            f"Drift fit ({self.run_id}): {len(self.tares)} tares at {pitches} pitch(es), one "
            f"{DEGREE_NAMES[self.degree]} in running time shared by all"
        )
        if self.degrees_of_freedom == 0:
            return f"{head}; no spare tare, so its shape is not tested."
        check = f"chi-square {self.chi_square:.1f} on {self.degrees_of_freedom} (p = {self.p_value:.2g})"
        rejected = (
            f"; lower degrees disagreed with the tares' noise ({', '.join(map(str, self.rejected_degrees))})"
            if self.rejected_degrees and self.covariance_inflation == 1.0
            else ""
        )
        if self.covariance_inflation > 1.0:
            return (
                f"{head}: {check}; NO curve up to degree {MAX_DRIFT_DEGREE} agrees with the tares' noise (drift "
                f"that differs between pitches?), so the tares' errors are inflated x"
                f"{np.sqrt(self.covariance_inflation):.2f} in sigma."
            )
        return f"{head}: {check}, consistent with the tares' noise{rejected}."


def _curve_basis(times: np.ndarray, span: tuple[float, float], degree: int) -> np.ndarray:
    """(n, degree) Legendre polynomials 1..degree of ``times`` scaled to [-1, 1] over ``span``."""
    low, high = span
    scaled = 2.0 * (np.asarray(times, dtype=float) - low) / (high - low) - 1.0
    return legendre.legvander(scaled, degree)[:, 1:]


def fit_run_drift(
    run_id: str, keyed_tares: Sequence[tuple[Hashable, RecordedTare]]
) -> RunDriftFit | None:
    """Fit a run's drift to its tares, each with its pitch and tail state key; None when no curve can be fitted
    (no pitch with two tares at different running times)."""
    tares = tuple(tare for _, tare in keyed_tares)
    keys = tuple(key for key, _ in keyed_tares)
    offset_keys = tuple(dict.fromkeys(keys))
    times = np.array([tare.running_time for tare in tares], dtype=float)
    if len(tares) < 2 or times.max() <= times.min():
        return None
    span = (float(times.min()), float(times.max()))
    volts = np.array([tare.volts for tare in tares])
    precisions = [np.linalg.inv(tare.volts_covariance) for tare in tares]
    offsets = np.array([[key == offset for offset in offset_keys] for key in keys], dtype=float)
    rejected: list[int] = []
    chosen: RunDriftFit | None = None
    for degree in range(1, MAX_DRIFT_DEGREE + 1):
        design = np.hstack((offsets, _curve_basis(times, span, degree)))
        spare = len(tares) - design.shape[1]
        if spare < 0 or np.linalg.matrix_rank(design) < design.shape[1]:
            break
        solution = np.linalg.pinv(design)
        residuals = volts - design @ (solution @ volts)
        chi_square = float(
            sum(r @ precision @ r for r, precision in zip(residuals, precisions, strict=True))
        )
        dof = 6 * spare
        p_value = float(chi2.sf(chi_square, dof)) if dof else 1.0
        chosen = RunDriftFit(
            run_id,
            tares,
            keys,
            degree,
            chi_square,
            dof,
            p_value,
            1.0,
            tuple(rejected),
            offset_keys,
            span,
            solution,
        )
        if dof == 0 or p_value >= DRIFT_FIT_SIGNIFICANCE:
            return chosen
        rejected.append(degree)
    if chosen is None:
        return None
    # No degree agreed with the tares' noise: keep the highest, its tares' errors inflated (Birge ratio).
    return dataclasses.replace(
        chosen,
        covariance_inflation=max(1.0, chosen.chi_square / chosen.degrees_of_freedom),
        rejected_degrees=tuple(rejected[:-1]),
    )


def zero_correction(
    fit: RunDriftFit | None, key: Hashable, running_time: float, before: RecordedTare
) -> TareCorrection:
    """The zero of a point at pitch and tail state ``key`` and ``running_time`` of its run: from the run's drift
    fit where the run's tares surround it, else the tare before it (``before``) as it is."""
    if fit is not None and fit.covers(running_time):
        return fit.correction(key, running_time, before)
    return TareCorrection.constant(before)
