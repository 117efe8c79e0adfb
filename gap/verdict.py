"""The diagnosis' verdict: an effect, no gap worth naming, or a gap the library does not explain.

``effect``: the ranking detected one (its best validation closure passes the calibrated detection
rule of :mod:`ornitail.gap.detection`).
``unexplained``: no candidate closes the gap, yet a large part of the baseline's gap repeats from
run to run: the input-locked gap, gap_before x sqrt(input-locked fraction), exceeds
:data:`UNEXPLAINED_GAP` (in units of the measured signals' standard deviation). The sparse
regression on the residual is then the pointer to what is missing.
``none``: neither; what is left is noise, disturbances, or a small error the library cannot name.
"""

from __future__ import annotations

import math

from ornitail.gap.ranking import Ranking

UNEXPLAINED_GAP = 0.25


def verdict_of(ranking: Ranking, gap_before: float, input_locked_fraction: float) -> str:
    if ranking.detected:
        return "effect"
    if gap_before * math.sqrt(max(input_locked_fraction, 0.0)) > UNEXPLAINED_GAP:
        return "unexplained"
    return "none"
