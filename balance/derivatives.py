"""Stability derivatives of a configuration from all its tunnel sweep points together.

The clamped vehicle's cycle-averaged loads X, Z (N) and M (N m, positive nose-down) are fitted as

    L = L0 + Lu du + Lw dw + Lf df + (curvature along each sweep)

by generalised (weighted) least squares over every tailed measurement of the configuration, where ``du = u -
u0``, ``dw = w - w0`` are the body velocities relative to the steady state (``u = -V cos theta``, ``w = -V sin
theta``, docs/frames.md) and ``df = f - f0``. V and theta are those read during each record (the fan's velocity
and the strut's pitch, averaged over the record) where the run has them: the fan reaches a set velocity only
within the settle tolerance, and ``Zu`` times that offset is several of Z0's sigmas. The pitch sweep at constant
V turns the velocity vector (mostly ``dw``), the velocity sweep stretches it (mostly ``du``): together they
separate the u- and w-derivatives. The intercept L0 is the steady-state load.

Curvature: over a sweep of +-0.25 m/s the loads are visibly non-linear, and a straight line through the points
gives the chord, not the derivative at the steady state. When a sweep has k >= 2 distinct offsets, the powers
2..min(k, 3) of that sweep's own coordinate are fitted as nuisance terms: ``dV_along**p`` (velocity change along
the steady-state stream direction) for the velocity sweep, ``dV_across**p`` (across it) for the pitch sweep and
``df**p`` for the frequency sweep. With a symmetric sweep the even powers do not move the slopes; the cubes
remove the chord bias. Higher powers (up to ``max_sweep_order``, 4 by default, and the sweep's k) are added one
at a time, per load, where the lack-of-fit test asks for them: the chi-square falls by more than its 1 % point
for one degree of freedom (6.63). On the simulator M along the velocity sweep is not cubic at the resolution of
M; the quartic (even) leaves the slope alone and stops the intercept M0 from taking up the curvature.
``max_sweep_order=1`` gives the plain straight-line fit.

Weights: the points' covariance is the cycle scatter of each point (``se**2`` on the diagonal, pooled over the
records of a run at one flapping frequency: one record's estimate is rough, see
:mod:`ornitail.balance.point_covariance`) plus the noise of each wind-off tare, shared by every point corrected
with that tare (with bracketing tares a point's zero is a weighted sum of its run's tares from the run's drift
fit, and two points share each tare's error in proportion to their weights on it); the fit is generalised least
squares with that covariance ``C``.

Repeatability: records scatter more than their cycle scatter and tares say (slow flow unsteadiness, drift the
model does not follow: on the simulated rig about 1.2 of their sigmas). That record-to-record variance ``s**2``
(per load, the same for every record) is measured where the data can tell it from lack of fit: on the fit in
which every sweep has all the powers its offsets allow, whose residual degrees of freedom are the repeats (the
steady state and the returns to it) and the sweeps' spare offsets. ``s**2`` is the Paule-Mandel value, the one
that brings that fit's chi-square with ``C + s**2 I`` to its degrees of freedom (0 when it is already below).
Every fit of the load then uses ``C + s**2 I``, so the sigmas of each coefficient grow by what its own points'
repeatability adds, not by one factor for all. Should the chosen model still disagree with its points (chi-square
rejected at p = 0.01), all its sigmas are multiplied by ``sqrt(chi2_red)`` and the fit says so. With no repeats
and no spare offsets there is nothing to measure ``s`` on; the fit says so and uses ``C`` alone.

The clamped set-up holds pitch fixed during a record, so the pitch-rate derivatives Xq, Zq, Mq cannot be
measured in it; the result states this.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy.stats import chi2

from ornitail.balance.point_covariance import (
    generalised_least_squares,
    point_covariance,
    record_to_record_variance,
)
from ornitail.core.errors import UserInputError
from ornitail.core.units import quotient_unit

LOADS = (("X", "x_n", "N"), ("Z", "z_n", "N"), ("M", "m_n_m", "N m"))
"""Load symbol, its column in the cycle-averaged table, its unit."""
VARIABLES = (("u", "m/s"), ("w", "m/s"), ("f", "Hz"))
"""Variable symbol and unit the derivatives are taken with respect to."""
DERIVATIVE_NAMES = tuple(load + variable for load, _, _ in LOADS for variable, _ in VARIABLES)
NOT_MEASURABLE_CLAMPED = ("Xq", "Zq", "Mq")
NOT_MEASURABLE_STATEMENT = (
    "Xq, Zq and Mq (derivatives with respect to pitch rate q) cannot be measured on the clamped balance: the "
    "pitch is fixed during every record, so q = 0 throughout; take them from free flight."
)
FRAME_STATEMENT = (
    "study body frame (docs/frames.md): x_b aft in forward flight, z_b nose to tail, M nose-down"
)
REFERENCE_POINT_STATEMENT = (
    "the rig's tool-transform point (rig file [balance].tool_transform_mm_deg)"
)
BASE_SWEEP_ORDER = 3
"""Highest power of a sweep's coordinate always fitted (where the sweep has that many offsets)."""
LACK_OF_FIT_SIGNIFICANCE = 0.01
"""A higher power along a sweep is added, and a final fit's sigmas inflated, when the chi-square test rejects at
this p-value."""
_VARIABLE_COLUMNS = {"u": "du_m_s", "w": "dw_m_s", "f": "df_hz"}
_SWEEP_COORDINATES = {"velocity": "dV_along", "theta": "dV_across", "frequency": "df_hz"}


def derivative_unit(load: str, variable: str) -> str:
    """Unit of ``d load / d variable``: N/(m/s), N m/(m/s), N/Hz or N m/Hz."""
    load_unit = dict((symbol, unit) for symbol, _, unit in LOADS)[load]
    return quotient_unit(load_unit, dict(VARIABLES)[variable])


def body_velocities(theta_rad: np.ndarray | float, v_m_s: np.ndarray | float) -> tuple:
    """Body velocities ``u = -V cos theta`` and ``w = -V sin theta`` (m/s) in still-air steady flight."""
    theta = np.asarray(theta_rad, dtype=float)
    speed = np.asarray(v_m_s, dtype=float)
    return -speed * np.cos(theta), -speed * np.sin(theta)


@dataclass(frozen=True)
class SteadyState:
    """The steady state the derivatives are taken about: pitch (rad), speed (m/s), flapping frequency (Hz)."""

    theta_rad: float
    v_m_s: float
    f_hz: float

    @property
    def u_m_s(self) -> float:
        """Body velocity along x_b, m/s."""
        return float(-self.v_m_s * math.cos(self.theta_rad))

    @property
    def w_m_s(self) -> float:
        """Body velocity along z_b, m/s."""
        return float(-self.v_m_s * math.sin(self.theta_rad))


@dataclass(frozen=True)
class LoadFitDiagnostics:
    """How well one load's model fits.

    Attributes
    ----------
    residuals : numpy.ndarray
        Measured minus fitted load per point (N or N m).
    normalised_residuals : numpy.ndarray
        Residuals divided by the point's standard error (cycle scatter, tares and ``record_scatter``).
    leverage : numpy.ndarray
        Diagonal of the weighted hat matrix per point (0..1; sums to the number of coefficients).
    chi_square, degrees_of_freedom, reduced_chi_square : float, int, float
        Residual sum of squares weighted by the points' own covariance ``C`` (without the record-to-record
        variance), points minus coefficients, and their ratio (NaN without degrees of freedom).
    record_scatter : float
        Record-to-record standard deviation ``s`` added to every point (unit of the load, N or N m; 0 when the
        repeats agree with their errors, NaN when nothing could measure it).
    repeatability_degrees_of_freedom : int
        Residual degrees of freedom of the fit ``s`` was measured on (repeats and spare sweep offsets).
    standard_error_inflation : float
        ``sqrt(chi2_red)`` of the final fit (with ``C + s**2 I``) when its chi-square test rejects, else 1.
    """

    residuals: np.ndarray
    normalised_residuals: np.ndarray
    leverage: np.ndarray
    chi_square: float
    degrees_of_freedom: int
    reduced_chi_square: float
    record_scatter: float
    repeatability_degrees_of_freedom: int
    standard_error_inflation: float


@dataclass
class StabilityDerivatives:
    """Fitted stability derivatives of one configuration (tunnel, clamped), body frame.

    Fitted values are plain attributes: ``Xu, Xw, Xf, Zu, Zw, Zf, Mu, Mw, Mf`` (N/(m/s), N m/(m/s), N/Hz,
    N m/Hz; NaN when the sweeps cannot give them), ``X0, Z0, M0`` the steady-state loads (N, N m) and
    ``sigma`` the standard error of each by name (inflated where the fit says so).

    Attributes
    ----------
    configuration : str
        E.g. ``"S3 x_h=98mm"``.
    steady_state : SteadyState
        The point the derivatives are taken about.
    sigma : dict
        Standard error of every fitted value, by name.
    diagnostics : dict
        :class:`LoadFitDiagnostics` by load symbol ``"X"``, ``"Z"``, ``"M"``.
    points : pandas.DataFrame
        The fitted points: ``sweep``, ``theta_deg``, ``v_m_s``, ``f_set_hz`` (set values),
        ``theta_measured_deg``, ``v_measured_m_s`` (the conditions regressed on: read during the record, or the set
        values for runs without readings), ``du_m_s``, ``dw_m_s``, ``df_hz``.
    condition_number : float
        Condition number of the design's derivative columns (du, dw, df), each scaled to unit length.
    variance_inflation : dict
        Variance inflation factor of each estimable derivative column (1 = orthogonal to the others).
    nuisance_terms : dict
        Curvature terms fitted alongside, by load symbol (e.g. ``{"X": ["dV_along^2", ...]}``).
    variables : list of str
        The estimable variables among ``u``, ``w``, ``f``, in coefficient order.
    coefficients : dict
        Every fitted coefficient by load: intercept, derivatives (``variables`` order), then nuisance terms.
    not_estimable : dict
        Derivatives the sweeps cannot give (name -> reason), always including Xq, Zq, Mq.
    frame, reference_point : str
        Where the loads act and in which axes.
    """

    configuration: str
    steady_state: SteadyState
    sigma: dict[str, float]
    diagnostics: dict[str, LoadFitDiagnostics]
    points: pd.DataFrame
    condition_number: float
    variance_inflation: dict[str, float]
    nuisance_terms: dict[str, list[str]]
    not_estimable: dict[str, str]
    frame: str = FRAME_STATEMENT
    reference_point: str = REFERENCE_POINT_STATEMENT
    X0: float = math.nan
    Z0: float = math.nan
    M0: float = math.nan
    Xu: float = math.nan
    Xw: float = math.nan
    Xf: float = math.nan
    Zu: float = math.nan
    Zw: float = math.nan
    Zf: float = math.nan
    Mu: float = math.nan
    Mw: float = math.nan
    Mf: float = math.nan
    statements: list[str] = field(default_factory=list)
    variables: list[str] = field(default_factory=list)
    coefficients: dict[str, np.ndarray] = field(default_factory=dict)

    def predict(
        self, theta_deg: np.ndarray, v_m_s: np.ndarray, f_hz: np.ndarray, linear_only: bool = False
    ) -> dict[str, np.ndarray]:
        """Fitted X, Z (N) and M (N m) at set points; ``linear_only``: the tangent at the steady state."""
        theta, speed, frequency = np.broadcast_arrays(
            np.asarray(theta_deg, float), np.asarray(v_m_s, float), np.asarray(f_hz, float)
        )
        points = pd.DataFrame(
            {"theta_deg": theta.ravel(), "v_m_s": speed.ravel(), "f_set_hz": frequency.ravel()}
        )
        coordinates = _sweep_coordinates(points, self.steady_state)
        predicted = {}
        for load, coefficients in self.coefficients.items():
            terms = [] if linear_only else self.nuisance_terms[load]
            design = _design(coordinates, self.variables, terms)
            predicted[load] = design @ coefficients[: design.shape[1]]
        return predicted

    def table(self) -> pd.DataFrame:
        """One row per derivative (and steady-state load): value, sigma, unit, fit diagnostics."""
        rows = []
        for load, _, unit in LOADS:
            diagnostics = self.diagnostics[load]
            common = {
                "reduced_chi_square": diagnostics.reduced_chi_square,
                "degrees_of_freedom": diagnostics.degrees_of_freedom,
                "sigma_inflation": diagnostics.standard_error_inflation,
            }
            rows.append(
                {
                    "name": f"{load}0",
                    "value": getattr(self, f"{load}0"),
                    "sigma": self.sigma[f"{load}0"],
                    "unit": unit,
                    "with_respect_to": "steady state",
                    "variance_inflation": math.nan,
                    "resolution": "",
                    **common,
                }
            )
            for variable, _ in VARIABLES:
                name = load + variable
                rows.append(
                    {
                        "name": name,
                        "value": getattr(self, name),
                        "sigma": self.sigma.get(name, math.nan),
                        "unit": derivative_unit(load, variable),
                        "with_respect_to": variable,
                        "variance_inflation": self.variance_inflation.get(variable, math.nan),
                        "resolution": resolution_label(
                            getattr(self, name), self.sigma.get(name, math.nan)
                        ),
                        **common,
                    }
                )
        for name in NOT_MEASURABLE_CLAMPED:
            rows.append(
                {
                    "name": name,
                    "value": math.nan,
                    "sigma": math.nan,
                    "unit": derivative_unit(name[0], "w").replace("(m/s)", "(rad/s)"),
                    "with_respect_to": "q",
                    "variance_inflation": math.nan,
                    "resolution": "not measurable on the clamped balance",
                    "reduced_chi_square": math.nan,
                    "degrees_of_freedom": 0,
                    "sigma_inflation": math.nan,
                }
            )
        frame = pd.DataFrame(rows)
        frame.insert(0, "configuration", self.configuration)
        frame["frame"] = "study body frame"
        return frame

    def to_json_dict(self) -> dict[str, Any]:
        """Values, sigmas, units, steady state, diagnostics and statements, JSON-serialisable."""
        derivatives = {}
        for row in self.table().itertuples():
            derivatives[row.name] = {
                "value": row.value,
                "sigma": row.sigma,
                "unit": row.unit,
                **({"resolution": row.resolution} if row.resolution else {}),
            }
        return {
            "configuration": self.configuration,
            "frame": self.frame,
            "reference_point": self.reference_point,
            "steady_state": {
                "theta_deg": math.degrees(self.steady_state.theta_rad),
                "v_m_s": self.steady_state.v_m_s,
                "f_hz": self.steady_state.f_hz,
                "u_m_s": self.steady_state.u_m_s,
                "w_m_s": self.steady_state.w_m_s,
            },
            "derivatives": derivatives,
            "not_estimable": self.not_estimable,
            "nuisance_terms": self.nuisance_terms,
            "condition_number": self.condition_number,
            "variance_inflation": self.variance_inflation,
            "fit": {
                load: {
                    "reduced_chi_square": diagnostics.reduced_chi_square,
                    "degrees_of_freedom": diagnostics.degrees_of_freedom,
                    f"record_scatter_{unit_key}": diagnostics.record_scatter,
                    "repeatability_degrees_of_freedom": diagnostics.repeatability_degrees_of_freedom,
                    "sigma_inflation": diagnostics.standard_error_inflation,
                    "max_abs_normalised_residual": float(
                        np.max(np.abs(diagnostics.normalised_residuals))
                    ),
                    "max_leverage": float(np.max(diagnostics.leverage)),
                }
                for (load, diagnostics), unit_key in zip(
                    self.diagnostics.items(), ("n", "n", "n_m"), strict=True
                )
            },
            "repeatability_statement": _repeatability_statement(self),
            "statements": self.statements,
        }


def steady_state_of(points: pd.DataFrame) -> SteadyState:
    """The steady state of a configuration's points: the set values of its ``steady_state`` rows."""
    steady = points[points["sweep"] == "steady_state"]
    if steady.empty:
        raise UserInputError("sweep table", "no steady-state point among the tailed measurements")
    values = steady[["theta_deg", "v_m_s", "f_set_hz"]].round(9).drop_duplicates()
    if len(values) > 1:
        raise UserInputError("sweep table", "the steady-state points differ in their set values")
    theta_deg, v_m_s, f_hz = values.iloc[0]
    return SteadyState(math.radians(theta_deg), float(v_m_s), float(f_hz))


def measured_or_set(points: pd.DataFrame, measured: str, set_value: str) -> np.ndarray:
    """The column ``measured`` where the table has it and it is finite, else the set value ``set_value``."""
    values = points[set_value].to_numpy(dtype=float)
    if measured not in points:
        return values
    readings = points[measured].to_numpy(dtype=float)
    return np.where(np.isfinite(readings), readings, values)


def _sweep_coordinates(
    points: pd.DataFrame, steady: SteadyState, measured: bool = False
) -> pd.DataFrame:
    """Coordinates of the points about the steady state; ``measured``: at the pitch and velocity read during
    each record (``theta_measured_deg``, ``v_measured_m_s``) where the table has them, else at the set values."""
    theta_deg, v_m_s = (
        (
            measured_or_set(points, "theta_measured_deg", "theta_deg"),
            measured_or_set(points, "v_measured_m_s", "v_m_s"),
        )
        if measured
        else (points["theta_deg"].to_numpy(dtype=float), points["v_m_s"].to_numpy(dtype=float))
    )
    u, w = body_velocities(np.radians(theta_deg), v_m_s)
    du, dw = u - steady.u_m_s, w - steady.w_m_s
    # Unit vector of the steady-state stream in body axes is -(cos theta0, sin theta0).
    cos0, sin0 = math.cos(steady.theta_rad), math.sin(steady.theta_rad)
    return pd.DataFrame(
        {
            "du_m_s": du,
            "dw_m_s": dw,
            "df_hz": points["f_set_hz"].to_numpy() - steady.f_hz,
            "dV_along": -(du * cos0 + dw * sin0),
            "dV_across": du * sin0 - dw * cos0,
        },
        index=points.index,
    )


def _nuisance_terms(
    points: pd.DataFrame, coordinates: pd.DataFrame, lowest_power: int, highest_power: int
) -> list[str]:
    """Powers ``lowest_power..highest_power`` of each sweep's coordinate that its distinct offsets can fix."""
    terms = []
    for sweep, coordinate in _SWEEP_COORDINATES.items():
        offsets = coordinates.loc[points["sweep"] == sweep, coordinate].round(9).unique()
        top = min(len(offsets), highest_power)
        terms += [f"{coordinate}^{power}" for power in range(max(lowest_power, 2), top + 1)]
    return terms


def _design(
    coordinates: pd.DataFrame, variables: list[str], nuisance_terms: list[str]
) -> np.ndarray:
    """Columns: 1, the estimable derivative variables, then the nuisance powers."""
    columns = [np.ones(len(coordinates))]
    columns += [coordinates[_VARIABLE_COLUMNS[variable]].to_numpy() for variable in variables]
    for term in nuisance_terms:
        coordinate, power = term.split("^")
        columns.append(coordinates[coordinate].to_numpy() ** int(power))
    return np.column_stack(columns)


def _estimable_variables(coordinates: pd.DataFrame) -> tuple[list[str], dict[str, str]]:
    """Which of u, w, f the points' spread can separate, and why the others cannot be."""
    velocity = coordinates[["du_m_s", "dw_m_s"]].to_numpy()
    velocity_rank = np.linalg.matrix_rank(velocity, tol=1e-9) if len(velocity) else 0
    reasons = {}
    variables = []
    if velocity_rank == 2:
        variables += ["u", "w"]
    else:
        reason = (
            "the points do not vary the body velocity"
            if velocity_rank == 0
            else "the points vary the body velocity in one direction only; a pitch sweep and a velocity "
            "sweep together are needed to separate u and w"
        )
        reasons.update({"u": reason, "w": reason})
    if np.ptp(coordinates["df_hz"].to_numpy()) > 1e-9:
        variables.append("f")
    else:
        reasons["f"] = "the points do not vary the flapping frequency (no frequency sweep)"
    return variables, reasons


def _variance_inflation(design: np.ndarray, names: list[str]) -> dict[str, float]:
    if len(names) < 2:
        return {name: 1.0 for name in names}
    centred = design - design.mean(axis=0)
    correlation = np.corrcoef(centred, rowvar=False)
    return dict(zip(names, np.diag(np.linalg.inv(correlation)).tolist(), strict=True))


def _chosen_terms(
    coordinates: pd.DataFrame,
    variables: list[str],
    base_terms: list[str],
    extra_terms: list[str],
    values: np.ndarray,
    covariance: np.ndarray,
) -> list[str]:
    """The base curvature terms plus each extra power, in turn, whose addition lowers the chi-square by more
    than the 1 - :data:`LACK_OF_FIT_SIGNIFICANCE` point of chi-square on one degree of freedom."""
    threshold = float(chi2.isf(LACK_OF_FIT_SIGNIFICANCE, 1))
    terms = list(base_terms)
    current = generalised_least_squares(_design(coordinates, variables, terms), values, covariance)[
        3
    ]
    for term in extra_terms:
        design = _design(coordinates, variables, terms + [term])
        if design.shape[0] <= design.shape[1]:
            continue
        candidate = generalised_least_squares(design, values, covariance)[3]
        if current - candidate > threshold:
            terms.append(term)
            current = candidate
    return terms


def _with_record_variance(covariance: np.ndarray, record_variance: float) -> np.ndarray:
    """``covariance + record_variance I`` (``covariance`` alone when the variance could not be measured)."""
    if not math.isfinite(record_variance):
        return covariance
    return covariance + record_variance * np.eye(len(covariance))


def _weighted_fit(
    design: np.ndarray,
    values: np.ndarray,
    covariance: np.ndarray,
    record_variance: float,
    repeatability_degrees_of_freedom: int,
) -> tuple[np.ndarray, np.ndarray, LoadFitDiagnostics]:
    """GLS under ``covariance + record_variance I``: coefficients, their standard errors (inflated when the
    chi-square test still rejects) and diagnostics."""
    extended = _with_record_variance(covariance, record_variance)
    coefficients, normal_inverse, weighted_design, chi_square = generalised_least_squares(
        design, values, extended
    )
    residuals = values - design @ coefficients
    own_chi_square = float(residuals @ np.linalg.solve(covariance, residuals))
    degrees_of_freedom = len(values) - design.shape[1]
    inflation = 1.0
    if (
        degrees_of_freedom > 0
        and chi2.sf(chi_square, degrees_of_freedom) < LACK_OF_FIT_SIGNIFICANCE
    ):
        inflation = math.sqrt(chi_square / degrees_of_freedom)
    sigma = np.sqrt(np.diag(normal_inverse)) * inflation
    return (
        coefficients,
        sigma,
        LoadFitDiagnostics(
            residuals=residuals,
            normalised_residuals=residuals / np.sqrt(np.diag(extended)),
            leverage=np.einsum("ij,jk,ik->i", weighted_design, normal_inverse, weighted_design),
            chi_square=own_chi_square,
            degrees_of_freedom=degrees_of_freedom,
            reduced_chi_square=own_chi_square / degrees_of_freedom
            if degrees_of_freedom > 0
            else math.nan,
            record_scatter=math.sqrt(record_variance)
            if math.isfinite(record_variance)
            else math.nan,
            repeatability_degrees_of_freedom=repeatability_degrees_of_freedom,
            standard_error_inflation=inflation,
        ),
    )


def fit_stability_derivatives(
    table: pd.DataFrame, configuration: str | None = None, max_sweep_order: int = 4
) -> StabilityDerivatives:
    """Fit the u-, w- and f-derivatives of X, Z and M to the tailed points of one configuration.

    Parameters
    ----------
    table : pandas.DataFrame
        Cycle-averaged points as :func:`~ornitail.balance.sweep_table.cycle_averaged_table` makes them (needs
        ``sweep``, ``tailed``, ``theta_deg``, ``v_m_s``, ``f_set_hz``, ``x_n``, ``z_n``, ``m_n_m`` and their
        ``_se`` and ``_tare_se``, optionally ``tare_id``); only tailed rows are used. Points sharing a
        ``tare_id`` share that tare's error (generalised least squares with that covariance).
    configuration : str, optional
        Name for the output; default from the table's ``tail_id`` and ``x_h_mm``.
    max_sweep_order : int
        Highest power of a sweep's coordinate that may be fitted (1: straight lines; powers up to 3 always,
        higher ones where the lack-of-fit test asks; 4 by default, see module notes).

    Raises
    ------
    UserInputError
        If there are no tailed points, no steady state, a point error is not positive and finite, or fewer
        points than coefficients.
    """
    if max_sweep_order < 1:
        raise UserInputError("max_sweep_order", f"must be at least 1, got {max_sweep_order}")
    points = table[table["tailed"].astype(bool)].reset_index(drop=True)
    if points.empty:
        raise UserInputError("sweep table", "no tailed measurements to fit derivatives to")
    configuration = configuration or _configuration_name(points)
    steady = steady_state_of(points)
    # What the sweeps can separate follows from their set points; the fit regresses on the conditions read
    # during each record (the fan reaches a set velocity only within the settle tolerance and still creeps).
    set_coordinates = _sweep_coordinates(points, steady)
    variables, not_estimable = _estimable_variables(set_coordinates)
    base_order = min(max_sweep_order, BASE_SWEEP_ORDER)
    base_terms = _nuisance_terms(points, set_coordinates, 2, base_order)
    extra_terms = _nuisance_terms(points, set_coordinates, base_order + 1, max_sweep_order)
    coordinates = _sweep_coordinates(points, steady, measured=True)
    derivative_design = coordinates[[_VARIABLE_COLUMNS[v] for v in variables]].to_numpy()
    design = _design(coordinates, variables, base_terms)
    richest = _design(coordinates, variables, base_terms + extra_terms)
    if richest.shape[0] <= richest.shape[1]:
        # Every sweep with all its powers leaves no residual: the richest fit that leaves some measures s.
        richest = design
    if len(points) < design.shape[1]:
        raise UserInputError(
            "sweep table",
            f"{len(points)} tailed points cannot fix {design.shape[1]} coefficients; measure more points",
        )
    scaled = derivative_design / np.linalg.norm(derivative_design, axis=0)
    condition_number = float(np.linalg.cond(scaled)) if len(variables) else math.nan
    result = StabilityDerivatives(
        configuration=configuration,
        steady_state=steady,
        sigma={},
        diagnostics={},
        points=pd.concat(
            [
                points[["sweep", "theta_deg", "v_m_s", "f_set_hz"]].assign(
                    theta_measured_deg=measured_or_set(points, "theta_measured_deg", "theta_deg"),
                    v_measured_m_s=measured_or_set(points, "v_measured_m_s", "v_m_s"),
                ),
                coordinates,
            ],
            axis=1,
        ),
        condition_number=condition_number,
        variance_inflation=_variance_inflation(derivative_design, variables),
        nuisance_terms={},
        variables=variables,
        not_estimable={
            **{load + v: reason for v, reason in not_estimable.items() for load, _, _ in LOADS},
            **{name: NOT_MEASURABLE_STATEMENT for name in NOT_MEASURABLE_CLAMPED},
        },
    )
    for load, column, _ in LOADS:
        values = points[column].to_numpy(dtype=float)
        errors = points[f"{column}_se"].to_numpy(dtype=float)
        tare_errors = points[f"{column}_tare_se"].to_numpy(dtype=float)
        if not np.all(np.isfinite(values)) or not np.all(
            np.isfinite(errors) & (errors > 0) & np.isfinite(tare_errors) & (tare_errors >= 0)
        ):
            raise UserInputError(
                f"sweep table: {column}", "values and standard errors must be finite, errors > 0"
            )
        covariance = point_covariance(points, column, pool_cycle_scatter=True)
        record_variance = record_to_record_variance(richest, values, covariance)
        extended = _with_record_variance(covariance, record_variance)
        terms = _chosen_terms(coordinates, variables, base_terms, extra_terms, values, extended)
        coefficients, sigma, diagnostics = _weighted_fit(
            _design(coordinates, variables, terms),
            values,
            covariance,
            record_variance,
            richest.shape[0] - richest.shape[1],
        )
        result.nuisance_terms[load] = terms
        result.diagnostics[load] = diagnostics
        result.coefficients[load] = coefficients
        names = [f"{load}0"] + [load + variable for variable in variables]
        for index, name in enumerate(names):
            setattr(result, name, float(coefficients[index]))
            result.sigma[name] = float(sigma[index])
    result.statements = _statements(result)
    return result


def _configuration_name(points: pd.DataFrame) -> str:
    if "tail_id" not in points or "x_h_mm" not in points:
        return "unnamed configuration"
    tail = str(points["tail_id"].iloc[0])
    return f"{tail} x_h={float(points['x_h_mm'].iloc[0]):.0f}mm"


RESOLVED = "resolved from zero (2 sigma)"
INCLUDES_ZERO = "2-sigma interval includes zero"
BELOW_SIGMA = "smaller than its sigma"


def resolution_label(value: float, sigma: float) -> str:
    """Whether a derivative is told apart from zero: :data:`RESOLVED` beyond 2 sigma, :data:`INCLUDES_ZERO`
    within, :data:`BELOW_SIGMA` within 1 sigma; ``"not estimated"`` without a value."""
    if not (math.isfinite(value) and math.isfinite(sigma)):
        return "not estimated"
    if abs(value) < sigma:
        return BELOW_SIGMA
    return INCLUDES_ZERO if abs(value) <= 2.0 * sigma else RESOLVED


def _statements(result: StabilityDerivatives) -> list[str]:
    lines = [
        f"Derivatives of {result.configuration}, {result.frame}, about {result.reference_point}, at "
        f"theta0 = {math.degrees(result.steady_state.theta_rad):.2f} deg, V0 = {result.steady_state.v_m_s:.3f} "
        f"m/s, f0 = {result.steady_state.f_hz:.2f} Hz (u0 = {result.steady_state.u_m_s:+.3f} m/s, "
        f"w0 = {result.steady_state.w_m_s:+.3f} m/s).",
        NOT_MEASURABLE_STATEMENT,
    ]
    lines.append(_repeatability_statement(result))
    for load, diagnostics in result.diagnostics.items():
        if diagnostics.standard_error_inflation > 1.0:
            lines.append(
                f"{load}: the model still disagrees with its points beyond their errors and the records' "
                f"scatter (chi-square test p < {LACK_OF_FIT_SIGNIFICANCE:g} on {diagnostics.degrees_of_freedom} "
                f"degrees of freedom); sigmas inflated by sqrt(chi2_red) = "
                f"{diagnostics.standard_error_inflation:.2f}."
            )
    unresolved = {
        name: resolution_label(getattr(result, name), result.sigma[name])
        for load, _, _ in LOADS
        for name in (load + variable for variable in result.variables)
        if name in result.sigma
    }
    unresolved = {name: label for name, label in unresolved.items() if label != RESOLVED}
    if unresolved:
        lines.append(
            "Not resolved from zero: "
            + ", ".join(f"{name} ({label})" for name, label in unresolved.items())
            + "; their sign is not established by these sweeps."
        )
    estimable_missing = sorted(
        {name for name in result.not_estimable if name not in NOT_MEASURABLE_CLAMPED}
    )
    if estimable_missing:
        reasons = sorted({result.not_estimable[name] for name in estimable_missing})
        lines.append(
            f"Not estimable from these sweeps: {', '.join(estimable_missing)} ({'; '.join(reasons)})."
        )
    high_vif = {name: value for name, value in result.variance_inflation.items() if value > 10}
    if high_vif:
        lines.append(
            "Collinear sweep design: variance inflation "
            + ", ".join(f"{name} {value:.0f}" for name, value in high_vif.items())
            + " (> 10): the sweeps barely separate these variables."
        )
    common_terms = [
        term
        for term in next(iter(result.nuisance_terms.values()), [])
        if all(term in terms for terms in result.nuisance_terms.values())
    ]
    added = {
        load: [term for term in terms if term not in common_terms]
        for load, terms in result.nuisance_terms.items()
    }
    if any(result.nuisance_terms.values()):
        lines.append(
            "Curvature along the sweeps fitted as nuisance terms ("
            + ", ".join(common_terms)
            + "".join(f"; {load} also {', '.join(terms)}" for load, terms in added.items() if terms)
            + "), so the derivatives are local slopes at the steady state, not chords"
            + (
                " (powers above 3 added where the lack-of-fit test asked)."
                if any(added.values())
                else "."
            )
        )
    return lines


def _repeatability_statement(result: StabilityDerivatives) -> str:
    """One sentence: the record-to-record scatter each load's fit measured and added to every point."""
    degrees = {d.repeatability_degrees_of_freedom for d in result.diagnostics.values()}
    if not all(math.isfinite(d.record_scatter) for d in result.diagnostics.values()):
        return (
            "Derivative fit: the records' scatter beyond their errors is not measured (no repeated set points and "
            "no spare sweep offsets); sigmas come from the points' cycle scatter and tares alone."
        )
    parts = []
    for (load, _, unit), diagnostics in zip(LOADS, result.diagnostics.values(), strict=True):
        scatter = diagnostics.record_scatter
        parts.append(f"{load} {scatter:.2g} {unit}" if scatter > 0 else f"{load} none")
    return (
        "Derivative fit: the records scatter beyond their cycle scatter and tares by "
        + ", ".join(parts)
        + f" (1 sigma, measured on the {max(degrees)} residual degrees of freedom of the steady state's repeats "
        "and spare sweep offsets), added to every point's error."
    )
