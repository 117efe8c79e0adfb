"""The diagnosis' verdict: an effect, no gap worth naming, or a gap the library does not explain.

``effect``: the ranking detected one (its best validation closure passes the calibrated detection
rule of :mod:`ornitail.gap.detection`).
``unexplained``: no candidate is detected, yet the gap is systematic, shown in one of two ways
(``verdict_basis``):
- ``input_locked_gap``: a large part of the baseline's gap repeats from run to run, the input-locked
  gap, gap_before x sqrt(input-locked fraction), exceeds :data:`UNEXPLAINED_GAP` (in units of the
  measured signals' standard deviation). The sparse regression on the residual is then the pointer
  to what is missing.
- ``derivative_refit``: the re-fit of the model's own derivatives (``derivative_refit``) closes a
  material part of the gap (at least the detection rule's materiality floor) on test runs it did not
  see, and those runs support it (its interval lies above zero). Segments of one record repeat no
  input, so there the input-locked gap cannot show a systematic error; a re-fit confirmed on
  withheld runs does, and its moved derivatives say where the model is wrong.
``none``: neither; what is left is noise, disturbances, or a small error the library cannot name.
"""

from __future__ import annotations

import math
from typing import Any

from ornitail.gap.detection import MATERIAL_CLOSURE
from ornitail.gap.ranking import Ranking

UNEXPLAINED_GAP = 0.25


def _refit_is_material(refit: dict[str, Any] | None) -> bool:
    """Whether a derivative re-fit (the report's ``derivative_refit``) closes a material part of
    the gap on its test runs and is supported by them."""
    if not refit or refit.get("derivatives") is None:
        return False
    return bool(refit["supported_by_test_runs"]) and refit["closure_test"] >= MATERIAL_CLOSURE


def verdict_of(
    ranking: Ranking,
    gap_before: float,
    input_locked_fraction: float,
    derivative_refit: dict[str, Any] | None = None,
) -> tuple[str, str]:
    """The verdict and its basis (module docstring): ``("effect", "detection_rule")``,
    ``("unexplained", "input_locked_gap" | "derivative_refit")`` or ``("none", "")``."""
    if ranking.detected:
        return "effect", "detection_rule"
    if gap_before * math.sqrt(max(input_locked_fraction, 0.0)) > UNEXPLAINED_GAP:
        return "unexplained", "input_locked_gap"
    if _refit_is_material(derivative_refit):
        return "unexplained", "derivative_refit"
    return "none", ""
