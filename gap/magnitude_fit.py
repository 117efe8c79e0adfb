"""Fitting one candidate's magnitude: a coarse grid over its bounds, then Brent's method.

The cost is any function of the magnitude (the training runs' normalised squared residual); the
grid guards against the local minima a delay or a blended effect can have. A fit within
:data:`BOUND_TOLERANCE` of the range from either end sits *at the bound*: the data want at least
(upper) or at most (lower) that value, and the report says so instead of giving a plain value.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import minimize_scalar

GRID_POINTS = 13
BOUND_TOLERANCE = 0.005  # fraction of the candidate's range


def fit_magnitude(
    cost: Callable[[float], float], bounds: tuple[float, float], grid_points: int = GRID_POINTS
) -> tuple[float, float]:
    """The magnitude in ``bounds`` that minimises ``cost`` and the cost there."""
    low, high = bounds
    grid = np.unique(np.concatenate([np.linspace(low, high, grid_points), [0.0]]))
    grid = grid[(grid >= low) & (grid <= high)]
    values = np.array([cost(float(k)) for k in grid])
    best = int(np.argmin(values))
    left = grid[max(best - 1, 0)]
    right = grid[min(best + 1, len(grid) - 1)]
    if right <= left:
        return float(grid[best]), float(values[best])
    result = minimize_scalar(
        cost,
        bounds=(float(left), float(right)),
        method="bounded",
        options={"xatol": 1e-4 * (high - low)},
    )
    if result.fun < values[best]:
        return float(result.x), float(result.fun)
    return float(grid[best]), float(values[best])


def bound_side(magnitude: float, bounds: tuple[float, float] | None) -> str | None:
    """``"lower"`` or ``"upper"`` when ``magnitude`` is within :data:`BOUND_TOLERANCE` of the
    range from that end of ``bounds`` (same unit as the magnitude), else None (also without
    bounds)."""
    if bounds is None:
        return None
    low, high = bounds
    tolerance = BOUND_TOLERANCE * (high - low)
    if magnitude <= low + tolerance:
        return "lower"
    if magnitude >= high - tolerance:
        return "upper"
    return None
