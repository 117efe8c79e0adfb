"""Tail-geometry proposals: a CasADi (Opti) problem over b, b_LE, c_r, c_t and x_h.

The problem is built once per trend model and re-solved (parameters and initial values change, the
graph does not) for every fuselage, start point, objective and Pareto point.

Variables (scaled to order one by hand): the geometry vector (b, b_LE, c_r, c_t, x_h) in decimetres;
the oscillatory pitch mode's damping ratio zeta and natural frequency omega (omega / 5 rad/s) and the
second quadratic factor s^2 + a s + p (a / 10, p / 10) holding the two real poles; one slack per
target (in the target's tolerance unit, see ``TARGET_SOFT_UNITS``).

Model: every A-matrix quantity is the trend's CasADi expression of the geometry; mass and inertia
come from the trend model or design/mass_model.py. The characteristic polynomial of the 4x4 A is
formed by Faddeev-LeVerrier and equated, coefficient by coefficient, to
(s^2 + 2 zeta omega s + omega^2)(s^2 + a s + p): four smooth equalities that put the pitch mode's
damping and frequency into the problem as variables (CasADi cannot differentiate eig). zeta <= 0.99
keeps the first factor a complex pair, so it is the oscillatory mode whenever A has one complex
pair; every solution is re-checked with numpy eigenvalues (design_evaluation.py).

Constraints: the planform encloses the base tail (geometry.py): b >= 80 mm, c_r >= 48 mm and the
leading edge at y = 40 mm at most 10 mm behind the root leading edge, written as the smooth bilinear
inequality 0.010 (b - b_LE)/2 >= (0.040 - b_LE/2)(c_r - c_t) (exact: when b_LE >= 80 mm both sides
have the right sign by themselves); c_t <= c_r; b_LE <= b; practical bounds on every dimension, on
S and AR (the trends' range); the two real poles stable (a, p >= 0.01); targets as bands.

Robust option: zeta - k sigma_zeta >= zeta_min, with sigma_zeta by the delta method: implicit
differentiation of the factor equations F(y) = c(v), dy/dv = (dF/dy)^-1 dc/dv, with v the predicted
quantities and Var(v) = phi^T Cov(beta) phi (mean trend) or that plus the residual variance (a new
flight). Trends are fitted separately, so their errors are taken as independent.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from scipy.stats import qmc

from ornitail.core.errors import UserInputError
from ornitail.design.design_evaluation import (
    A_MODEL_QUANTITIES,
    DesignEvaluation,
    MassInertiaModel,
    a_matrix_of_quantities,
    evaluate_design,
    mass_inertia_model_for,
    require_model_quantities,
)
from ornitail.design.linear_model import (
    characteristic_polynomial,
    modal_summary,
    quadratic_factor_coefficients,
)
from ornitail.vehicle.geometry import (
    BASE_TAIL_CHORD_M,
    BASE_TAIL_CORNER_SETBACK_M,
    BASE_TAIL_SPAN_M,
    TailGeometry,
    study_fuselages_x_h_m,
)

FUSELAGE_X_H_M = dict(sorted(study_fuselages_x_h_m().items(), key=lambda item: item[1]))
"""The study's fuselages (``vehicle/data/fuselages.csv``): tail position x_h in metres, shortest first."""
OBJECTIVES = ("min-area", "max-damping", "closest")
INTERVAL_KINDS = ("mean", "new")
MAX_STARTS = 256
"""Most optimiser starts per tail position."""
TARGET_NAMES = ("theta_ss", "v_ss", "f_ss", "damping_ratio", "natural_frequency")
TARGET_SOFT_UNITS = (math.radians(1.0), 0.02, 0.1, 0.02, 0.2)
"""Units of the target slacks and of the 'closest' objective: 1 deg, 0.02 m/s, 0.1 Hz, 0.02, 0.2 rad/s."""
MAX_OSCILLATORY_DAMPING = 0.99
MIN_REAL_FACTOR = 0.01
_LENGTH_SCALE_M = 0.1
_OMEGA_SCALE = 5.0
_SECOND_FACTOR_SCALE = 10.0
_AREA_SCALE_M2 = 0.01
_OPEN_BAND = 1e6
_CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
_SLACK_TOLERANCE = 1e-4  # in soft units: 1e-4 deg, 2e-6 m/s ... far below anything that matters
_BINDING_DUAL_TOLERANCE = 1e-6
AGREEING_STARTS = 3
"""Multi-start stops once this many starts reach the same best objective (0: run every start)."""
_AGREEMENT_TOLERANCE = 1e-7  # relative objective: S to 1e-7 relative, ~1e-5 cm^2 at 136 cm^2
_VERIFY_TOLERANCE = 1e-5  # NLP zeta vs numpy zeta: IPOPT tol 1e-8 on order-one equalities


@dataclass(frozen=True)
class TargetBand:
    """A target interval [lower, upper] in SI units (an equality when lower == upper)."""

    lower: float
    upper: float

    @classmethod
    def around(cls, value: float, tolerance: float = 0.0) -> TargetBand:
        return cls(value - tolerance, value + tolerance)


@dataclass(frozen=True)
class DesignTargets:
    """What the proposed tail must achieve (SI units, radians); None: no target.

    ``damping_ratio_min`` is a lower bound on zeta (zeta - k sigma_zeta with the robust option).
    """

    theta_ss_rad: TargetBand | None = None
    v_ss_m_s: TargetBand | None = None
    f_ss_hz: TargetBand | None = None
    damping_ratio_min: float | None = None
    natural_frequency_rad_s: TargetBand | None = None

    def bands(self) -> list[TargetBand | None]:
        zeta = (
            None
            if self.damping_ratio_min is None
            else TargetBand(self.damping_ratio_min, _OPEN_BAND)
        )
        return [self.theta_ss_rad, self.v_ss_m_s, self.f_ss_hz, zeta, self.natural_frequency_rad_s]


@dataclass(frozen=True)
class DesignBounds:
    """Practical bounds (SI): dimensions, area and aspect ratio (the trends' range), continuous x_h."""

    span_m: tuple[float, float] = (BASE_TAIL_SPAN_M, 0.300)
    leading_edge_span_m: tuple[float, float] = (0.010, 0.300)
    root_chord_m: tuple[float, float] = (BASE_TAIL_CHORD_M, 0.120)
    tip_chord_m: tuple[float, float] = (0.005, 0.120)
    area_m2: tuple[float, float] = (0.0050, 0.0200)
    aspect_ratio: tuple[float, float] = (1.5, 6.5)
    x_h_m: tuple[float, float] = (0.057, 0.126)
    real_pole_decay_1_s: float = 0.2
    within_fitted_range: bool = True


@dataclass(frozen=True)
class SolveSettings:
    """One solve's parameters: targets, objective, robust factor k and its interval kind, x_h range."""

    targets: DesignTargets
    objective: str = "min-area"
    robust_k: float = 0.0
    interval_kind: str = "new"
    x_h_range_m: tuple[float, float] = (0.098, 0.098)
    soft_targets: bool = False


@dataclass
class StartOutcome:
    """The result of one IPOPT run from one start point."""

    geometry_vector_m: np.ndarray
    damping_ratio: float
    natural_frequency_rad_s: float
    sigma_damping_ratio: float
    objective_value: float
    target_violations: dict[str, float]
    binding_constraints: list[str]
    status: str
    converged: bool
    verified: bool = False


@dataclass
class Proposal:
    """A proposed tail and everything predicted about it (SI units, radians inside).

    ``evaluation`` holds S, AR, steady state, A, poles and the numpy damping ratio and natural
    frequency with intervals (mean trend and new flight); ``*_in_problem`` are the NLP's own values
    (they agree with numpy to ``_VERIFY_TOLERANCE``). ``unmet_targets`` names targets the nearest
    achievable design misses (with the miss in SI units), ``binding_constraints`` the constraints
    that hold the optimum where it is.
    """

    geometry: TailGeometry
    x_h_m: float
    objective: str
    targets: DesignTargets
    evaluation: DesignEvaluation
    damping_ratio_in_problem: float
    natural_frequency_in_problem_rad_s: float
    sigma_damping_ratio_in_problem: float
    robust_k: float
    interval_kind: str
    targets_met: bool
    unmet_targets: dict[str, float]
    binding_constraints: list[str]
    solver_status: str
    starts_tried: int
    starts_converged: int
    per_position: list[dict[str, Any]] = field(default_factory=list)
    solve_time_s: float = 0.0

    @property
    def area_m2(self) -> float:
        return self.evaluation.area_m2

    @property
    def aspect_ratio(self) -> float:
        return self.evaluation.aspect_ratio


@dataclass
class _BuiltNlp:
    """One built Opti problem: its variables, parameters and named constraints.

    ``robust_k`` and ``new_flight`` are None in the build without the robust term.
    """

    opti: Any
    scaled: Any
    factor: Any
    slack: Any
    zeta: Any
    omega: Any
    x_h_range: Any
    target_lower: Any
    target_upper: Any
    slack_enabled: Any
    robust_k: Any
    new_flight: Any
    weights: Any
    named_constraints: list[tuple[str, Any]]
    target_constraints: list[tuple[str, Any, Any]]


class ProposalProblem:
    """The proposal NLP for one trend model, built once and re-solved.

    Parameters
    ----------
    trend_model : TrendModel
        Trends (design/trends.py) for every A-matrix derivative, theta_ss and V_ss (f_ss optional).
    bounds : DesignBounds
        Practical bounds.
    mass_inertia : MassInertiaModel or None
        Mass and inertia model; None takes them from the trend model or design/mass_model.py.
    """

    def __init__(
        self,
        trend_model: Any,
        bounds: DesignBounds | None = None,
        mass_inertia: MassInertiaModel | None = None,
    ) -> None:
        self.trend_model = trend_model
        self.bounds = bounds or DesignBounds()
        self.mass_inertia = (
            mass_inertia if mass_inertia is not None else mass_inertia_model_for(trend_model)
        )
        require_model_quantities(trend_model, self.mass_inertia)
        self.solve_count = 0
        self._a_matrix_function, self._sigma_zeta_function = self._model_functions()
        self._has_frequency_trend = "f_ss_hz" in self.trend_model.trends
        self._builds = {False: self._build(robust=False)}

    def _nlp_for(self, robust: bool) -> _BuiltNlp:
        """The NLP without the robust term (robust_k = 0), or with it (built at first need)."""
        if robust not in self._builds:
            self._builds[robust] = self._build(robust=robust)
        return self._builds[robust]

    # -- building ---------------------------------------------------------------------------------
    def _quantity_expressions(self, vector: tuple[Any, ...]) -> tuple[dict, dict, dict]:
        values, variance_mean, residual_variance = {}, {}, {}
        for name in A_MODEL_QUANTITIES + ("f_ss_hz",):
            if name in self.trend_model.trends:
                trend = self.trend_model.trends[name]
                values[name] = trend.casadi_value(vector)
                features = trend.basis.features(vector)
                covariance = np.asarray(trend.covariance, dtype=float)
                variance_mean[name] = sum(
                    features[i] * features[j] * covariance[i, j]
                    for i in range(len(features))
                    for j in range(len(features))
                    if covariance[i, j] != 0.0
                )
                residual_variance[name] = float(trend.residual_variance)
            elif name == "mass_kg":
                values[name] = self.mass_inertia.mass_kg(vector)
            elif name == "iyy_kg_m2":
                values[name] = self.mass_inertia.iyy_kg_m2(vector)
        return values, variance_mean, residual_variance

    def _model_functions(self) -> tuple[ca.Function, ca.Function]:
        """A(scaled geometry) and sigma_zeta(scaled geometry, factor, new_flight) as functions."""
        scaled = ca.MX.sym("scaled", 5)
        factor = ca.MX.sym("factor", 4)
        new_flight = ca.MX.sym("new_flight")
        vector = tuple(_LENGTH_SCALE_M * scaled[index] for index in range(5))
        values, variance_mean, residual_variance = self._quantity_expressions(vector)
        a_rows = a_matrix_of_quantities(values, cos=ca.cos, sin=ca.sin)
        a_matrix = ca.Function(
            "a_matrix", [scaled], [ca.vertcat(*[ca.horzcat(*row) for row in a_rows])]
        )
        sigma = self._delta_method_sigma(
            values, variance_mean, residual_variance, factor, new_flight
        )
        sigma_zeta = ca.Function("sigma_zeta", [scaled, factor, new_flight], [sigma])
        return a_matrix.expand(), sigma_zeta.expand()

    def _build(self, robust: bool) -> _BuiltNlp:
        """Build the Opti problem; without ``robust`` the sigma_zeta expressions are left out
        (they are most of the Hessian's cost and vanish when robust_k = 0)."""
        opti = ca.Opti()
        bounds = self.bounds
        scaled = opti.variable(5)
        vector = tuple(_LENGTH_SCALE_M * scaled[index] for index in range(5))
        span, leading_edge_span, root_chord, tip_chord, x_h = vector
        factor = opti.variable(4)
        zeta = factor[0]
        omega = _OMEGA_SCALE * factor[1]
        second_linear = _SECOND_FACTOR_SCALE * factor[2]
        second_constant = _SECOND_FACTOR_SCALE * factor[3]
        slack = opti.variable(5)

        x_h_range = opti.parameter(2)
        target_lower = opti.parameter(5)
        target_upper = opti.parameter(5)
        slack_enabled = opti.parameter()
        robust_k = opti.parameter() if robust else None
        new_flight = opti.parameter() if robust else None
        weights = opti.parameter(3)  # area, damping, target slacks

        values, _, _ = self._quantity_expressions(vector)
        area = (leading_edge_span + span) / 2 * (root_chord - tip_chord) + span * tip_chord
        aspect_ratio = span * span / area

        a_rows = a_matrix_of_quantities(values, cos=ca.cos, sin=ca.sin)
        polynomial = characteristic_polynomial(a_rows)
        factored = quadratic_factor_coefficients(zeta, omega, second_linear, second_constant)
        reference = self._reference_polynomial()
        for k in range(4):
            opti.subject_to((factored[k] - polynomial[k]) / reference[k] == 0)

        robust_zeta = zeta
        if robust:
            sigma_zeta = self._sigma_zeta_function(scaled, factor, new_flight)
            robust_zeta = zeta - robust_k * sigma_zeta

        named: list[tuple[str, Any]] = []

        def require(name: str, constraint: Any) -> None:
            opti.subject_to(constraint)
            named.append((name, constraint))

        s = _LENGTH_SCALE_M
        for label, variable, (low, high) in (
            ("span b", scaled[0], bounds.span_m),
            ("leading-edge span b_LE", scaled[1], bounds.leading_edge_span_m),
            ("root chord c_r", scaled[2], bounds.root_chord_m),
            ("tip chord c_t", scaled[3], bounds.tip_chord_m),
        ):
            require(f"{label} >= {low * 1e3:g} mm", variable >= low / s)
            require(f"{label} <= {high * 1e3:g} mm", variable <= high / s)
        require("tip chord c_t <= root chord c_r", scaled[3] <= scaled[2])
        require("leading-edge span b_LE <= span b", scaled[1] <= scaled[0])
        half_base = BASE_TAIL_SPAN_M / 2 / s
        setback = BASE_TAIL_CORNER_SETBACK_M / s
        require(
            "planform encloses the base tail (leading edge at y = 40 mm at most 10 mm aft)",
            setback * (scaled[0] - scaled[1]) / 2
            - (half_base - scaled[1] / 2) * (scaled[2] - scaled[3])
            >= 0,
        )
        require(
            f"area S >= {bounds.area_m2[0] * 1e4:g} cm^2",
            area / _AREA_SCALE_M2 >= bounds.area_m2[0] / _AREA_SCALE_M2,
        )
        require(
            f"area S <= {bounds.area_m2[1] * 1e4:g} cm^2",
            area / _AREA_SCALE_M2 <= bounds.area_m2[1] / _AREA_SCALE_M2,
        )
        require(
            f"aspect ratio AR >= {bounds.aspect_ratio[0]:g}", aspect_ratio >= bounds.aspect_ratio[0]
        )
        require(
            f"aspect ratio AR <= {bounds.aspect_ratio[1]:g}", aspect_ratio <= bounds.aspect_ratio[1]
        )
        require(
            "tail position x_h within the allowed range",
            opti.bounded(x_h_range[0], scaled[4], x_h_range[1]),
        )
        require(
            f"pitch mode oscillatory (zeta <= {MAX_OSCILLATORY_DAMPING})",
            zeta <= MAX_OSCILLATORY_DAMPING,
        )
        # Routh-Hurwitz on s^2 + a s + p shifted by the decay d: both poles have real part <= -d
        decay = bounds.real_pole_decay_1_s
        require(
            f"real poles decay faster than {decay:g} 1/s (a >= 2d)",
            (second_linear - 2 * decay) / _SECOND_FACTOR_SCALE >= 0,
        )
        require(
            f"real poles decay faster than {decay:g} 1/s (p - a d + d^2 >= 0)",
            (second_constant - second_linear * decay + decay * decay) / _SECOND_FACTOR_SCALE >= 0,
        )
        require("natural frequency positive", factor[1] >= 1e-3)

        if bounds.within_fitted_range:
            self._require_fitted_range(vector, require)

        target_expressions = [
            values["theta_ss_rad"],
            values["v_ss_m_s"],
            values.get("f_ss_hz", ca.MX(0.0)),
            robust_zeta,
            omega,
        ]
        target_constraints = []
        for index, (name, expression) in enumerate(
            zip(TARGET_NAMES, target_expressions, strict=True)
        ):
            unit = TARGET_SOFT_UNITS[index]
            relaxed = slack_enabled * slack[index]
            lower = expression / unit >= target_lower[index] - relaxed
            upper = expression / unit <= target_upper[index] + relaxed
            opti.subject_to(lower)
            opti.subject_to(upper)
            target_constraints.append((name, lower, upper))
        opti.subject_to(slack >= 0)

        opti.minimize(
            weights[0] * area / _AREA_SCALE_M2
            - weights[1] * robust_zeta
            + weights[2] * ca.sumsqr(slack)
        )
        opti.solver(
            "ipopt",
            {"print_time": False, "error_on_fail": False, "expand": True},
            {"print_level": 0, "sb": "yes", "max_iter": 300, "tol": 1e-9},
        )
        return _BuiltNlp(
            opti=opti,
            scaled=scaled,
            factor=factor,
            slack=slack,
            zeta=zeta,
            omega=omega,
            x_h_range=x_h_range,
            target_lower=target_lower,
            target_upper=target_upper,
            slack_enabled=slack_enabled,
            robust_k=robust_k,
            new_flight=new_flight,
            weights=weights,
            named_constraints=named,
            target_constraints=target_constraints,
        )

    def _require_fitted_range(self, vector: tuple[Any, ...], require: Any) -> None:
        """Keep every fitted feature (S, AR, b, x_h, ...) inside the range of each trend's data."""
        ranges: dict[str, list[float]] = {}
        expressions: dict[str, Any] = {}
        for trend in self.trend_model.trends.values():
            features = trend.basis.features(vector)
            varying = [index for index in trend.active_features if index != 0]
            for index, low, high in zip(varying, trend.feature_min, trend.feature_max, strict=True):
                name = trend.basis.feature_names[index]
                current = ranges.setdefault(name, [low, high])
                ranges[name] = [max(current[0], low), min(current[1], high)]
                expressions[name] = features[index]
        for name, (low, high) in ranges.items():
            scale = max(abs(low), abs(high), 1e-12)
            require(
                f"{name} >= {low:.4g} (fitted data range)", expressions[name] / scale >= low / scale
            )
            require(
                f"{name} <= {high:.4g} (fitted data range)",
                expressions[name] / scale <= high / scale,
            )

    def _reference_polynomial(self) -> list[float]:
        """Magnitudes of the characteristic-polynomial coefficients at a mid-range design, used to
        scale the four factor equalities to order one."""
        middle = np.array([0.20, 0.10, 0.065, 0.035, 0.098]) / _LENGTH_SCALE_M
        matrix = np.array(self._a_matrix_function(middle))
        return [max(abs(float(c)), 1.0) for c in characteristic_polynomial(matrix)]

    def _delta_method_sigma(
        self,
        values: dict,
        variance_mean: dict,
        residual_variance: dict,
        factor: Any,
        new_flight: Any,
    ) -> Any:
        names = list(A_MODEL_QUANTITIES)
        quantity_symbols = ca.SX.sym("v", len(names))
        factor_symbols = ca.SX.sym("y", 4)
        polynomial = ca.vertcat(
            *characteristic_polynomial(
                a_matrix_of_quantities(
                    {name: quantity_symbols[i] for i, name in enumerate(names)},
                    cos=ca.cos,
                    sin=ca.sin,
                )
            )
        )
        factor_polynomial = ca.vertcat(
            *quadratic_factor_coefficients(
                factor_symbols[0], factor_symbols[1], factor_symbols[2], factor_symbols[3]
            )
        )
        # implicit differentiation of F(y) = c(v): dy/dv = (dF/dy)^-1 dc/dv; zeta is row 0
        sensitivity = ca.solve(
            ca.jacobian(factor_polynomial, factor_symbols),
            ca.jacobian(polynomial, quantity_symbols),
        )[0, :]
        zeta_sensitivity = ca.Function(
            "dzeta_dv", [factor_symbols, quantity_symbols], [sensitivity]
        )
        y_value = ca.vertcat(
            factor[0],
            _OMEGA_SCALE * factor[1],
            _SECOND_FACTOR_SCALE * factor[2],
            _SECOND_FACTOR_SCALE * factor[3],
        )
        row = zeta_sensitivity(y_value, ca.vertcat(*[values[name] for name in names]))
        variance = 0
        for i, name in enumerate(names):
            if name not in variance_mean:
                continue  # mass and inertia from design/mass_model.py: no variance
            quantity_variance = variance_mean[name] + new_flight * residual_variance[name]
            variance = variance + row[i] ** 2 * quantity_variance
        return ca.sqrt(variance + 1e-14)

    # -- solving ----------------------------------------------------------------------------------
    def a_matrix_at(self, geometry_vector_m: np.ndarray) -> np.ndarray:
        """The A matrix the problem uses, evaluated at a geometry vector (m)."""
        return np.array(self._a_matrix_function(np.asarray(geometry_vector_m) / _LENGTH_SCALE_M))

    def _initial_factor(self, geometry_vector_m: np.ndarray) -> np.ndarray:
        modes = modal_summary(self.a_matrix_at(geometry_vector_m))
        if modes.oscillatory_eigenvalue is None or np.any(np.abs(modes.other_poles.imag) > 1e-9):
            return np.array([0.3, 5.0 / _OMEGA_SCALE, 1.6, 1.5])
        others = modes.other_poles.real
        zeta = min(modes.damping_ratio, MAX_OSCILLATORY_DAMPING - 0.01)
        return np.array(
            [
                zeta,
                modes.natural_frequency_rad_s / _OMEGA_SCALE,
                max(-(others[0] + others[1]), MIN_REAL_FACTOR * 2) / _SECOND_FACTOR_SCALE,
                max(others[0] * others[1], MIN_REAL_FACTOR * 2) / _SECOND_FACTOR_SCALE,
            ]
        )

    def solve_from(self, settings: SolveSettings, start_vector_m: np.ndarray) -> StartOutcome:
        """Run IPOPT once from ``start_vector_m`` (b, b_LE, c_r, c_t, x_h in metres)."""
        if settings.objective not in OBJECTIVES:
            raise UserInputError(
                "objective",
                f"unknown objective {settings.objective!r}; choose one of {', '.join(OBJECTIVES)}",
            )
        if settings.interval_kind not in INTERVAL_KINDS:
            raise UserInputError(
                "robust_interval",
                f"unknown interval {settings.interval_kind!r}; choose mean or new",
            )
        nlp = self._nlp_for(robust=settings.robust_k > 0)
        opti = nlp.opti
        lower, upper = [], []
        for band, unit in zip(settings.targets.bands(), TARGET_SOFT_UNITS, strict=True):
            lower.append(-_OPEN_BAND if band is None else band.lower / unit)
            upper.append(_OPEN_BAND if band is None else min(band.upper / unit, _OPEN_BAND))
        if settings.targets.f_ss_hz is not None and not self._has_frequency_trend:
            raise UserInputError(
                "f_ss_hz", "the trend data has no flapping-frequency trend (f_ss_hz)"
            )
        opti.set_value(nlp.target_lower, lower)
        opti.set_value(nlp.target_upper, upper)
        soft = settings.soft_targets or settings.objective == "closest"
        opti.set_value(nlp.slack_enabled, 1.0 if soft else 0.0)
        new_flight = 1.0 if settings.interval_kind == "new" else 0.0
        if nlp.robust_k is not None:
            opti.set_value(nlp.robust_k, settings.robust_k)
            opti.set_value(nlp.new_flight, new_flight)
        opti.set_value(nlp.x_h_range, np.array(settings.x_h_range_m) / _LENGTH_SCALE_M)
        weights = {
            "min-area": [1.0, 0.0, 1.0],  # slack weight 1: slacks are unused when hard, and
            "max-damping": [1e-3, 1.0, 1.0],  # curvature there keeps IPOPT's iterations few
            "closest": [1e-4, 0.0, 1.0],
        }[settings.objective]
        if soft and settings.objective != "closest":
            weights = [weights[0] * 1e-3, weights[1] * 1e-3, 1.0]
        opti.set_value(nlp.weights, weights)
        start = np.array(start_vector_m, dtype=float)
        start[4] = min(max(start[4], settings.x_h_range_m[0]), settings.x_h_range_m[1])
        opti.set_initial(nlp.scaled, start / _LENGTH_SCALE_M)
        opti.set_initial(nlp.factor, self._initial_factor(start))
        opti.set_initial(nlp.slack, np.zeros(5))
        self.solve_count += 1
        try:
            value = opti.solve().value
        except RuntimeError:  # IPOPT did not converge; Opti raises, the status says why
            value = opti.debug.value
        status = str(opti.stats()["return_status"])
        if status not in _CONVERGED:
            return _failed_outcome(status, np.array(value(nlp.scaled)).ravel() * _LENGTH_SCALE_M)
        slack = np.atleast_1d(value(nlp.slack))
        violations = {}
        for index, name in enumerate(TARGET_NAMES):
            if (
                settings.targets.bands()[index] is not None
                and slack[index] > _SLACK_TOLERANCE
                and soft
            ):
                violations[name] = float(slack[index] * TARGET_SOFT_UNITS[index])
        binding = []
        for name, constraint in nlp.named_constraints:
            if _dual_size(value(opti.dual(constraint))) > _BINDING_DUAL_TOLERANCE:
                binding.append(name)
        for name, lower_constraint, upper_constraint in nlp.target_constraints:
            for label, constraint in (("lower", lower_constraint), ("upper", upper_constraint)):
                if (
                    _dual_size(value(opti.dual(constraint))) > _BINDING_DUAL_TOLERANCE
                    and name not in violations
                ):
                    binding.append(f"target {name} ({label} bound)")
        scaled_value, factor_value = value(nlp.scaled), value(nlp.factor)
        return StartOutcome(
            geometry_vector_m=np.array(scaled_value).ravel() * _LENGTH_SCALE_M,
            damping_ratio=float(value(nlp.zeta)),
            natural_frequency_rad_s=float(value(nlp.omega)),
            sigma_damping_ratio=float(
                self._sigma_zeta_function(scaled_value, factor_value, new_flight)
            ),
            objective_value=float(value(opti.f)),
            target_violations=violations,
            binding_constraints=binding,
            status=status,
            converged=status in _CONVERGED,
        )


def sobol_start_points(
    bounds: DesignBounds, count: int, x_h_range_m: tuple[float, float], seed: int = 7
) -> np.ndarray:
    """``count`` low-discrepancy start vectors (b, b_LE, c_r, c_t, x_h) in metres.

    Sampled in (b, b_LE/b, c_r, c_t/c_r, x_h) so that every start respects b_LE <= b and c_t <= c_r.
    """
    sampler = qmc.Sobol(d=5, scramble=True, seed=seed)
    unit = sampler.random(2 ** max(0, math.ceil(math.log2(max(count, 1)))))[:count]
    low_span, high_span = bounds.span_m[0], min(bounds.span_m[1], 0.26)
    low_chord, high_chord = bounds.root_chord_m[0], min(bounds.root_chord_m[1], 0.09)
    span = low_span + unit[:, 0] * (high_span - low_span)
    leading = span * (0.35 + 0.6 * unit[:, 1])
    root = low_chord + unit[:, 2] * (high_chord - low_chord)
    tip = root * (0.3 + 0.6 * unit[:, 3])
    x_h = x_h_range_m[0] + unit[:, 4] * (x_h_range_m[1] - x_h_range_m[0])
    return np.column_stack([span, leading, root, tip, x_h])


def _objective_rank(outcome: StartOutcome) -> float:
    return outcome.objective_value


def best_of_starts(
    problem: ProposalProblem,
    settings: SolveSettings,
    starts: np.ndarray,
    agreeing_starts: int = AGREEING_STARTS,
) -> tuple[StartOutcome | None, int, int]:
    """Solve from the starts in order (sequentially: IPOPT is not thread-safe); return the best
    verified converged outcome, the number that converged and the number tried.

    Stops early once ``agreeing_starts`` verified starts have reached the best objective within
    ``_AGREEMENT_TOLERANCE`` (relative): further starts would only find it again. 0 runs them all.
    """
    best, converged, tried, agreeing = None, 0, 0, 0
    for start in starts:
        tried += 1
        outcome = problem.solve_from(settings, start)
        if not outcome.converged:
            continue
        outcome.verified = _verified_by_numpy(problem, outcome)
        if not outcome.verified:
            continue
        converged += 1
        if best is not None and _objectives_agree(outcome, best):
            agreeing += 1
            if _objective_rank(outcome) < _objective_rank(best):
                best = outcome
        elif best is None or _objective_rank(outcome) < _objective_rank(best):
            best, agreeing = outcome, 1
        if agreeing_starts and agreeing >= agreeing_starts:
            break
    return best, converged, tried


def _objectives_agree(first: StartOutcome, second: StartOutcome) -> bool:
    scale = max(abs(first.objective_value), abs(second.objective_value), 1.0)
    return abs(first.objective_value - second.objective_value) <= _AGREEMENT_TOLERANCE * scale


def _verified_by_numpy(problem: ProposalProblem, outcome: StartOutcome) -> bool:
    modes = modal_summary(problem.a_matrix_at(outcome.geometry_vector_m))
    if modes.oscillatory_eigenvalue is None:
        return False
    return (
        abs(modes.damping_ratio - outcome.damping_ratio) < _VERIFY_TOLERANCE
        and abs(modes.natural_frequency_rad_s - outcome.natural_frequency_rad_s)
        < _VERIFY_TOLERANCE * 10
    )


def geometry_of_vector(vector_m: np.ndarray) -> TailGeometry:
    """The TailGeometry of a solution vector (b, b_LE, c_r, c_t, x_h) in metres."""
    return TailGeometry(
        span_m=float(vector_m[0]),
        leading_edge_span_m=float(vector_m[1]),
        root_chord_m=float(vector_m[2]),
        tip_chord_m=float(vector_m[3]),
    )


def propose(
    trend_model: Any,
    targets: DesignTargets,
    objective: str = "min-area",
    robust_k: float = 0.0,
    interval_kind: str = "new",
    x_h_m: float | None = None,
    continuous_x_h: bool = False,
    start_count: int = 8,
    bounds: DesignBounds | None = None,
    mass_inertia: MassInertiaModel | None = None,
    problem: ProposalProblem | None = None,
) -> Proposal:
    """Propose a tail for ``targets``.

    Solves for each available fuselage (``FUSELAGE_X_H_M``), for the one ``x_h_m`` given, or for a
    continuous x_h within ``bounds.x_h_m``; ``start_count`` Sobol starts each. When no start meets
    the targets, the nearest achievable design is returned (minimum sum of squared target misses
    in ``TARGET_SOFT_UNITS``) with the unmet targets and the binding constraints named.
    """
    began = time.perf_counter()
    if robust_k < 0 or not math.isfinite(robust_k):
        raise UserInputError("robust_k", f"value {robust_k!r} must be a finite number >= 0")
    if not 1 <= start_count <= 256:
        raise UserInputError(
            "start_count", f"value {start_count!r} must be between 1 and {MAX_STARTS}"
        )
    problem = problem or ProposalProblem(trend_model, bounds, mass_inertia)
    bounds = problem.bounds
    if continuous_x_h:
        ranges = [bounds.x_h_m]
    elif x_h_m is not None:
        if not (math.isfinite(x_h_m) and bounds.x_h_m[0] - 1e-9 <= x_h_m <= bounds.x_h_m[1] + 1e-9):
            raise UserInputError(
                "x_h_mm",
                f"value {x_h_m * 1e3!r} mm is outside {bounds.x_h_m[0] * 1e3:g}-{bounds.x_h_m[1] * 1e3:g} mm",
            )
        ranges = [(x_h_m, x_h_m)]
    else:
        ranges = [(value, value) for value in sorted(FUSELAGE_X_H_M.values())]

    def run(soft: bool) -> tuple[StartOutcome | None, int, int, list[dict[str, Any]]]:
        best, converged_total, tried, per_position = None, 0, 0, []
        for x_h_range in ranges:
            settings = SolveSettings(targets, objective, robust_k, interval_kind, x_h_range, soft)
            starts = sobol_start_points(bounds, start_count, x_h_range)
            outcome, converged, tried_here = best_of_starts(problem, settings, starts)
            tried += tried_here
            converged_total += converged
            per_position.append(
                {
                    "x_h_m": x_h_range[0] if x_h_range[0] == x_h_range[1] else None,
                    "found": outcome is not None,
                    "objective": None if outcome is None else outcome.objective_value,
                    "area_m2": None if outcome is None else _area_of(outcome.geometry_vector_m),
                    "damping_ratio": None if outcome is None else outcome.damping_ratio,
                }
            )
            if outcome is not None and (
                best is None or outcome.objective_value < best.objective_value
            ):
                best = outcome
        return best, converged_total, tried, per_position

    best, converged, tried, per_position = run(soft=False)
    status = "targets met"
    if best is None or objective == "closest":
        if objective != "closest":
            soft_best, soft_converged, soft_tried, per_position = run(soft=True)
        else:
            soft_best, soft_converged, soft_tried = best, converged, 0
        converged, tried = converged + soft_converged, tried + soft_tried
        best = soft_best
        if best is None:
            raise UserInputError(
                "targets",
                f"none of {tried} IPOPT runs found a tail within the bounds with an oscillatory "
                "pitch mode and real poles decaying faster than "
                f"{bounds.real_pole_decay_1_s:g} 1/s under these trends (try more starts)",
            )
        status = (
            "targets met" if not best.target_violations else "nearest achievable (targets not met)"
        )
    vector = best.geometry_vector_m
    geometry = geometry_of_vector(vector)
    evaluation = evaluate_design(trend_model, geometry, float(vector[4]), problem.mass_inertia)
    return Proposal(
        geometry=geometry,
        x_h_m=float(vector[4]),
        objective=objective,
        targets=targets,
        evaluation=evaluation,
        damping_ratio_in_problem=best.damping_ratio,
        natural_frequency_in_problem_rad_s=best.natural_frequency_rad_s,
        sigma_damping_ratio_in_problem=best.sigma_damping_ratio,
        robust_k=robust_k,
        interval_kind=interval_kind,
        targets_met=not best.target_violations,
        unmet_targets=best.target_violations,
        binding_constraints=best.binding_constraints,
        solver_status=f"{status}; IPOPT {best.status}",
        starts_tried=tried,
        starts_converged=converged,
        per_position=per_position,
        solve_time_s=time.perf_counter() - began,
    )


def _failed_outcome(status: str, vector_m: np.ndarray) -> StartOutcome:
    return StartOutcome(vector_m, math.nan, math.nan, math.nan, math.inf, {}, [], status, False)


def _dual_size(dual: Any) -> float:
    return float(np.max(np.abs(np.atleast_1d(np.asarray(dual, dtype=float)))))


def _area_of(vector_m: np.ndarray) -> float:
    return geometry_of_vector(vector_m).area_m2
