"""Unit strings at the user-facing edge."""

from __future__ import annotations


def quotient_unit(numerator: str, denominator: str) -> str:
    """The unit of ``numerator / denominator``, bracketing a compound denominator: N/Hz, N m/(m/s)."""
    return f"{numerator}/({denominator})" if "/" in denominator else f"{numerator}/{denominator}"
