"""The detection rule: a candidate must beat what a free parameter of no physical meaning reaches.

The rule is calibrated on the data in hand. ``draws`` random one-parameter directions of the
baseline (flight: a random direction in the linear model's A and B entries, by default stripped of
its first-order output response along the top set's candidates, :mod:`ornitail.gap.null_response`;
tunnel and steady tables: a random combination of the standardised configuration variables per
channel) are fitted with the candidates' own fitter on the training runs and scored on the
validation runs. Their validation closures are the *null distribution*: what one extra parameter
reaches on these runs by absorbing noise and whatever systematic error the baseline leaves (its own
linearisation, a nonlinearity), without naming anything.

A candidate is named (detected) when its validation closure exceeds the null's 95th percentile and
its lower bound (resampling validation runs, simultaneous over the candidates that could have won:
:mod:`ornitail.gap.ranking`) exceeds the *lower-bound threshold*, the larger of the null's median
and :data:`MATERIAL_CLOSURE`: it beats 95 % of meaningless parameters on the runs observed, and
even in its unfavourable resamples it is better than a typical one and removes a material part of
the gap. The materiality floor is there because
the null alone cannot tell a small real systematic error from an effect: on simulated flights
without any withheld effect the physical candidates (a blend of ``cg_shift_with_x_h`` or
``wake_profile``) absorb the simulator's own linearisation error 1.2-2 times better than random
directions do, closing 1-5 % of the gap, above the null's 95th percentile (0.5-4 %) in 3 of 4
flights tried (docs/gap-diagnosis.md). The floor applies to the lower bound, not to the closure
itself, because the closure compared is the best of several candidates on the same validation runs
(the winner of a contest is lucky on the runs that chose it): an effect-free simulated flight's best
candidate closed 0.115 on its validation runs (5 % quantile 0.086), 0.076 on its test runs and 0.059
on a fresh flight, and was named under the floor on the closure alone. With the derivative-level
candidates in the library (15 candidates for the simulator) a candidate's own 5 % quantile no longer
accounted for the luck of the contest: the simultaneous bound does.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

NULL_DRAWS = 24
NULL_QUANTILE = 0.95
MATERIAL_CLOSURE = 0.10


@dataclass(frozen=True)
class DetectionRule:
    """The null distribution: validation closures of ``len(closures)`` random directions;
    ``orthogonal_to`` names the changes the directions were stripped of (empty: none)."""

    method: str
    closures: np.ndarray
    orthogonal_to: str = ""

    @property
    def null_quantile(self) -> float:
        """The null's :data:`NULL_QUANTILE` quantile (closure, dimensionless)."""
        return float(np.quantile(self.closures, NULL_QUANTILE))

    @property
    def threshold(self) -> float:
        """The validation closure a candidate must exceed: the null's quantile (dimensionless)."""
        return self.null_quantile

    @property
    def lower_bound_threshold(self) -> float:
        """What the closure's simultaneous lower bound must exceed: the null's median or the
        materiality floor, whichever is larger (dimensionless)."""
        return max(self.median, MATERIAL_CLOSURE)

    @property
    def median(self) -> float:
        """The null's median (closure, dimensionless)."""
        return float(np.median(self.closures))

    def detects(self, closure: float, lower_bound: float) -> bool:
        """A validation ``closure`` with (simultaneous) lower bound ``lower_bound`` is an effect."""
        return bool(closure > self.threshold and lower_bound > self.lower_bound_threshold)

    def as_report(self) -> dict[str, object]:
        """The report's ``detection_rule`` field."""
        return {
            "method": self.method,
            "null_directions_orthogonal_to": self.orthogonal_to or None,
            "threshold": self.threshold,
            "lower_bound_threshold": self.lower_bound_threshold,
            "null_closures_quantile_95": self.null_quantile,
            "null_closures_median": self.median,
            "materiality_floor": MATERIAL_CLOSURE,
            "draws": len(self.closures),
        }


def closure_of(before_sse: float, after_sse: float) -> float:
    """1 - gap_after / gap_before from the two (equal-count) squared-residual sums."""
    if before_sse <= 0:
        return 0.0
    return 1.0 - float(np.sqrt(after_sse / before_sse))


def random_matrix_directions(
    a_matrix: np.ndarray,
    b_matrix: np.ndarray,
    draws: int,
    seed: int,
    dynamic_rows: tuple[int, ...] = (0, 1, 2),
    named_steps: Sequence[np.ndarray] = (),
    response_gradients: Sequence[np.ndarray] = (),
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``draws`` random directions (dA, dB) in the entries of the ``dynamic_rows`` of A and B (the
    simulator's q, u, w rows; a model file's rows with parameters), each entry scaled by its own
    size (zero entries stay zero) and the whole normalised to a unit RMS relative change, so a
    magnitude of 1 changes entries by about 100 % of themselves. Kinematic rows (theta' = q) are
    left alone, as every candidate leaves them.

    ``named_steps``: changes [dA dB] (rows, A's columns + B's) that the library's candidates make
    (``gap.flight_diagnosis.library_matrix_steps``); each direction is first stripped of its part
    along them (:func:`stripped_basis`), in the entries relative to their size, so that it
    names nothing the library names, keeping at least one free dimension.

    ``response_gradients``: for each effect under test, the gradient over the entries of A and B
    (same shape) of the overlap between an entry change's first-order output response and the
    effect's (``gap.null_response.response_gradients``); each direction is stripped of its part
    along them, so its first-order response shares nothing with any of those effects."""
    generator = np.random.default_rng([seed, 15])
    joined = np.hstack([a_matrix, b_matrix])
    size = np.zeros_like(joined)
    rows = list(dynamic_rows)
    size[rows] = np.abs(joined[rows])
    active = size > 0
    basis = stripped_basis(named_steps, size, response_gradients)
    directions = []
    for _ in range(draws):
        relative = generator.standard_normal(joined.shape) * active
        if basis is not None:
            relative[active] -= basis @ (basis.T @ relative[active])
        relative /= np.sqrt(np.mean(relative[active] ** 2))
        step = relative * size
        directions.append((step[:, : a_matrix.shape[1]], step[:, a_matrix.shape[1] :]))
    return directions


def stripped_basis(
    named_steps: Sequence[np.ndarray],
    size: np.ndarray,
    response_gradients: Sequence[np.ndarray] = (),
) -> np.ndarray | None:
    """Orthonormal columns, in the entries where ``size`` > 0 relative to their size, spanning the
    ``named_steps`` (each entry divided by its size) and the ``response_gradients`` (each entry
    times its size: the gradient with respect to the relative change); None without either; at most
    one fewer columns than entries."""
    active = size > 0
    relative = [step[active] / size[active] for step in named_steps if np.any(step[active])]
    relative += [
        gradient[active] * size[active]
        for gradient in response_gradients
        if np.any(gradient[active])
    ]
    if not relative:
        return None
    columns = np.array(relative).T
    left, singular, _ = np.linalg.svd(columns, full_matrices=False)
    rank = int(np.count_nonzero(singular > singular[0] * 1e-9))
    return left[:, : min(rank, int(np.count_nonzero(active)) - 1)]


def random_feature_steps(
    features: np.ndarray, scales: np.ndarray, draws: int, seed: int
) -> list[np.ndarray]:
    """``draws`` random steps (rows, channels) for row tables: per channel a random combination
    (standard normal weights) of the standardised ``features`` (rows, variables) and a constant,
    in units of ``scales`` (broadcast to rows x channels)."""
    generator = np.random.default_rng([seed, 15])
    spread = features.std(axis=0)
    keep = spread > 0
    standardised = (features[:, keep] - features[:, keep].mean(axis=0)) / spread[keep]
    design = np.column_stack([standardised, np.ones(len(features))])
    channels = np.broadcast_to(scales, (len(features), np.shape(scales)[-1]))
    return [
        design @ generator.standard_normal((design.shape[1], channels.shape[1])) * channels
        for _ in range(draws)
    ]
