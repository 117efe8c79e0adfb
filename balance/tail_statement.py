"""Plain-language statements of whether the tail's contribution is resolvable on the balance.

For each force and moment at a set point measured with and without tail, the statement compares the difference
with (a) the balance resolution (0.149 gram-force for forces), (b) twice the standard error of the difference
(from cycle scatter, tare noise and repeat scatter, see :func:`~ornitail.balance.sweep_table.tail_contribution`)
and (c) the single-cycle scatter, which says whether one flap could show it or only the mean over many.
"""

from __future__ import annotations

import pandas as pd

from ornitail.balance.sweep_table import BALANCE_RESOLUTION_N

_STATED_LOADS = (("X", "x_n", "N"), ("Z", "z_n", "N"), ("M", "m_n_m", "N m"))


def tail_contribution_statements(contribution: pd.DataFrame) -> list[str]:
    """One line per load and set point of a :func:`tail_contribution` table, in words a tunnel engineer reads."""
    lines = []
    for _, row in contribution.iterrows():
        where = f"theta {row['theta_deg']:.2f} deg, V {row['v_m_s']:.3f} m/s, f {row['f_set_hz']:.2f} Hz"
        for symbol, name, unit in _STATED_LOADS:
            difference, sigma = float(row[name]), float(row[f"{name}_sigma"])
            single_cycle = max(
                float(row[f"{name}_cycle_2sigma_tailed"]),
                float(row[f"{name}_cycle_2sigma_tailless"]),
            )
            text = f"{symbol} at {where}: tail contributes {difference:+.5f} {unit} +- {2 * sigma:.5f} (2 sigma); "
            reasons = []
            if name.endswith("_n"):
                ratio = abs(difference) / BALANCE_RESOLUTION_N
                reasons.append(
                    f"{ratio:.1f}x the balance resolution ({BALANCE_RESOLUTION_N:.5f} N)"
                )
            reasons.append(
                f"{abs(difference) / (2 * sigma):.1f}x its 2-sigma uncertainty"
                if sigma > 0
                else "no uncertainty estimate"
            )
            text += "that is " + " and ".join(reasons) + ". "
            if bool(row[f"{name}_resolvable"]):
                verdict = "RESOLVABLE"
                if abs(difference) < single_cycle:
                    verdict += f", but only in the mean: a single cycle scatters by {single_cycle:.5f} {unit} (2 sigma)"
            else:
                below = []
                if name.endswith("_n") and abs(difference) <= BALANCE_RESOLUTION_N:
                    below.append("the balance resolution")
                if abs(difference) <= 2 * sigma:
                    below.append("the measurement uncertainty")
                verdict = "NOT resolvable: below " + " and ".join(below)
            lines.append(text + verdict + ".")
    return lines


def repeatability_statement(contribution: pd.DataFrame) -> str:
    """One sentence on the repeatability check of a :func:`tail_contribution` table: which loads' repeats
    scattered beyond their errors, by how much per record, and how much their sigma grew (empty for an empty
    table)."""
    if contribution.empty:
        return ""
    inflated = []
    for _, row in contribution.iterrows():
        for symbol, name, unit in _STATED_LOADS:
            scatter = float(row[f"{name}_record_scatter"])
            if scatter > 0.0:
                inflated.append(
                    f"{symbol} at theta {row['theta_deg']:.2f} deg by {scatter:.2g} {unit} per record (chi-square "
                    f"{float(row[f'{name}_repeat_chi_square_tailed']):.1f} on "
                    f"{int(row['repeats_tailed']) - 1} tailed, "
                    f"{float(row[f'{name}_repeat_chi_square_tailless']):.1f} on "
                    f"{int(row['repeats_tailless']) - 1} tailless; sigma x"
                    f"{float(row[f'{name}_repeat_inflation_tailed']):.2f} tailed, x"
                    f"{float(row[f'{name}_repeat_inflation_tailless']):.2f} tailless)"
                )
    if not inflated:
        return "Repeatability check: the repeats agree within their errors (no sigma inflated)."
    return (
        "Repeatability check: repeats scatter beyond their errors for "
        + "; ".join(inflated)
        + ", added to each repeat's error."
    )
