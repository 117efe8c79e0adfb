"""Feature bases of the trend fits: which functions of tail geometry and position a quantity is linear in.

A trend is ``quantity = coefficients . features(b, b_LE, c_r, c_t, x_h)``. The default basis ``"linear"`` is
``[1, S, AR, x_h]`` (the study found steady states and derivatives roughly linear in S and AR,
docs/background.md section 6); the others add the span ``b`` (the flapping wake's high-velocity region,
docs/background.md section 6), a curvature in ``x_h`` (X_q peaks near 98 mm), or drop AR for tables where AR
hardly varies.

Features are written with + - * / only, so :meth:`TrendBasis.features` works on floats and on CasADi SX/MX
symbols alike. The planform behind a geometry vector is the hexagon of docs/background.md section 2:
``S = (b_LE + b) / 2 (c_r - c_t) + b c_t`` and ``AR = b^2 / S``. All lengths in metres, S in m^2.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from ornitail.core.errors import UserInputError
from ornitail.vehicle.geometry import TailGeometry


def hexagon_area_m2(
    span_m: Any, leading_edge_span_m: Any, root_chord_m: Any, tip_chord_m: Any
) -> Any:
    """Planform area S (m^2) of the hexagonal tail; floats or CasADi symbols."""
    return (leading_edge_span_m + span_m) / 2 * (root_chord_m - tip_chord_m) + span_m * tip_chord_m


@dataclass(frozen=True)
class PlanformFeatures:
    """What every basis is built from: area S (m^2), aspect ratio AR (-), span b (m), tail position x_h (m)."""

    area_m2: Any
    aspect_ratio: Any
    span_m: Any
    x_h_m: Any


def planform_features_of_vector(geometry_vector: Sequence[Any]) -> PlanformFeatures:
    """Planform features of a geometry vector ``(b, b_LE, c_r, c_t, x_h)`` in metres (hexagon)."""
    if len(geometry_vector) != 5:
        raise ValueError("a geometry vector is (b, b_LE, c_r, c_t, x_h) in metres")
    span, leading_edge_span, root_chord, tip_chord, x_h = geometry_vector
    area = hexagon_area_m2(span, leading_edge_span, root_chord, tip_chord)
    return PlanformFeatures(area_m2=area, aspect_ratio=span * span / area, span_m=span, x_h_m=x_h)


def planform_features_of_geometry(geometry: TailGeometry, x_h_m: float) -> PlanformFeatures:
    """Planform features of a :class:`TailGeometry` (hexagon or elliptical leading edge) at x_h (m)."""
    return PlanformFeatures(
        area_m2=geometry.area_m2,
        aspect_ratio=geometry.aspect_ratio,
        span_m=geometry.span_m,
        x_h_m=x_h_m,
    )


@dataclass(frozen=True)
class TrendBasis:
    """A named list of features; ``feature_names[i]`` labels ``features(...)[i]``.

    Parameters
    ----------
    name : str
        Basis name (``"linear"``, ``"linear-area"``, ``"linear-span"``, ``"quadratic-xh"``).
    feature_names : tuple of str
        Labels with units, e.g. ``"S_m2"``; the first is always ``"1"`` (the intercept).
    make_features : callable
        PlanformFeatures -> list of features (floats or CasADi expressions).
    """

    name: str
    feature_names: tuple[str, ...]
    make_features: Callable[[PlanformFeatures], list[Any]]

    def features(self, geometry_vector: Sequence[Any]) -> list[Any]:
        """Features at ``(b, b_LE, c_r, c_t, x_h)`` (metres; floats or CasADi symbols)."""
        return self.make_features(planform_features_of_vector(geometry_vector))

    def features_of_geometry(self, geometry: TailGeometry, x_h_m: float) -> list[float]:
        """Features of a :class:`TailGeometry` at x_h (m); also for the elliptical tail T2."""
        return [
            float(value)
            for value in self.make_features(planform_features_of_geometry(geometry, x_h_m))
        ]


BASES: dict[str, TrendBasis] = {
    basis.name: basis
    for basis in (
        TrendBasis(
            "linear",
            ("1", "S_m2", "AR", "x_h_m"),
            lambda p: [1.0, p.area_m2, p.aspect_ratio, p.x_h_m],
        ),
        TrendBasis(
            "linear-area",
            ("1", "S_m2", "x_h_m"),
            lambda p: [1.0, p.area_m2, p.x_h_m],
        ),
        TrendBasis(
            "linear-span",
            ("1", "S_m2", "AR", "x_h_m", "b_m"),
            lambda p: [1.0, p.area_m2, p.aspect_ratio, p.x_h_m, p.span_m],
        ),
        TrendBasis(
            "quadratic-xh",
            ("1", "S_m2", "AR", "x_h_m", "x_h_m^2"),
            lambda p: [1.0, p.area_m2, p.aspect_ratio, p.x_h_m, p.x_h_m * p.x_h_m],
        ),
    )
}
"""The selectable bases by name."""


def trend_basis(name: str | TrendBasis, where: str = "basis") -> TrendBasis:
    """The basis called ``name`` (a :class:`TrendBasis` passes through); unknown names are refused."""
    if isinstance(name, TrendBasis):
        return name
    if name not in BASES:
        raise UserInputError(where, f"unknown basis {name!r}; known bases: {', '.join(BASES)}")
    return BASES[name]
