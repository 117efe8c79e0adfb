"""A design proposal in user units: targets checked and converted to SI, the result as a plain dict
(mm, cm^2, deg in the field names), its readable text and its honest status line.

Shared by ``ornitail design propose``, ``design pareto``, the demo and the window's design tab.
"""

from __future__ import annotations

import math
from typing import Any

from ornitail.core.errors import UserInputError, require_finite
from ornitail.core.normal_quantiles import NORMAL_QUANTILE_95
from ornitail.design.design_evaluation import IntervalEstimate, PredictedQuantity
from ornitail.design.proposal import (
    MAX_STARTS,
    TARGET_NAMES,
    DesignTargets,
    Proposal,
    TargetBand,
)
from ornitail.design.trends import TrendModel
from ornitail.vehicle.geometry import require_tail_position_mm

_UNMET_UNITS = {
    "theta_ss": ("deg", math.degrees(1.0)),
    "v_ss": ("m/s", 1.0),
    "f_ss": ("Hz", 1.0),
    "damping_ratio": ("", 1.0),
    "natural_frequency": ("rad/s", 1.0),
}


MAX_TARGETS = {"v_ss_m_s": 20.0, "f_ss_hz": 100.0, "omega_rad_s": 1000.0}
"""Largest targets accepted (m/s, Hz, rad/s): far beyond any flapping-wing MAV."""
MAX_ROBUST_K = 10.0
"""Largest robust factor k (sigmas)."""


def _band(
    where: str, value: float | None, tolerance: float, scale: float, tolerance_where: str
) -> TargetBand | None:
    require_finite(tolerance_where, tolerance)
    if tolerance < 0:
        raise UserInputError(tolerance_where, f"tolerance {tolerance!r} must be >= 0")
    if value is None:
        return None
    require_finite(where, value)
    return TargetBand.around(value * scale, tolerance * scale)


def check_solver_settings(
    x_h_mm: float | None, start_count: int, robust_k: float = 0.0, point_count: int | None = None
) -> None:
    """Refuse a tail position (mm), start count, robust factor or front size outside its range, naming it."""
    if x_h_mm is not None:
        require_tail_position_mm("x_h_mm", x_h_mm)
    if not 1 <= start_count <= MAX_STARTS:
        raise UserInputError("start_count", f"{start_count} is outside 1..{MAX_STARTS}")
    require_finite("robust_k", robust_k)
    if not 0.0 <= robust_k <= MAX_ROBUST_K:
        raise UserInputError("robust_k", f"{robust_k:g} is outside 0..{MAX_ROBUST_K:g}")
    if point_count is not None and not 2 <= point_count <= 100:
        raise UserInputError("point_count", f"{point_count} is outside 2..100")


def design_targets(
    theta_ss_deg: float | None,
    theta_tol_deg: float,
    v_ss_m_s: float | None,
    v_tol_m_s: float,
    f_ss_hz: float | None,
    f_tol_hz: float,
    zeta: float | None,
    omega_rad_s: float | None,
    omega_tol_rad_s: float,
) -> DesignTargets:
    """Targets in SI from values in user units (degrees converted to radians); a value out of range raises
    :class:`UserInputError` naming the target (``v_ss_m_s``) and the value."""
    if zeta is not None:
        require_finite("zeta", zeta)
        if not 0.0 < zeta < 0.99:
            raise UserInputError(
                "zeta", f"value {zeta!r} must lie in (0, 0.99): an oscillatory mode"
            )
    if theta_ss_deg is not None and not 0.0 < theta_ss_deg < 90.0:
        raise UserInputError("theta_ss_deg", f"value {theta_ss_deg!r} must lie in (0, 90) degrees")
    for where, value in (
        ("v_ss_m_s", v_ss_m_s),
        ("f_ss_hz", f_ss_hz),
        ("omega_rad_s", omega_rad_s),
    ):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise UserInputError(where, f"value {value!r} must be a positive finite number")
        if value is not None and value > MAX_TARGETS[where]:
            raise UserInputError(where, f"value {value:g} is more than {MAX_TARGETS[where]:g}")
    return DesignTargets(
        theta_ss_rad=_band(
            "theta_ss_deg", theta_ss_deg, theta_tol_deg, math.radians(1.0), "theta_tol_deg"
        ),
        v_ss_m_s=_band("v_ss_m_s", v_ss_m_s, v_tol_m_s, 1.0, "v_tol_m_s"),
        f_ss_hz=_band("f_ss_hz", f_ss_hz, f_tol_hz, 1.0, "f_tol_hz"),
        damping_ratio_min=zeta,
        natural_frequency_rad_s=_band(
            "omega_rad_s", omega_rad_s, omega_tol_rad_s, 1.0, "omega_tol_rad_s"
        ),
    )


def _interval_dict(
    estimate: IntervalEstimate | PredictedQuantity, scale: float = 1.0
) -> dict[str, Any]:
    value, sigma_mean, sigma_new = estimate.value, estimate.sigma_mean, estimate.sigma_new
    z = NORMAL_QUANTILE_95
    result = {
        "value": value * scale,
        "sigma_mean": sigma_mean * scale,
        "sigma_new": sigma_new * scale,
        "interval_95_mean": [(value - z * sigma_mean) * scale, (value + z * sigma_mean) * scale],
        "interval_95_new": [(value - z * sigma_new) * scale, (value + z * sigma_new) * scale],
    }
    if isinstance(estimate, PredictedQuantity):
        result["extrapolation_mahalanobis"] = estimate.extrapolation
        result["sources"] = list(estimate.sources)
    return result


def extrapolation_notes(proposal: Proposal, trend_model: TrendModel) -> dict[str, str]:
    """Trend name -> why the proposal lies outside that trend's fitted data (only those that do)."""
    geometry = proposal.geometry
    vector = (
        geometry.span_m,
        geometry.leading_edge_span_m,
        geometry.root_chord_m,
        geometry.tip_chord_m,
        proposal.x_h_m,
    )
    return {
        name: prediction.extrapolation_note
        for name, prediction in trend_model.predict(vector).items()
        if prediction.outside_fitted_range
    }


_INTERVAL_KINDS = {"mean": "of the mean trend", "new": "for a new flight"}
_CROSSING_FRACTION = 1e-3
"""An interval reaches past a target's edge when it does by more than this fraction of its half-width (a robust
target, value - k sigma at the edge, is met to the solver's tolerance)."""


def targets_within_their_noise(proposal: Proposal) -> list[str]:
    """The targets the design meets by its predicted value whose 95 % interval (the proposal's kind: mean trend or
    new flight) still reaches past the target's edge, one phrase each in user units ("damping ratio 0.014 to 0.64
    reaches below 0.25")."""
    if not proposal.targets_met:
        return []
    evaluation = proposal.evaluation
    quantities = evaluation.quantities
    estimates = (
        quantities.get("theta_ss_rad"),
        quantities.get("v_ss_m_s"),
        quantities.get("f_ss_hz"),
        evaluation.damping_ratio,
        evaluation.natural_frequency_rad_s,
    )
    phrases = []
    for name, band, estimate in zip(TARGET_NAMES, proposal.targets.bands(), estimates, strict=True):
        if band is None or estimate is None:
            continue
        low, high = IntervalEstimate(
            estimate.value, estimate.sigma_mean, estimate.sigma_new
        ).interval_95(proposal.interval_kind)
        margin = _CROSSING_FRACTION * (high - low) / 2
        unit, scale = _UNMET_UNITS[name]
        shown = f"{name.replace('_', ' ')} {low * scale:.3g} to {high * scale:.3g}{' ' + unit if unit else ''}"
        below, above = low < band.lower - margin, high > band.upper + margin
        if below and above:
            phrases.append(
                f"{shown} reaches past both ends of {band.lower * scale:.3g} to {band.upper * scale:.3g}"
            )
        elif below:
            phrases.append(f"{shown} reaches below {band.lower * scale:.3g}")
        elif above:
            phrases.append(f"{shown} reaches above {band.upper * scale:.3g}")
    return phrases


def honest_status(proposal: Proposal, extrapolated: int, trends: int) -> str:
    """The solver status, qualified when the targets are met: "by extrapolation" when the design lies outside the
    fitted data of ``extrapolated`` of the ``trends`` trends (their intervals assume the trend holds there), "by the
    predicted values only" when a target's 95 % interval reaches past its edge."""
    if not proposal.targets_met:
        return proposal.solver_status
    qualifiers = []
    if extrapolated:
        qualifiers.append(
            f"by extrapolation ({extrapolated} of {trends} trends outside their fitted data; "
            "their intervals assume the trend holds there)"
        )
    within_noise = targets_within_their_noise(proposal)
    if within_noise:
        qualifiers.append(
            f"by the predicted values only (95 % intervals {_INTERVAL_KINDS[proposal.interval_kind]}: "
            f"{'; '.join(within_noise)})"
        )
    if not qualifiers:
        return proposal.solver_status
    return proposal.solver_status.replace(
        "targets met", "targets met " + " and ".join(qualifiers), 1
    )


def proposal_result(proposal: Proposal, trend_model: TrendModel) -> dict[str, Any]:
    """The proposal as a plain dict with user-facing units (mm, cm^2, deg) in the field names."""
    evaluation = proposal.evaluation
    geometry = proposal.geometry
    quantities = evaluation.quantities
    steady = {
        "theta_ss_deg": _interval_dict(quantities["theta_ss_rad"], math.degrees(1.0)),
        "v_ss_m_s": _interval_dict(quantities["v_ss_m_s"]),
    }
    if "f_ss_hz" in quantities:
        steady["f_ss_hz"] = _interval_dict(quantities["f_ss_hz"])
    notes = extrapolation_notes(proposal, trend_model)
    return {
        "objective": proposal.objective,
        "solver_status": honest_status(proposal, len(notes), len(trend_model.trends)),
        "targets_met": proposal.targets_met,
        "targets_met_inside_fitted_data": proposal.targets_met and not notes,
        "targets_met_by_their_95_percent_intervals": proposal.targets_met
        and not targets_within_their_noise(proposal),
        "unmet_targets": {
            f"{name}_miss{('_' + _UNMET_UNITS[name][0].replace('/', '_')) if _UNMET_UNITS[name][0] else ''}": miss
            * _UNMET_UNITS[name][1]
            for name, miss in proposal.unmet_targets.items()
        },
        "binding_constraints": proposal.binding_constraints,
        "geometry": {
            "b_mm": geometry.span_m * 1e3,
            "b_le_mm": geometry.leading_edge_span_m * 1e3,
            "c_r_mm": geometry.root_chord_m * 1e3,
            "c_t_mm": geometry.tip_chord_m * 1e3,
            "valid": geometry.validation_problems() == [],
        },
        "x_h_mm": proposal.x_h_m * 1e3,
        "s_cm2": proposal.area_m2 * 1e4,
        "ar": proposal.aspect_ratio,
        "steady_state": steady,
        "poles": [
            {"real": float(p.real), "imag": float(p.imag)} for p in evaluation.modes.eigenvalues
        ],
        "oscillatory_mode": {
            "damping_ratio": _interval_dict(evaluation.damping_ratio),
            "natural_frequency_rad_s": _interval_dict(evaluation.natural_frequency_rad_s),
            "damping_ratio_in_problem": proposal.damping_ratio_in_problem,
            "sigma_damping_ratio_in_problem": proposal.sigma_damping_ratio_in_problem,
            "interval_kinds": "mean: uncertainty of the mean trend; new: one new flight of the built tail",
        },
        "robust": {"k": proposal.robust_k, "interval": proposal.interval_kind},
        "mass_kg": quantities["mass_kg"].value,
        "iyy_kg_m2": quantities["iyy_kg_m2"].value,
        "mass_source": list(quantities["mass_kg"].sources),
        "max_extrapolation_mahalanobis": evaluation.max_extrapolation,
        "extrapolation_notes": notes,
        "trend_sources": sorted({s for t in trend_model.trends.values() for s in t.sources}),
        "starts_tried": proposal.starts_tried,
        "starts_converged": proposal.starts_converged,
        "per_position": [
            {
                **{k: v for k, v in item.items() if k not in ("x_h_m", "area_m2")},
                "x_h_mm": None if item["x_h_m"] is None else item["x_h_m"] * 1e3,
                "s_cm2": None if item["area_m2"] is None else item["area_m2"] * 1e4,
            }
            for item in proposal.per_position
        ],
        "solve_time_s": proposal.solve_time_s,
    }


def _format_interval(name: str, item: dict[str, Any], unit: str) -> str:
    low, high = item["interval_95_new"]
    low_mean, high_mean = item["interval_95_mean"]
    return (
        f"  {name:24s} {item['value']:.4g} {unit}  95 % mean trend [{low_mean:.4g}, {high_mean:.4g}]"
        f"  new flight [{low:.4g}, {high:.4g}]"
    )


def render_proposal(result: dict[str, Any]) -> str:
    """Readable text of :func:`proposal_result`."""
    g = result["geometry"]
    lines = [
        f"status: {result['solver_status']} ({result['starts_converged']}/{result['starts_tried']} starts converged)",
        f"tail: b {g['b_mm']:.1f} mm, b_LE {g['b_le_mm']:.1f} mm, c_r {g['c_r_mm']:.1f} mm, "
        f"c_t {g['c_t_mm']:.1f} mm at x_h {result['x_h_mm']:.1f} mm",
        f"S = {result['s_cm2']:.1f} cm^2, AR = {result['ar']:.2f}",
        "steady state:",
    ]
    units = {"theta_ss_deg": "deg", "v_ss_m_s": "m/s", "f_ss_hz": "Hz"}
    for name, item in result["steady_state"].items():
        lines.append(_format_interval(name, item, units[name]))
    mode = result["oscillatory_mode"]
    lines.append("oscillatory pitch mode:")
    lines.append(_format_interval("damping ratio", mode["damping_ratio"], ""))
    lines.append(_format_interval("natural frequency", mode["natural_frequency_rad_s"], "rad/s"))
    poles = ", ".join(f"{p['real']:.3f}{p['imag']:+.3f}j" for p in result["poles"])
    lines.append(f"poles (1/s): {poles}")
    if result["unmet_targets"]:
        lines.append(
            "unmet targets: "
            + ", ".join(f"{k} = {v:.4g}" for k, v in result["unmet_targets"].items())
        )
    lines.append("binding constraints: " + ("; ".join(result["binding_constraints"]) or "none"))
    lines.append(
        f"largest extrapolation (Mahalanobis): {result['max_extrapolation_mahalanobis']:.3g}"
    )
    names_by_note: dict[str, list[str]] = {}
    for name, note in result["extrapolation_notes"].items():
        names_by_note.setdefault(note, []).append(name)
    for note, names in names_by_note.items():
        lines.append(f"  extrapolated {', '.join(names)}: {note}")
    for name, path in result.get("files", {}).items():
        lines.append(f"{name}: {path}")
    return "\n".join(lines)
