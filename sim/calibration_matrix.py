"""Minimal reader of an ATI ``.cal`` file's basic matrix, converted to SI (N and N m per volt).

Kept deliberately tiny (the full calibration reader lives in ``ornitail.calibration``): the basic
matrix row of each ``Axis`` element is its ``values`` divided by its ``scale``; torque rows are
converted from the file's ``TorqueUnits`` to N m.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from importlib import resources
from pathlib import Path

import numpy as np

from ornitail.core.errors import UserInputError

_FORCE_TO_NEWTON = {"N": 1.0, "lbf": 4.4482216152605, "kgf": 9.80665}
_TORQUE_TO_NEWTON_METRE = {
    "N-m": 1.0,
    "N-mm": 1e-3,
    "lbf-in": 0.1129848290276167,
    "kgf-cm": 0.0980665,
}
AXIS_ORDER = ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")


def read_basic_matrix_si(path: str | Path) -> np.ndarray:
    """6x6 matrix: gauge voltages (V) to sensor-frame [Fx, Fy, Fz (N), Tx, Ty, Tz (N m)]."""
    try:
        root = ElementTree.parse(path).getroot()
    except (OSError, ElementTree.ParseError) as error:
        raise UserInputError(str(path), f"cannot read calibration file ({error})") from error
    calibration = root.find("Calibration")
    if calibration is None:
        raise UserInputError(str(path), "no <Calibration> element")
    force_unit = calibration.get("ForceUnits", "")
    torque_unit = calibration.get("TorqueUnits", "")
    if force_unit not in _FORCE_TO_NEWTON or torque_unit not in _TORQUE_TO_NEWTON_METRE:
        raise UserInputError(str(path), f"unsupported units {force_unit!r}/{torque_unit!r}")
    rows = {}
    for axis in calibration.findall("Axis"):
        values = np.array(axis.get("values", "").split(), dtype=float)
        rows[axis.get("Name")] = values / float(axis.get("scale", "1"))
    if set(rows) != set(AXIS_ORDER) or any(len(row) != 6 for row in rows.values()):
        raise UserInputError(str(path), "expected six Axis rows Fx..Tz with six values each")
    matrix = np.array([rows[name] for name in AXIS_ORDER])
    matrix[:3] *= _FORCE_TO_NEWTON[force_unit]
    matrix[3:] *= _TORQUE_TO_NEWTON_METRE[torque_unit]
    return matrix


def packaged_nano17_matrix_si() -> np.ndarray:
    """Basic matrix of the packaged real Nano-17 calibration ``sim/data/FT8884.cal`` (SI units)."""
    with resources.as_file(resources.files("ornitail.sim").joinpath("data/FT8884.cal")) as path:
        return read_basic_matrix_si(path)
