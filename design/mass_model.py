"""Vehicle mass and pitch inertia as functions of tail geometry and position (floats or CasADi symbols).

Without campaign data these are documented *estimates* anchored to the study's figures (docs/background.md section 1):

- mass ``m = m_0 + rho_tail S + lambda_fuselage (x_h - 57 mm)``: tail foil and stiffeners at
  ``rho_tail = 0.03 kg/m^2`` (*estimate*: 10 um Mylar is 0.014 kg/m^2, plus carbon strips), the fuselage
  extension at ``lambda = 0.017 kg/m`` and ``m_0 = 22.62 g``, chosen so that the lightest study configuration (T3
  at 57 mm) weighs 22.8 g and the heaviest (S6 at 126 mm) 24.3 g, the study's range;
- pitch inertia ``I_yy = I_57 (1 + 1.5 (x_h - 57 mm) / 69 mm) + rho_tail (S - S_T2) (x_h + 0.07 m)^2``: +150 % from
  57 to 126 mm (study), ``I_57`` such that the standard tail T2 at 98 mm has 1.5e-4 kg m^2 (the value
  docs/frames.md checks the study's eigenstructure with); the second term is the extra tail mass at its arm
  (CG to the tail's centre about x_h + 70 mm, *estimate*).

When a :class:`~ornitail.design.trends.TrendModel` with trends of ``mass_kg`` / ``iyy_kg_m2`` (fitted from a
campaign's mass columns) is passed, its trend is used instead. Geometry vector: ``(b, b_LE, c_r, c_t, x_h)`` in
metres (hexagonal planform).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ornitail.design.trend_basis import hexagon_area_m2
from ornitail.vehicle.geometry import study_tails

TAIL_AREAL_DENSITY_KG_M2 = 0.03
FUSELAGE_EXTENSION_KG_M = 0.017
BASE_MASS_KG = 0.02262
REFERENCE_X_H_M = 0.057
INERTIA_GROWTH_PER_M = 1.5 / 0.069
TAIL_ARM_BEYOND_X_H_M = 0.07
_T2_AT_98_MM_IYY_KG_M2 = 1.5e-4


def _standard_tail_area_m2() -> float:
    return study_tails()["T2"].geometry.area_m2


INERTIA_AT_REFERENCE_KG_M2 = _T2_AT_98_MM_IYY_KG_M2 / (
    1.0 + INERTIA_GROWTH_PER_M * (0.098 - REFERENCE_X_H_M)
)


def _trend_of(trend_model: Any, quantity: str) -> Any:
    if trend_model is None:
        return None
    return trend_model.trends.get(quantity)


def vehicle_mass_kg(geometry_vector: Sequence[Any], trend_model: Any = None) -> Any:
    """Vehicle mass (kg) at ``(b, b_LE, c_r, c_t, x_h)`` (m); the ``mass_kg`` trend when fitted."""
    trend = _trend_of(trend_model, "mass_kg")
    if trend is not None:
        return trend.casadi_value(geometry_vector)
    span, leading_edge_span, root_chord, tip_chord, x_h = geometry_vector
    area = hexagon_area_m2(span, leading_edge_span, root_chord, tip_chord)
    return (
        BASE_MASS_KG
        + TAIL_AREAL_DENSITY_KG_M2 * area
        + FUSELAGE_EXTENSION_KG_M * (x_h - REFERENCE_X_H_M)
    )


def pitch_inertia_kg_m2(geometry_vector: Sequence[Any], trend_model: Any = None) -> Any:
    """Pitch inertia I_yy (kg m^2) about the CG at ``(b, b_LE, c_r, c_t, x_h)`` (m); the ``iyy_kg_m2`` trend
    when fitted."""
    trend = _trend_of(trend_model, "iyy_kg_m2")
    if trend is not None:
        return trend.casadi_value(geometry_vector)
    span, leading_edge_span, root_chord, tip_chord, x_h = geometry_vector
    area = hexagon_area_m2(span, leading_edge_span, root_chord, tip_chord)
    arm = x_h + TAIL_ARM_BEYOND_X_H_M
    return (
        INERTIA_AT_REFERENCE_KG_M2 * (1.0 + INERTIA_GROWTH_PER_M * (x_h - REFERENCE_X_H_M))
        + TAIL_AREAL_DENSITY_KG_M2 * (area - _standard_tail_area_m2()) * arm * arm
    )
