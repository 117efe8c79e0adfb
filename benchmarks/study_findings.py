"""Evaluate the simulator against every finding of the study (issue 13) and print a table.

Run: ``python benchmarks/study_findings.py``. Trims and linearises every study tail at the study's four
tail positions (x_h = 57, 98, 114, 126 mm, reference/fuselages.csv) with all effects on, then checks
each finding of Rijks et al. (AIAA 2018-0524, Section IV.B; docs/background.md section 6) and prints the finding,
the measured (study) value, the simulator's value and whether the simulator reproduces it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.sim.configuration import study_configuration
from ornitail.sim.dynamics import LinearisedModel, linearise
from ornitail.sim.effects import EffectSet

POSITIONS_MM = (57.0, 98.0, 114.0, 126.0)
AREA_SERIES = ("S1", "S2", "S3", "S4", "S5", "S6")
ASPECT_SERIES = ("AR1", "AR2", "S3", "AR4", "AR5", "AR6")  # S3 is AR3
ALL_TAILS = AREA_SERIES + ("AR1", "AR2", "AR4", "AR5", "AR6", "T1", "T2", "T3")
TABLE_3_PATH = (
    Path(__file__).resolve().parents[1]
    / "tests"
    / "data"
    / "reference"
    / "steady_state_validation.csv"
)
"""Table 3 of the study (a copy of ../shared/reference/steady_state_validation.csv): free-flight steady states at
57 mm of tails flown on one day (rows ``AR2a`` ...)."""


def table_3() -> dict[str, tuple[float, float, float]]:
    """Measured theta (deg), V (m/s) and f (Hz) at 57 mm by tail (``AR2``, ..., ``S6``), from Table 3."""
    rows = pd.read_csv(TABLE_3_PATH, comment="#")
    return {
        row["tail"][:-1]: (row["theta_meas_deg"], row["v_meas_m_s"], row["f_meas_hz"])
        for row in rows.to_dict("records")
    }


TABLE_3_SCATTER = (1.4, 0.08, 0.6)  # deg, m/s, Hz: the study's own scatter (issue 13)
# damping ratio of the pitch oscillation implied by Table 4 at 98 mm (Mu, Mw, Xq, Zq sign-flipped)
# (m = 23.5 g, I_yy = 1.5e-4 kg m^2, theta0 = 22 deg, V0 = 0.68 m/s, docs/frames.md)
TABLE_4_DAMPING = {"S1": 0.15, "S2": 0.21, "S3": 0.34, "S5": 0.39}
TABLE_4_DAMPING_TOLERANCE = 0.05


@cache
def model(tail: str, x_h_mm: float) -> LinearisedModel:
    """Linearised free-flight model of a study tail at x_h (mm), all effects on."""
    return linearise(study_configuration(tail, x_h_mm), EffectSet())


def theta_deg(tail: str, x_h_mm: float) -> float:
    return math.degrees(model(tail, x_h_mm).trim.theta_rad)


def speed(tail: str, x_h_mm: float) -> float:
    return model(tail, x_h_mm).trim.airspeed_m_s


def frequency(tail: str, x_h_mm: float) -> float:
    return model(tail, x_h_mm).trim.flapping_frequency_hz


def damping(tail: str, x_h_mm: float) -> float:
    return model(tail, x_h_mm).oscillatory_damping_ratio()


def natural_frequency(tail: str, x_h_mm: float) -> float:
    return model(tail, x_h_mm).oscillatory_natural_frequency_rad_s()


def strictly_increasing(values: list[float]) -> bool:
    return all(later > earlier for earlier, later in zip(values, values[1:], strict=False))


def strictly_decreasing(values: list[float]) -> bool:
    return strictly_increasing([-value for value in values])


@dataclass(frozen=True)
class Finding:
    """One row: what the study found, what it measured, what the simulator gives, and the verdict."""

    name: str
    measured: str
    simulated: str
    reproduced: bool


def _series(quantity, series: tuple[str, ...], x_h_mm: float) -> list[float]:
    return [quantity(tail, x_h_mm) for tail in series]


def _trend_row(name: str, series: tuple[str, ...]) -> Finding:
    """Larger tail: larger theta, V, damping, slightly lower natural frequency (every position)."""
    misses = []
    for x_h in POSITIONS_MM:
        if not strictly_increasing(_series(theta_deg, series, x_h)):
            misses.append(f"theta@{x_h:g}")
        if not strictly_increasing(_series(speed, series, x_h)):
            misses.append(f"V@{x_h:g}")
        if not strictly_increasing(_series(damping, series, x_h)):
            misses.append(f"zeta@{x_h:g}")
        omegas = _series(natural_frequency, series, x_h)
        if not (omegas[-1] < omegas[0] and omegas[0] - omegas[-1] < 0.3 * omegas[0]):
            misses.append(f"omega@{x_h:g}")
    zetas = _series(damping, series, 98.0)
    simulated = "zeta@98 " + " ".join(f"{value:.2f}" for value in zetas)
    if misses:
        simulated += "; misses " + ",".join(misses)
    return Finding(name, "monotone at every x_h", simulated, not misses)


def findings() -> list[Finding]:
    rows = [
        _trend_row("larger S: larger theta, V, damping, slightly lower omega_n", AREA_SERIES),
        _trend_row("larger AR: larger theta, V, damping, slightly lower omega_n", ASPECT_SERIES),
    ]
    # near the wings AR acts more strongly than S on theta (Table 3: +7.6 vs +6.1 deg)
    ar_gain = theta_deg("AR6", 57.0) - theta_deg("AR2", 57.0)
    s_gain = theta_deg("S6", 57.0) - theta_deg("S2", 57.0)
    rows.append(
        Finding(
            "near the wings AR acts more strongly than S (theta AR2->AR6 vs S2->S6, 57 mm)",
            "+7.63 vs +6.07 deg",
            f"{ar_gain:+.2f} vs {s_gain:+.2f} deg",
            ar_gain > s_gain > 0.0,
        )
    )
    # Table 3 steady states at 57 mm
    worst = np.zeros(3)
    for tail, measured in table_3().items():
        simulated = (theta_deg(tail, 57.0), speed(tail, 57.0), frequency(tail, 57.0))
        worst = np.maximum(worst, np.abs(np.subtract(simulated, measured)))
    rows.append(
        Finding(
            "Table 3 steady states at 57 mm (AR2, AR4, AR6, S2, S4, S6)",
            "within 1.4 deg, 0.08 m/s, 0.6 Hz",
            f"worst {worst[0]:.2f} deg, {worst[1]:.3f} m/s, {worst[2]:.2f} Hz",
            bool(np.all(worst <= TABLE_3_SCATTER)),
        )
    )
    # flapping frequency falls slightly with S and AR at every position
    misses = []
    for x_h in POSITIONS_MM:
        for label, series in (("S", AREA_SERIES), ("AR", ASPECT_SERIES)):
            values = _series(frequency, series, x_h)
            if not 0.0 < values[0] - values[-1] < 1.0:
                misses.append(f"{label}@{x_h:g}")
    ar_drop = frequency("AR2", 57.0) - frequency("AR6", 57.0)
    rows.append(
        Finding(
            "flapping frequency falls slightly with S and AR (every x_h)",
            "AR2->AR6 -0.72 Hz (57 mm)",
            f"AR2->AR6 {-ar_drop:+.2f} Hz" + (f"; misses {','.join(misses)}" if misses else ""),
            not misses,
        )
    )
    # S1 and AR1 gain damping up to 98 mm, then lose it sharply; S3 keeps it to 126 mm
    by_position = {
        tail: [damping(tail, x_h) for x_h in POSITIONS_MM] for tail in ("S1", "AR1", "S3")
    }
    narrow_ok = all(
        zetas[1] > zetas[0] and zetas[3] < 0.7 * zetas[1]
        for zetas in (by_position["S1"], by_position["AR1"])
    )
    s3 = by_position["S3"]
    wide_ok = s3[1] > s3[0] and min(s3[1:]) > 0.9 * s3[1]
    rows.append(
        Finding(
            "S1, AR1 gain damping to 98 mm then lose it sharply; S3 keeps it to 126 mm",
            "qualitative",
            "; ".join(
                f"{tail} " + "/".join(f"{value:.2f}" for value in zetas)
                for tail, zetas in by_position.items()
            ),
            narrow_ok and wide_ok,
        )
    )
    # AR advantage fades with x_h: the theta spread AR1 -> AR5 shrinks aft
    theta_spread = [theta_deg("AR5", x) - theta_deg("AR1", x) for x in POSITIONS_MM]
    rows.append(
        Finding(
            "AR advantage fades with x_h (AR1 and AR5 converge)",
            "qualitative",
            "theta AR5-AR1 " + "/".join(f"{value:.2f}" for value in theta_spread),
            strictly_decreasing(theta_spread),
        )
    )
    # M_q hardly depends on x_h; M_u set by x_h; X_q peaks near 98 mm
    mq = [abs(model("S3", x).derivatives["Mq"]) for x in POSITIONS_MM]
    mu = [model("S3", x).derivatives["Mu"] for x in POSITIONS_MM]
    mu_tails = [model(tail, 98.0).derivatives["Mu"] for tail in AREA_SERIES]
    xq = [model("S3", x).derivatives["Xq"] for x in POSITIONS_MM]
    mq_flat = max(mq) / min(mq) < 1.25
    mu_by_x_h = (max(mu) - min(mu)) > (max(mu_tails) - min(mu_tails))
    xq_peak = int(np.argmax(np.abs(xq))) in (1, 2)
    rows.append(
        Finding(
            "M_q hardly depends on x_h; M_u set by x_h; X_q peaks near 98 mm (S3)",
            "qualitative",
            "|Mq| " + "/".join(f"{v:.2e}" for v in mq) + "; Xq " + "/".join(f"{v:.1e}" for v in xq),
            bool(mq_flat and mu_by_x_h and xq_peak),
        )
    )
    # T3: stable (lightly damped) at 57 mm, unstable at 98 and 126 mm
    t3 = [damping("T3", x) for x in (57.0, 98.0, 126.0)]
    rows.append(
        Finding(
            "T3 stable but lightly damped at 57 mm, unstable at 98 and 126 mm",
            "qualitative",
            "zeta " + "/".join(f"{value:.3f}" for value in t3),
            0.0 < t3[0] < 0.1 and t3[1] < 0.0 and t3[2] < 0.0,
        )
    )
    # poles: an oscillatory pair and real poles near -1 and -10 1/s
    slow, fast = [], []
    for tail in ALL_TAILS:
        if tail == "T3":
            continue
        for x_h in POSITIONS_MM:
            poles = model(tail, x_h).real_poles()
            if len(poles) == 2:
                fast.append(poles[0])
                slow.append(poles[1])
    poles_ok = (
        len(fast) == (len(ALL_TAILS) - 1) * len(POSITIONS_MM)
        and min(fast) > -15.0
        and max(fast) < -5.0
        and min(slow) > -2.5
        and max(slow) < -0.4
    )
    rows.append(
        Finding(
            "poles: an oscillatory pair, real poles near -1 and -10 1/s",
            "~-1, ~-10",
            f"slow {min(slow):.2f}..{max(slow):.2f}, fast {min(fast):.1f}..{max(fast):.1f}",
            bool(poles_ok),
        )
    )
    # damping ratios at 98 mm against Table 4
    errors = {tail: damping(tail, 98.0) - value for tail, value in TABLE_4_DAMPING.items()}
    rows.append(
        Finding(
            "pitch damping at 98 mm (Table 4: S1 0.15, S2 0.21, S3 0.34, S5 0.39)",
            "0.15/0.21/0.34/0.39",
            "/".join(f"{damping(tail, 98.0):.3f}" for tail in TABLE_4_DAMPING),
            all(abs(error) <= TABLE_4_DAMPING_TOLERANCE for error in errors.values()),
        )
    )
    return rows


def trim_table() -> str:
    """theta / V / f / zeta / omega_n of every study tail at every position."""
    lines = []
    for tail in ALL_TAILS:
        cells = []
        for x_h in POSITIONS_MM:
            cells.append(
                f"{theta_deg(tail, x_h):5.1f}/{speed(tail, x_h):.3f}/{frequency(tail, x_h):.2f}"
                f"/{damping(tail, x_h):+.3f}/{natural_frequency(tail, x_h):.2f}"
            )
        lines.append(f"{tail:4s} " + "  ".join(cells))
    return "\n".join(lines)


def main() -> None:
    print("tail theta/V/f/zeta/omega_n at x_h = " + ", ".join(f"{x:g}" for x in POSITIONS_MM))
    print(trim_table())
    print()
    rows = findings()
    for row in rows:
        verdict = "yes" if row.reproduced else "NO"
        print(
            f"[{verdict:3s}] {row.name}\n       study: {row.measured}\n       sim:   {row.simulated}"
        )
    print(f"\n{sum(row.reproduced for row in rows)}/{len(rows)} findings reproduced")


if __name__ == "__main__":
    main()
