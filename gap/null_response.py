"""What the ``top-set-orthogonal`` null directions are stripped of: the effects' output responses.

A random direction of A and B is meant to be one extra parameter of no physical meaning. Orthogonal
in the entries to the change an effect makes, it can still move the outputs much as the effect
does (a pitch-inertia change scales the whole q row; M_q or M_de alone mimic most of its response
to a doublet), and fitted freely it then absorbs the effect it is meant to be judged against. So
the directions are made orthogonal where the fit sees them: in the first-order response of the
weighted outputs on the training runs. For an effect with response r_c (per unit magnitude) and an
entry change with response r_ij, the direction's relative entries x must satisfy
sum_ij x_ij |a_ij| <r_ij, r_c> = 0; :func:`response_gradients` gives g_ij = <r_ij, r_c>.
Responses are forward differences at :data:`RESPONSE_STEP` of a candidate's range or of an entry's
size, outputs divided by the channel weights (dimensionless).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_model import LinearFlightModel, simulate_runs

RESPONSE_STEP = 0.01


def _weighted_outputs(
    model: LinearFlightModel, runs: Sequence[FlightRun], scales: np.ndarray
) -> np.ndarray:
    return np.concatenate([outputs / scales for outputs in simulate_runs(model, runs)]).ravel()


def response_gradients(
    start: LinearFlightModel,
    effects: Sequence[tuple[Callable[[float], LinearFlightModel], float]],
    runs: Sequence[FlightRun],
    scales: np.ndarray,
) -> list[np.ndarray]:
    """For each effect (``family`` k -> model, with ``family(0)`` = ``start``, and its range's
    half-width), g over the entries of [A B] (shape of A's rows by A's and B's columns; zero outside
    ``start``'s dynamic rows and its zero entries): the overlap of an entry's output response with
    the effect's, on ``runs`` with channels divided by ``scales``."""
    reference = _weighted_outputs(start, runs, scales)
    effect_responses = [
        (_weighted_outputs(family(RESPONSE_STEP * reach), runs, scales) - reference)
        / (RESPONSE_STEP * reach)
        for family, reach in effects
    ]
    columns = start.a_matrix.shape[1]
    joined = np.hstack([start.a_matrix, start.b_matrix])
    gradients = [np.zeros_like(joined) for _ in effects]
    for row in start.dynamic_rows:
        for column in np.flatnonzero(joined[row]):
            step = RESPONSE_STEP * abs(joined[row, column])
            changed = joined.copy()
            changed[row, column] += step
            model = start.with_matrices(changed[:, :columns], changed[:, columns:])
            entry_response = (_weighted_outputs(model, runs, scales) - reference) / step
            for gradient, effect_response in zip(gradients, effect_responses, strict=True):
                gradient[row, column] = float(entry_response @ effect_response)
    return gradients
