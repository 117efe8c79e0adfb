"""Example data for the worked examples: a flight log or a tunnel sweep table with withheld
effects, and the baseline model file that lacks them (``ornitail gap example``).

Flight: :mod:`ornitail.gap.withheld_effects` (the benchmark's generator). Tunnel: a sweep in the
layout of ``cycle-averages.csv`` (docs/processed-tables.md, tailed rows) at x_h = 57, 98 and
126 mm (pitch 0-40 deg at 0.8 m/s and 13.5 Hz; velocity 0.4-1.2 m/s and frequency 11-15 Hz at
25 deg), loads from :func:`ornitail.sim.tunnel.true_cycle_average` with the withheld effects on,
plus Gaussian scatter of :data:`TUNNEL_NOISE` (standard error of a cycle average with its tare).
Steady: a table of steady states (``tail, x_h_mm, theta_ss_deg, v_ss_m_s, f_ss_hz`` and their
``*_sigma``) at :data:`STEADY_CONFIGURATIONS`, the simulator's free-flight trims with the withheld
effects on plus Gaussian scatter of :data:`ornitail.gap.steady_data.DEFAULT_SIGMA`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import prepare_output_directory
from ornitail.gap.model_spec import BaselineSpec, write_baseline_spec
from ornitail.gap.steady_data import DEFAULT_SIGMA
from ornitail.gap.steady_diagnosis import predict_trims
from ornitail.gap.tunnel_diagnosis import predict_loads
from ornitail.gap.withheld_effects import WithheldCase, check_effects, simulate_withheld_log
from ornitail.sim.configuration import study_configuration
from ornitail.sim.effects import EffectSet
from ornitail.sim.free_flight import write_flight_log_csv

TUNNEL_SWITCHED = ("strut_interference", "clamping", "wake_profile", "cg_shift_with_x_h")
TUNNEL_NOISE = np.array([5e-4, 5e-4, 2e-5])  # N, N, N m
DEFAULT_MAGNITUDES = {
    "added_mass": 2.5,
    "flapping_frequency_coupling": 1.0,
    "wake_profile": 1.0,
    "cg_shift_with_x_h": 1.0,
    "pitch_damping": 0.6,
    "input_delay": 0.06,
    "input_filter": 0.06,
    "theta_drift": 0.008,
}
MAX_MAGNITUDE_FACTOR = 20.0
"""An example's effect magnitude may be at most this many times its default (docs/gap-diagnosis.md)."""
SWEEP_X_H_MM = (57.0, 98.0, 126.0)
STEADY_SWITCHED = ("wake_profile", "cg_shift_with_x_h", "day_to_day_drift")
STEADY_TAILS = ("S1", "S2", "S3", "S4", "S5", "S6", "AR1", "AR2", "AR4", "AR5", "AR6")
STEADY_CONFIGURATIONS = tuple((tail, 98.0) for tail in STEADY_TAILS) + tuple(
    (tail, x_h_mm) for x_h_mm in (57.0, 126.0) for tail in ("S1", "S3", "S6", "AR1", "AR6")
)


def tunnel_sweep_points(tail: str) -> pd.DataFrame:
    """The example sweep's set points (one row each, cycle-averages.csv columns)."""
    rows = []
    for x_h_mm in SWEEP_X_H_MM:
        for theta in range(0, 45, 5):
            rows.append(("theta", x_h_mm, float(theta), 0.8, 13.5))
        for speed in (0.4, 0.6, 1.0, 1.2):
            rows.append(("velocity", x_h_mm, 25.0, speed, 13.5))
        for frequency in (11.0, 12.0, 15.0):
            rows.append(("frequency", x_h_mm, 25.0, 0.8, frequency))
    table = pd.DataFrame(rows, columns=["sweep", "x_h_mm", "theta_deg", "v_m_s", "f_set_hz"])
    table.insert(0, "tail_id", tail)
    table.insert(2, "tailed", True)
    return table


def write_tunnel_example(
    effects: dict[str, float], tail: str, seed: int, folder: Path
) -> tuple[Path, Path]:
    """A sweep table with ``effects`` (tunnel-scope simulator effects, on/off) and its baseline."""
    _check_names(effects, TUNNEL_SWITCHED, "tunnel")
    table = tunnel_sweep_points(tail)
    points = table.assign(theta_rad=np.radians(table["theta_deg"]), f_hz=table["f_set_hz"])
    truth = EffectSet().without(*TUNNEL_SWITCHED).with_enabled(*effects)
    loads = predict_loads(points, truth)
    loads += np.random.default_rng(seed).standard_normal(loads.shape) * TUNNEL_NOISE
    for index, column in enumerate(("x_n", "z_n", "m_n_m")):
        table[column] = loads[:, index]
        table[f"{column}_se"] = TUNNEL_NOISE[index]
    data = folder / "cycle-averages.csv"
    table.to_csv(data, index=False, float_format="%.9g")
    spec = BaselineSpec("simulator", tail, 98.0, effects_off=TUNNEL_SWITCHED)
    return data, write_baseline_spec(spec, folder / "baseline.toml")


def _check_names(effects: dict[str, float], allowed: tuple[str, ...], kind: str) -> None:
    unknown = [name for name in effects if name not in allowed]
    if unknown:
        raise UserInputError(
            "effects",
            f"{unknown[0]!r} is not a {kind} example effect; choose from {', '.join(allowed)}",
        )


def write_steady_example(effects: dict[str, float], seed: int, folder: Path) -> tuple[Path, Path]:
    """A steady-state table with ``effects`` (on/off) and the baseline that switches them off."""
    _check_names(effects, STEADY_SWITCHED, "steady")
    table = pd.DataFrame(STEADY_CONFIGURATIONS, columns=["tail", "x_h_mm"])
    rows = table.assign(label=table["tail"], x_h_m=table["x_h_mm"] / 1000.0)
    truth = EffectSet().without(*STEADY_SWITCHED).with_enabled(*effects)
    values = predict_trims(rows, truth)
    values += np.random.default_rng(seed).standard_normal(values.shape) * DEFAULT_SIGMA
    for index, column in enumerate(("theta_ss_deg", "v_ss_m_s", "f_ss_hz")):
        scale = 180.0 / math.pi if column.endswith("_deg") else 1.0
        table[column] = values[:, index] * scale
        table[f"{column}_sigma"] = DEFAULT_SIGMA[index] * scale
    data = folder / "steady-states.csv"
    table.to_csv(data, index=False, float_format="%.6g")
    spec = BaselineSpec("simulator", "S3", 98.0, effects_off=STEADY_SWITCHED)
    return data, write_baseline_spec(spec, folder / "baseline.toml")


def write_example(
    kind: str,
    effects: dict[str, float | None],
    tail: str,
    x_h_mm: float,
    manoeuvres: int,
    seed: int,
    folder: Path,
) -> dict[str, object]:
    """Write the example data and baseline file into ``folder``; return their paths."""
    if not math.isfinite(x_h_mm):
        raise UserInputError("x_h_mm", f"{x_h_mm!r} is not a finite number")
    if kind == "flight":
        check_effects({name: 0.0 if value is None else value for name, value in effects.items()})
        for name, value in effects.items():
            limit = MAX_MAGNITUDE_FACTOR * abs(DEFAULT_MAGNITUDES.get(name, 1.0))
            if value is not None and abs(value) > limit:
                raise UserInputError(
                    f"effect {name}",
                    f"magnitude {value:g} is beyond +-{limit:g} ({MAX_MAGNITUDE_FACTOR:g} x the "
                    f"example's {DEFAULT_MAGNITUDES.get(name, 1.0):g})",
                )
    if kind == "flight":
        study_configuration(tail, x_h_mm)  # tail and x_h checked before anything is written
    prepare_output_directory(folder)
    if kind in ("tunnel", "steady"):
        magnitudes = {name: 1.0 for name in effects}
        if kind == "tunnel":
            data, model = write_tunnel_example(magnitudes, tail, seed, folder)
        else:
            data, model = write_steady_example(magnitudes, seed, folder)
    else:
        magnitudes = {
            name: DEFAULT_MAGNITUDES.get(name, 1.0) if value is None else value
            for name, value in effects.items()
        }
        check_effects(magnitudes)
        case = WithheldCase(tail, x_h_mm, magnitudes, manoeuvres=manoeuvres, seed=seed)
        data = write_flight_log_csv(simulate_withheld_log(case), folder / "flight.csv")
        model = write_baseline_spec(case.baseline_spec(), folder / "baseline.toml")
    return {"kind": kind, "data": str(data), "model": str(model), "effects": magnitudes}
