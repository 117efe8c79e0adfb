"""An independent reality for the gap diagnosis: flight logs of a different flapping vehicle.

Nothing here imports or shares model structure with ``ornitail.sim``: a nonlinear longitudinal
rigid-body model of its own ("flapper B", 28 g, a larger tail plate further aft than the DelFly's)
with its own quasi-steady aerodynamics, integrated with ``scipy.integrate.solve_ivp``. It writes
the documented flight-log CSV (docs/flight-campaign.md, "Flight-log columns") and its own
linearisation about trim as a ``linear_model`` baseline file (docs/model-files.md), so a diagnosis
sees it exactly as it would see a real vehicle with a model identified or derived elsewhere.

Frame and equations (docs/frames.md, the documented interface of the logs): body axes x_b
(perpendicular to the fuselage, aft in forward flight) and z_b (along the fuselage towards the
tail); u, w (m/s) body velocities, q (rad/s) pitch rate (positive nose-down), theta (rad) the
fuselage's tilt forward from the vertical;

    m (du/dt + q w) = X - m g sin(theta),  m (dw/dt - q u) = Z + m g cos(theta),
    I dq/dt = M,  dtheta/dt = q,  d delta/dt = (delta_cmd - delta) / tau_servo.

Forces (N) and moments (N m, about the CG, M = z F_x - x F_z for a force at (x, z)):

- thrust along -z_b at the CG: T = c_T f^2 - c_a f (-w_air) (the axial inflow unloads the wings);
- flapping counter-force at the wings (z_w): -c_x f u_w along x_b and -c_z f w_air along z_b,
  u_w = u_air + q z_w (it damps the motion perpendicular to the stroke plane);
- quasi-steady wing lift and drag at z_w: the flow's angle to the fuselage
  alpha = atan2(-u_w, -w_air), effective angle alpha - alpha_0; lift coefficient C_La alpha_e
  blended (sigmoid at +-alpha_stall) into the flat plate's 2 sin(alpha_e) cos(alpha_e) (stall);
  drag polar C_D0 + k C_L^2; lift perpendicular to the flow, drag against it;
- a flat tail plate at z_t along the fuselage in the wings' induced flow v_i = sqrt(T / (2 rho
  A_stroke)) (momentum theory): flow angle atan2(-(u_air + q z_t), v_i - w_air) plus the elevator
  delta; low-aspect-ratio plate normal force C_N = (pi AR / 2) sin a cos a + 2 sin a |sin a|
  along x_b;
- gusts: horizontal and vertical wind (Ornstein-Uhlenbeck, world frame) enter the air-relative
  velocities (u_air, w_air); the log holds the inertial body velocities.

Effects (the ``effect`` of a :class:`RealityCase`, magnitude ``k``):

| effect | how | k | in the diagnosis' library? |
|---|---|---|---|
| ``none`` | - | - | - |
| ``input_delay`` | logged ``elevator_rad`` leads the deflection: delta(t + k) | s | yes |
| ``input_filter`` | logged ``elevator_rad``: the deflection through a 1st-order low-pass | s | yes |
| ``added_mass`` | apparent pitch inertia of wings and plate: I = I_rigid (1 + k) | fraction | yes (``iyy_shift``) |
| ``static_stability`` | wing forces' line moves aft by k: M += k F_x,wings (normal force) | m | no |
| ``frequency_sag`` | the flapping frequency sags with pitch rate: f = f0 (1 - k abs(q)) | s/rad | no |

``python benchmarks/independent_reality.py OUT`` writes one case of each effect into OUT.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from ornitail.gap.withheld_effects import first_order_lowpass

G = 9.80665  # m/s^2
RHO = 1.225  # kg/m^3
LOG_RATE_HZ = 200.0
PERIOD_S = 6.0  # one manoeuvre: run-in, doublet, free response, then a rudder blip ends it
INPUT_AT_S = 1.0  # doublet onset within the period
DOUBLET_HALF_S = 0.33
DOUBLET_FRACTION = 0.3  # of the elevator limit
RUDDER_AT_S = 5.9
MANOEUVRES = 16
EFFECTS = ("none", "input_delay", "input_filter", "added_mass", "static_stability", "frequency_sag")
IN_LIBRARY = {
    "input_delay": "input_delay",
    "input_filter": "input_filter",
    "added_mass": "iyy_shift",
}
UNITS = {
    "Mq": "N m s/rad",
    "Mu": "N s",
    "Mw": "N s",
    "Xq": "N s/rad",
    "Xu": "N s/m",
    "Xw": "N s/m",
    "Zq": "N s/rad",
    "Zu": "N s/m",
    "Zw": "N s/m",
    "Mde": "N m/rad",
    "Xde": "N/rad",
    "Zde": "N/rad",
}
MAGNITUDE_RANGES = {
    "input_delay": (0.04, 0.10),
    "input_filter": (0.04, 0.10),
    "added_mass": (0.3, 0.8),
    "static_stability": (0.006, 0.012),
    "frequency_sag": (0.15, 0.3),
}


@dataclass(frozen=True)
class Vehicle:
    """Flapper B: mass (kg), rigid pitch inertia (kg m^2), geometry (m, m^2) and aerodynamic
    coefficients (SI) of the module docstring."""

    mass_kg: float = 0.028
    iyy_kg_m2: float = 1.8e-4
    frequency_hz: float = 12.0
    thrust_per_hz2: float = 2.5e-3  # c_T, N/Hz^2
    inflow_per_hz: float = 2.0e-3  # c_a, N s/m/Hz
    counter_force_x: float = 0.020  # c_x, N s/m/Hz
    counter_force_z: float = 0.003  # c_z, N s/m/Hz
    wing_z_m: float = -0.035  # wings' force line (towards the nose)
    wing_area_m2: float = 0.030
    stroke_area_m2: float = 0.05
    alpha_0_rad: float = 1.0
    lift_slope: float = 3.0  # 1/rad
    stall_rad: float = 0.35
    stall_width_rad: float = 0.08
    drag_zero: float = 0.4
    drag_factor: float = 0.15
    tail_z_m: float = 0.14
    tail_area_m2: float = 0.009
    tail_aspect_ratio: float = 1.5
    elevator_limit_rad: float = 0.3
    servo_s: float = 0.02
    gust_sigma_m_s: float = 0.04
    gust_time_s: float = 0.6
    noise_q_rad_s: float = 0.01
    noise_velocity_m_s: float = 0.008
    noise_theta_rad: float = 0.003
    noise_elevator_rad: float = 0.002


@dataclass(frozen=True)
class RealityCase:
    """One flight of flapper B with ``effect`` of ``magnitude`` (module table), ``seed`` for the
    gusts and the sensor noise."""

    effect: str = "none"
    magnitude: float = 0.0
    seed: int = 0
    manoeuvres: int = MANOEUVRES


def _wing_lift(alpha_e: np.ndarray | float, vehicle: Vehicle) -> np.ndarray | float:
    blend = 1.0 / (1.0 + np.exp(-(np.abs(alpha_e) - vehicle.stall_rad) / vehicle.stall_width_rad))
    plate = 2.0 * np.sin(alpha_e) * np.cos(alpha_e)
    return (1.0 - blend) * vehicle.lift_slope * alpha_e + blend * plate


def _loads(
    state, elevator, wind, vehicle: Vehicle, case: RealityCase
) -> tuple[float, float, float]:
    """X, Z (N) and M (N m) on flapper B; ``state`` = (u, w, q, theta), ``wind`` = body-axis air
    velocity (m/s)."""
    u, w, q, _ = state
    u_air, w_air = u - wind[0], w - wind[1]
    frequency = vehicle.frequency_hz
    if case.effect == "frequency_sag":
        frequency *= 1.0 - case.magnitude * abs(q)
    thrust = vehicle.thrust_per_hz2 * frequency**2 - vehicle.inflow_per_hz * frequency * (-w_air)
    u_wing = u_air + q * vehicle.wing_z_m
    wing_x = -vehicle.counter_force_x * frequency * u_wing
    wing_z = -vehicle.counter_force_z * frequency * w_air
    speed = math.hypot(u_wing, w_air)
    if speed > 1e-6:
        alpha_e = math.atan2(-u_wing, -w_air) - vehicle.alpha_0_rad
        lift = _wing_lift(alpha_e, vehicle)
        drag = vehicle.drag_zero + vehicle.drag_factor * lift**2
        pressure = 0.5 * RHO * speed**2 * vehicle.wing_area_m2
        along = np.array([u_wing, w_air]) / speed  # direction of motion through the air
        normal = np.array([-along[1], along[0]])  # lift: the motion turned by +90 deg
        force = pressure * (lift * normal - drag * along)
        wing_x += force[0]
        wing_z += force[1]
    induced = math.sqrt(max(thrust, 0.0) / (2.0 * RHO * vehicle.stroke_area_m2))
    flow_x, flow_z = -(u_air + q * vehicle.tail_z_m), induced - w_air
    angle = math.atan2(flow_x, flow_z) + elevator
    aspect = vehicle.tail_aspect_ratio
    normal_coefficient = (math.pi * aspect / 2) * math.sin(angle) * math.cos(angle) + 2.0 * (
        math.sin(angle) * abs(math.sin(angle))
    )
    tail_x = 0.5 * RHO * (flow_x**2 + flow_z**2) * vehicle.tail_area_m2 * normal_coefficient
    moment = vehicle.wing_z_m * wing_x + vehicle.tail_z_m * tail_x
    if case.effect == "static_stability":
        moment += case.magnitude * wing_x
    return wing_x + tail_x, wing_z - thrust, moment


def _inertia(vehicle: Vehicle, case: RealityCase) -> float:
    extra = case.magnitude if case.effect == "added_mass" else 0.0
    return vehicle.iyy_kg_m2 * (1.0 + extra)


def _rates(state, elevator, wind, vehicle: Vehicle, case: RealityCase) -> np.ndarray:
    """d/dt (u, w, q, theta) (frames.md rigid-body equations)."""
    u, w, q, theta = state
    x_force, z_force, moment = _loads(state, elevator, wind, vehicle, case)
    mass = vehicle.mass_kg
    return np.array(
        [
            x_force / mass - G * math.sin(theta) - q * w,
            z_force / mass + G * math.cos(theta) + q * u,
            moment / _inertia(vehicle, case),
            q,
        ]
    )


@dataclass(frozen=True)
class Trim:
    """Steady level flight at zero elevator: body velocities (m/s) and pitch (rad)."""

    u_m_s: float
    w_m_s: float
    theta_rad: float


def trim(vehicle: Vehicle = Vehicle()) -> Trim:
    """Zero X, Z, M at q = 0, zero elevator and still air (the vehicle's own effect-free trim)."""
    plain = RealityCase()

    def residual(x: np.ndarray) -> np.ndarray:
        rates = _rates((x[0], x[1], 0.0, x[2]), 0.0, (0.0, 0.0), vehicle, plain)
        return rates[:3] * np.array([1.0, 1.0, 1e-2])

    solution = least_squares(residual, x0=[-0.7, -0.3, 0.4], xtol=1e-14, ftol=1e-14)
    if np.max(np.abs(solution.fun)) > 1e-9:
        raise RuntimeError(f"flapper B does not trim: residual {solution.fun}")
    return Trim(*map(float, solution.x))


def linearisation(vehicle: Vehicle = Vehicle()) -> tuple[np.ndarray, np.ndarray, Trim]:
    """A (4 x 4) and B (4 x 1) about :func:`trim` in states (q, u, w, theta) and the elevator
    deflection (rad), by central differences of the effect-free equations."""
    steady = trim(vehicle)
    plain = RealityCase()
    base = np.array([steady.u_m_s, steady.w_m_s, 0.0, steady.theta_rad])
    order = [2, 0, 1, 3]  # (u, w, q, theta) -> (q, u, w, theta)

    def f(state_qu: np.ndarray, elevator: float) -> np.ndarray:
        state = np.empty(4)
        state[order] = state_qu
        return _rates(state, elevator, (0.0, 0.0), vehicle, plain)[order]

    point = base[order]
    a_matrix = np.zeros((4, 4))
    for column in range(4):
        step = np.zeros(4)
        step[column] = 1e-6
        a_matrix[:, column] = (f(point + step, 0.0) - f(point - step, 0.0)) / 2e-6
    b_matrix = ((f(point, 1e-6) - f(point, -1e-6)) / 2e-6)[:, None]
    return a_matrix, b_matrix, steady


def _gusts(count: int, step_s: float, vehicle: Vehicle, generator) -> np.ndarray:
    """Horizontal and vertical wind (count, 2; m/s, world frame), Ornstein-Uhlenbeck."""
    decay = math.exp(-step_s / vehicle.gust_time_s)
    drive = vehicle.gust_sigma_m_s * math.sqrt(1.0 - decay**2)
    wind = np.zeros((count, 2))
    for index in range(1, count):
        wind[index] = decay * wind[index - 1] + drive * generator.standard_normal(2)
    return wind


def _command(time_s: np.ndarray, manoeuvres: int) -> tuple[np.ndarray, np.ndarray]:
    """elevator_cmd (fraction) and rudder_cmd (-1, 0, 1) of the doublet programme."""
    phase = np.mod(time_s - 1.0, PERIOD_S)
    inside = (time_s >= 1.0) & (time_s < 1.0 + manoeuvres * PERIOD_S)
    first = (phase >= INPUT_AT_S) & (phase < INPUT_AT_S + DOUBLET_HALF_S)
    second = (phase >= INPUT_AT_S + DOUBLET_HALF_S) & (phase < INPUT_AT_S + 2 * DOUBLET_HALF_S)
    elevator = DOUBLET_FRACTION * (first.astype(float) - second.astype(float)) * inside
    rudder = ((phase >= RUDDER_AT_S) & (phase < RUDDER_AT_S + 0.05) & inside).astype(float)
    return elevator, rudder


def fly(case: RealityCase, vehicle: Vehicle = Vehicle()) -> pd.DataFrame:
    """The flight log of ``case`` (docs/flight-campaign.md columns, absolute values)."""
    generator = np.random.default_rng([case.seed, 2026])
    step_s = 1.0 / LOG_RATE_HZ
    duration_s = 1.0 + case.manoeuvres * PERIOD_S + 0.5
    time_s = np.arange(int(round(duration_s / step_s))) * step_s
    command, rudder = _command(time_s, case.manoeuvres)
    wind_world = _gusts(len(time_s), step_s, vehicle, generator)
    steady = trim(vehicle)
    target = command * vehicle.elevator_limit_rad

    def rates(t: float, y: np.ndarray) -> np.ndarray:
        index = min(int(t / step_s), len(time_s) - 1)
        theta = y[3]
        horizontal, vertical = wind_world[index]  # world: horizontal forward, vertical down
        # world (forward, down) to body (x_b, z_b): forward = -cos(theta) x_b - sin(theta) z_b,
        # down = -sin(theta) x_b + cos(theta) z_b
        wind = (
            -math.cos(theta) * horizontal - math.sin(theta) * vertical,
            -math.sin(theta) * horizontal + math.cos(theta) * vertical,
        )
        motion = _rates(y[:4], y[4], wind, vehicle, case)
        return np.append(motion, (target[index] - y[4]) / vehicle.servo_s)

    start = [steady.u_m_s, steady.w_m_s, 0.0, steady.theta_rad, 0.0]
    solution = solve_ivp(rates, (0.0, time_s[-1]), start, t_eval=time_s, max_step=step_s, rtol=1e-6)
    if not solution.success:
        raise RuntimeError(f"flapper B: integration failed: {solution.message}")
    u, w, q, theta, elevator = solution.y
    logged = elevator.copy()
    if case.effect == "input_delay":
        logged = np.interp(time_s + case.magnitude, time_s, elevator)
    elif case.effect == "input_filter":
        logged = first_order_lowpass(elevator, step_s, case.magnitude)

    def noisy(values: np.ndarray, sigma: float) -> np.ndarray:
        return values + sigma * generator.standard_normal(len(values))

    return pd.DataFrame(
        {
            "time_s": time_s,
            "q_rad_s": noisy(q, vehicle.noise_q_rad_s),
            "u_m_s": noisy(u, vehicle.noise_velocity_m_s),
            "w_m_s": noisy(w, vehicle.noise_velocity_m_s),
            "theta_rad": noisy(theta, vehicle.noise_theta_rad),
            "elevator_cmd": command,
            "elevator_rad": noisy(logged, vehicle.noise_elevator_rad),
            "rudder_cmd": rudder,
        }
    )


def write_model_file(path: Path, vehicle: Vehicle = Vehicle()) -> Path:
    """Flapper B's effect-free linearisation as a model file of docs/model-files.md, in the
    structure of the DelFly's (dimensional derivatives as parameters; m, Iyy, g and the trim as
    constants), so the diagnosis can act on its Mq and Iyy."""
    a, b, steady = linearisation(vehicle)
    m, inertia = vehicle.mass_kg, vehicle.iyy_kg_m2
    u0, w0 = steady.u_m_s, steady.w_m_s
    derivatives = {
        "Mq": a[0, 0] * inertia,
        "Mu": a[0, 1] * inertia,
        "Mw": a[0, 2] * inertia,
        "Xq": (a[1, 0] + w0) * m,
        "Xu": a[1, 1] * m,
        "Xw": a[1, 2] * m,
        "Zq": (a[2, 0] - u0) * m,
        "Zu": a[2, 1] * m,
        "Zw": a[2, 2] * m,
        "Mde": b[0, 0] * inertia,
        "Xde": b[1, 0] * m,
        "Zde": b[2, 0] * m,
    }
    lines = [
        "# Flapper B (benchmarks/independent_reality.py) linearised about its trim; frame docs/frames.md.",
        "[model]",
        'name = "flapper_b_longitudinal"',
        'description = "independent reality: flapper B, states q u w theta, input elevator"',
        'states = ["q", "u", "w", "theta"]',
        'inputs = ["elevator"]',
        'outputs = ["q", "u", "w", "theta"]',
        'initial_state = "estimate"',
        "",
        "[constants]",
        f"m = {m!r}",
        f"Iyy = {inertia!r}",
        f"g = {G!r}",
        f"theta0 = {steady.theta_rad!r}",
        f"u0 = {u0!r}",
        f"w0 = {w0!r}",
        "",
        "[parameters]",
        *(
            f'{name} = {{ start = {float(value)!r}, unit = "{UNITS[name]}" }}'
            for name, value in derivatives.items()
        ),
        "",
        "[matrices]",
        "A = [",
        '  ["Mq/Iyy", "Mu/Iyy", "Mw/Iyy", 0],',
        '  ["Xq/m - w0", "Xu/m", "Xw/m", "-g*cos(theta0)"],',
        '  ["Zq/m + u0", "Zu/m", "Zw/m", "-g*sin(theta0)"],',
        "  [1, 0, 0, 0],",
        "]",
        'B = [["Mde/Iyy"], ["Xde/m"], ["Zde/m"], [0]]',
        'C = "identity"',
        "",
        "[data]",
        'time_column = "time_s"',
        "",
        "[columns]",
        *(
            f'{state} = {{ column = "{column}", remove_start_mean_s = 0.4 }}'
            for state, column in (
                ("q", "q_rad_s"),
                ("u", "u_m_s"),
                ("w", "w_m_s"),
                ("theta", "theta_rad"),
                ("elevator", "elevator_rad"),
            )
        ),
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_case(case: RealityCase, folder: Path) -> tuple[Path, Path]:
    """The log of ``case`` and the baseline file naming flapper B's linearisation, in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    log_path = folder / "flight.csv"
    fly(case).to_csv(log_path, index=False, float_format="%.9g")
    write_model_file(folder / "flapper_b.toml")
    baseline = folder / "baseline.toml"
    baseline.write_text('[baseline]\nkind = "linear_model"\nmodel = "flapper_b.toml"\n')
    return log_path, baseline


def draw_case(index: int, seed: int) -> RealityCase:
    """The ``index``-th case of a benchmark seeded with ``seed``: effects in the order of
    :data:`EFFECTS`, magnitudes drawn from :data:`MAGNITUDE_RANGES`."""
    generator = np.random.default_rng([seed, index, 7])
    effect = EFFECTS[index % len(EFFECTS)]
    low, high = MAGNITUDE_RANGES.get(effect, (0.0, 0.0))
    return RealityCase(effect, float(generator.uniform(low, high)), int(generator.integers(2**31)))


def main(argv: list[str] | None = None) -> int:
    """Write one case of every effect (at the middle of its range) under the folder given."""
    parser = argparse.ArgumentParser(
        description="write one flapper B flight of each effect, with its model and baseline files"
    )
    parser.add_argument("out", nargs="?", default="independent-reality", help="folder to write")
    out = Path(parser.parse_args(argv).out)
    for number, name in enumerate(EFFECTS):
        low, high = MAGNITUDE_RANGES.get(name, (0.0, 0.0))
        written = write_case(RealityCase(name, 0.5 * (low + high), seed=number), out / name)
        print(name, *written)
    return 0


if __name__ == "__main__":
    sys.exit(main())
