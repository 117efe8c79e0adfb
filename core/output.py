"""Results made printable: plain JSON values (numpy values made plain, NaN and infinity made null)."""

from __future__ import annotations

import math
import sys
from typing import Any


def to_jsonable(value: Any) -> Any:
    """``value`` with numpy arrays and scalars made plain and NaN or infinity made ``None`` (strict JSON)."""
    if isinstance(value, dict):
        return {str(key): to_jsonable(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(item) for item in value]
    # numpy is not imported here (`ornitail --help` needs none): before it is imported, no value is numpy's.
    numpy = sys.modules.get("numpy")
    if numpy is not None and isinstance(value, numpy.ndarray):
        return to_jsonable(value.tolist())
    if numpy is not None and isinstance(value, numpy.generic):
        return to_jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
