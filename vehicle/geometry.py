"""Horizontal-tail planform of the DelFly II: dimensions, area, aspect ratio, local chord, validity.

The outline (docs/background.md section 2) is a symmetric hexagon: a straight leading edge of width b_LE;
side edges that widen linearly to the full span b at a distance c_r - c_t behind the leading edge;
straight tips of length c_t; a straight trailing edge of width b. The standard tail T2 has an
elliptical leading edge instead (``leading_edge_span_m = None``): its local chord is c_t + (c_r -
c_t) sqrt(1 - (2y/b)^2).

Spanwise position y is measured from the plane of symmetry (y = 0) along y_b; chords are measured
aft (along +z_b) from the root leading edge. All lengths are in metres.

Enclosing the base tail
-----------------------
Every planform is fitted around the base tail (80 mm span, 48 mm chord incl. elevator), aligned at
the leading-edge centreline. Read as a sharp rectangle, the base tail's leading corners (+-40 mm, 0)
would stick out of T3, AR5 and AR6 (b_LE = 70-76 mm) and of the elliptical T2, all of which were
flown. So the base tail is modelled with a swept-back leading edge: from its leading-edge centre (0,
0) straight to its leading corners 10 mm further aft (*estimate*; the DelFly base tail's leading
edge is rounded), then straight sides to its 80 mm wide trailing edge 48 mm behind the centre. Its
outline is the polygon (0, 0), (+-40, 10), (+-40, 48) mm. Both the hexagon and the
elliptical-leading-edge planform are convex, so the base tail is enclosed exactly when all five
vertices lie inside the planform (tolerance 1e-9 m, touching allowed). In words: span b >= 80 mm,
root chord c_r >= 48 mm, and the planform's leading edge at y = +-40 mm at most 10 mm behind its
root leading edge (T3, the tightest study tail, has 3.3 mm there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.vehicle.constants import TAIL_POSITION_RANGE_MM
from ornitail.vehicle.study_tables import STUDY_FUSELAGES_TABLE, STUDY_TAILS_TABLE, study_table_rows

BASE_TAIL_SPAN_M = 0.080
BASE_TAIL_CHORD_M = 0.048
BASE_TAIL_CORNER_SETBACK_M = 0.010
_CONTAINMENT_TOLERANCE_M = 1e-9
MAX_DIMENSION_M = 1.0
"""Longest tail dimension accepted (span, chords), m: a DelFly tail is a few hundred mm."""


def base_tail_outline_vertices_m() -> np.ndarray:
    """Vertices (y, distance aft of the leading edge) of the base-tail outline (m), shape (5, 2)."""
    half = BASE_TAIL_SPAN_M / 2
    setback = BASE_TAIL_CORNER_SETBACK_M
    return np.array(
        [
            [0.0, 0.0],
            [-half, setback],
            [half, setback],
            [-half, BASE_TAIL_CHORD_M],
            [half, BASE_TAIL_CHORD_M],
        ]
    )


@dataclass(frozen=True)
class TailGeometry:
    """A horizontal-tail planform in metres.

    Parameters
    ----------
    span_m : float
        Maximum span b.
    leading_edge_span_m : float or None
        Width b_LE of the straight leading edge; None for an elliptical leading edge (tail T2).
    root_chord_m : float
        Root chord c_r (plane of symmetry).
    tip_chord_m : float
        Tip chord c_t (length of the straight tip edges).
    """

    span_m: float
    leading_edge_span_m: float | None
    root_chord_m: float
    tip_chord_m: float

    @classmethod
    def from_mm(
        cls, b_mm: float, b_le_mm: float | None, c_r_mm: float, c_t_mm: float
    ) -> TailGeometry:
        """Build a geometry from millimetre dimensions (b, b_LE or None, c_r, c_t)."""
        return cls(
            span_m=b_mm / 1000.0,
            leading_edge_span_m=None if b_le_mm is None else b_le_mm / 1000.0,
            root_chord_m=c_r_mm / 1000.0,
            tip_chord_m=c_t_mm / 1000.0,
        )

    @property
    def has_elliptical_leading_edge(self) -> bool:
        return self.leading_edge_span_m is None

    @property
    def area_m2(self) -> float:
        """Planform area S in m^2."""
        b, c_r, c_t = self.span_m, self.root_chord_m, self.tip_chord_m
        if self.leading_edge_span_m is None:
            return b * c_t + math.pi / 4 * b * (c_r - c_t)
        return (self.leading_edge_span_m + b) / 2 * (c_r - c_t) + b * c_t

    @property
    def aspect_ratio(self) -> float:
        """Aspect ratio b^2 / S (dimensionless)."""
        return self.span_m**2 / self.area_m2

    def chord_at(self, spanwise_position_m: float | np.ndarray) -> np.ndarray:
        """Local chord (m) at spanwise position(s) y (m, from the plane of symmetry); zero outside
        the span.
        """
        y = np.abs(np.asarray(spanwise_position_m, dtype=float))
        half_span = self.span_m / 2
        c_r, c_t = self.root_chord_m, self.tip_chord_m
        if self.leading_edge_span_m is None:
            ratio = np.clip(y / half_span, 0.0, 1.0)
            chord = c_t + (c_r - c_t) * np.sqrt(1.0 - ratio**2)
        else:
            half_le = self.leading_edge_span_m / 2
            widening = half_span - half_le
            if widening <= 0:
                chord = np.full_like(y, c_r)
            else:
                fraction = np.clip((y - half_le) / widening, 0.0, 1.0)
                chord = c_r - fraction * (c_r - c_t)
        return np.where(y <= half_span, chord, 0.0)

    def leading_edge_setback_at(self, spanwise_position_m: float | np.ndarray) -> np.ndarray:
        """Distance (m) of the local leading edge aft of the root leading edge; the trailing edge is
        straight.
        """
        return self.root_chord_m - self.chord_at(spanwise_position_m)

    def validation_problems(self) -> list[str]:
        """Every reason this planform is not a buildable tail, one line each (empty: valid)."""
        named = {
            "span_m": self.span_m,
            "root_chord_m": self.root_chord_m,
            "tip_chord_m": self.tip_chord_m,
        }
        if self.leading_edge_span_m is not None:
            named["leading_edge_span_m"] = self.leading_edge_span_m
        problems = [
            f"{name} = {value!r} must be a positive finite length"
            for name, value in named.items()
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0)
        ]
        problems += [
            f"{name} = {value * 1e3:g} mm is longer than {MAX_DIMENSION_M * 1e3:g} mm"
            for name, value in named.items()
            if not problems and value > MAX_DIMENSION_M
        ]
        if problems:
            return problems
        if self.tip_chord_m > self.root_chord_m:
            problems.append(
                f"tip chord {self.tip_chord_m * 1e3:.1f} mm exceeds root chord "
                f"{self.root_chord_m * 1e3:.1f} mm"
            )
        if self.leading_edge_span_m is not None and self.leading_edge_span_m > self.span_m:
            problems.append(
                f"leading-edge span {self.leading_edge_span_m * 1e3:.1f} mm exceeds span "
                f"{self.span_m * 1e3:.1f} mm"
            )
        if not problems and not self.encloses_base_tail():
            problems.append(
                "planform does not enclose the base tail (80 mm span, 48 mm chord, leading "
                "corners 10 mm aft of its leading-edge centre, aligned at the leading-edge "
                "centreline)"
            )
        return problems

    def encloses_base_tail(self) -> bool:
        """True if every vertex of the base-tail outline lies inside this (convex) planform."""
        vertices = base_tail_outline_vertices_m()
        y, aft = vertices[:, 0], vertices[:, 1]
        inside_span = np.abs(y) <= self.span_m / 2 + _CONTAINMENT_TOLERANCE_M
        behind_leading_edge = aft >= self.leading_edge_setback_at(y) - _CONTAINMENT_TOLERANCE_M
        before_trailing_edge = aft <= self.root_chord_m + _CONTAINMENT_TOLERANCE_M
        return bool(np.all(inside_span & behind_leading_edge & before_trailing_edge))

    def validate(self, where: str = "tail geometry") -> TailGeometry:
        """Return self if valid, else raise :class:`UserInputError` naming the problems."""
        problems = self.validation_problems()
        if problems:
            raise UserInputError(where, "; ".join(problems))
        return self


@dataclass(frozen=True)
class StudyTail:
    """One row of the study's tail table: name, geometry and the published S (m^2) and AR."""

    name: str
    geometry: TailGeometry
    published_area_m2: float
    published_aspect_ratio: float


def study_tails() -> dict[str, StudyTail]:
    """The 14 study tails (package data ``vehicle/data/tails.csv``) keyed by name (``"S3"``)."""
    tails: dict[str, StudyTail] = {}
    for row in study_table_rows(STUDY_TAILS_TABLE):
        geometry = TailGeometry.from_mm(
            float(row["b_mm"]),
            float(row["b_le_mm"]) if row["b_le_mm"] else None,
            float(row["c_r_mm"]),
            float(row["c_t_mm"]),
        )
        tails[row["tail"]] = StudyTail(
            name=row["tail"],
            geometry=geometry,
            published_area_m2=float(row["s_cm2"]) * 1e-4,
            published_aspect_ratio=float(row["ar"]),
        )
    return tails


def study_fuselages_x_h_m() -> dict[str, float]:
    """The study's fuselages (package data ``vehicle/data/fuselages.csv``, Table 1): letter -> tail position x_h
    (m), in the table's order."""
    rows = study_table_rows(STUDY_FUSELAGES_TABLE)
    return {row["fuselage"]: float(row["x_h_mm"]) * 1e-3 for row in rows}


def study_tail_geometry(tail_name: str, where: str = "tail") -> TailGeometry:
    """Geometry of a study tail by name; unknown names raise :class:`UserInputError`."""
    tails = study_tails()
    if tail_name not in tails:
        raise UserInputError(
            where, f"unknown tail {tail_name!r}; known tails: {', '.join(sorted(tails))}"
        )
    return tails[tail_name].geometry


def require_tail_position_mm(where: str, x_h_mm: float) -> None:
    """Refuse a tail position x_h (mm) that is not finite or lies outside ``TAIL_POSITION_RANGE_MM``."""
    low, high = TAIL_POSITION_RANGE_MM
    if not math.isfinite(x_h_mm):
        raise UserInputError(where, f"value {x_h_mm!r} is not a finite number")
    if not low <= x_h_mm <= high:
        raise UserInputError(where, f"tail position {x_h_mm:g} mm is outside {low:g}-{high:g} mm")
