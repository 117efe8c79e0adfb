"""Reading ATI ``.cal`` calibration files (XML, formats 1.0 and 1.1) as written, in file units.

Fields read (see ``docs/calibration.md``):

- ``FTSensor``: ``Serial``, ``BodyStyle``, ``Family``, ``NumGages``, ``CalFileVersion``;
- the first ``Calibration`` element: ``PartNumber``, ``CalDate``, ``ForceUnits``, ``TorqueUnits``,
  ``DistUnits``, optional ``AngleUnits`` (default degrees, as in ATI's library);
- six ``Axis`` rows ``Fx, Fy, Fz, Tx, Ty, Tz`` with ``values`` (one per gauge), ``max`` and
  ``scale``; the optional ``BasicTransform`` (``Dx, Dy, Dz`` in ``DistUnits``, ``Rx, Ry, Rz`` in
  ``AngleUnits``); in format 1.1 also six ``UserAxis`` rows with ``values`` and ``max``.

Conversion to SI and the matrix maths live in :mod:`ornitail.calibration.ati_calibration`.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_input_bytes

AXIS_NAMES = ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")
SUPPORTED_GAUGE_COUNT = 6
SUPPORTED_FORMAT_VERSIONS = ("1.0", "1.1")
RADIANS_PER_ANGLE_UNIT = {
    "deg": math.pi / 180.0,
    "degree": math.pi / 180.0,
    "degrees": math.pi / 180.0,
    "rad": 1.0,
    "radian": 1.0,
    "radians": 1.0,
}


@dataclass(frozen=True)
class AtiCalFileContents:
    """The numbers and strings of one ATI ``.cal`` file, in the file's own units.

    ``axis_rows`` are the ``Axis`` values divided by their ``scale`` (the basic matrix, force
    rows in ``force_units`` per volt, torque rows in ``torque_units`` per volt);
    ``user_axis_rows`` are the ``UserAxis`` values (format 1.1) or ``None``.
    ``basic_transform_distances`` are in ``distance_units``; ``basic_transform_angles_rad`` in
    radians.
    """

    serial: str
    body_style: str
    family: str
    part_number: str
    calibration_date: str
    file_format_version: str
    gauge_count: int
    force_units: str
    torque_units: str
    distance_units: str
    axis_rows: np.ndarray
    axis_maxima: np.ndarray
    user_axis_rows: np.ndarray | None
    user_axis_maxima: np.ndarray | None
    basic_transform_distances: np.ndarray
    basic_transform_angles_rad: np.ndarray


def _attribute(element: ElementTree.Element, name: str, where: str) -> str:
    value = element.get(name)
    if value is None or not value.strip():
        raise UserInputError(where, f"missing attribute {name!r}")
    return value.strip()


def _number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise UserInputError(where, f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise UserInputError(where, f"{text!r} is not a finite number")
    return value


def _read_rows(
    calibration: ElementTree.Element, tag: str, gauge_count: int, source: str, scaled: bool
) -> tuple[np.ndarray, np.ndarray]:
    elements = calibration.findall(tag)
    if len(elements) != len(AXIS_NAMES):
        raise UserInputError(
            f"{source}: <{tag}>", f"expected {len(AXIS_NAMES)} rows, found {len(elements)}"
        )
    rows = np.empty((len(AXIS_NAMES), gauge_count))
    maxima = np.empty(len(AXIS_NAMES))
    for index, (element, expected_name) in enumerate(zip(elements, AXIS_NAMES, strict=True)):
        name = element.get("Name", "")
        where = f"{source}: <{tag} Name={name!r}>"
        if name != expected_name:
            raise UserInputError(
                where, f"row {index + 1} should be {expected_name!r} (order Fx Fy Fz Tx Ty Tz)"
            )
        items = _attribute(element, "values", where).split()
        if len(items) != gauge_count:
            raise UserInputError(
                f"{where} values", f"expected {gauge_count} values (NumGages), got {len(items)}"
            )
        values = np.array([_number(item, f"{where} values") for item in items])
        scale = _number(element.get("scale", "1"), f"{where} scale") if scaled else 1.0
        if scale <= 0.0:
            raise UserInputError(f"{where} scale", f"scale must be positive, got {scale!r}")
        rows[index] = values / scale
        maxima[index] = _number(_attribute(element, "max", where), f"{where} max")
        if maxima[index] <= 0.0:
            raise UserInputError(
                f"{where} max", f"rated load must be positive, got {maxima[index]}"
            )
    return rows, maxima


def _read_basic_transform(
    calibration: ElementTree.Element, source: str
) -> tuple[np.ndarray, np.ndarray]:
    angle_units = calibration.get("AngleUnits", "degrees").strip()
    if angle_units not in RADIANS_PER_ANGLE_UNIT:
        known = ", ".join(sorted(RADIANS_PER_ANGLE_UNIT))
        raise UserInputError(
            f"{source}: AngleUnits", f"unknown angle unit {angle_units!r} (known: {known})"
        )
    elements = calibration.findall("BasicTransform")
    if len(elements) > 1:
        raise UserInputError(f"{source}: <BasicTransform>", "more than one BasicTransform")
    if not elements:
        return np.zeros(3), np.zeros(3)
    element = elements[0]
    where = f"{source}: <BasicTransform>"
    values = {
        key: _number(element.get(key, "0"), f"{where} {key}")
        for key in ("Dx", "Dy", "Dz", "Rx", "Ry", "Rz")
    }
    distances = np.array([values["Dx"], values["Dy"], values["Dz"]])
    angles = np.array([values["Rx"], values["Ry"], values["Rz"]])
    return distances, angles * RADIANS_PER_ANGLE_UNIT[angle_units]


def read_ati_cal_bytes(data: bytes, source: str) -> AtiCalFileContents:
    """Parse the bytes of an ATI ``.cal`` file; ``source`` names the file in error messages."""
    try:
        root = ElementTree.fromstring(data)
    except ElementTree.ParseError as error:
        raise UserInputError(source, f"not a valid XML calibration file ({error})") from None
    if root.tag != "FTSensor":
        raise UserInputError(source, f"root element is <{root.tag}>, expected <FTSensor>")
    version = root.get("CalFileVersion", "1.0").strip()
    if version not in SUPPORTED_FORMAT_VERSIONS:
        raise UserInputError(
            f"{source}: CalFileVersion",
            f"unsupported format {version!r} (supported: {', '.join(SUPPORTED_FORMAT_VERSIONS)})",
        )
    gauge_text = _attribute(root, "NumGages", f"{source}: <FTSensor>")
    if gauge_text != str(SUPPORTED_GAUGE_COUNT):
        raise UserInputError(
            f"{source}: NumGages",
            f"{gauge_text!r} gauges; ornitail reads six-gauge six-axis sensors only",
        )
    calibration = root.find("Calibration")
    if calibration is None:
        raise UserInputError(source, "no <Calibration> element")
    where = f"{source}: <Calibration>"
    axis_rows, axis_maxima = _read_rows(
        calibration, "Axis", SUPPORTED_GAUGE_COUNT, source, scaled=True
    )
    user_axis_rows = user_axis_maxima = None
    if version == "1.1":
        user_axis_rows, user_axis_maxima = _read_rows(
            calibration, "UserAxis", SUPPORTED_GAUGE_COUNT, source, scaled=False
        )
    distances, angles_rad = _read_basic_transform(calibration, source)
    return AtiCalFileContents(
        serial=_attribute(root, "Serial", f"{source}: <FTSensor>"),
        body_style=root.get("BodyStyle", "").strip(),
        family=root.get("Family", "").strip(),
        part_number=calibration.get("PartNumber", "").strip(),
        calibration_date=calibration.get("CalDate", "").strip(),
        file_format_version=version,
        gauge_count=SUPPORTED_GAUGE_COUNT,
        force_units=_attribute(calibration, "ForceUnits", where),
        torque_units=_attribute(calibration, "TorqueUnits", where),
        distance_units=_attribute(calibration, "DistUnits", where),
        axis_rows=axis_rows,
        axis_maxima=axis_maxima,
        user_axis_rows=user_axis_rows,
        user_axis_maxima=user_axis_maxima,
        basic_transform_distances=distances,
        basic_transform_angles_rad=angles_rad,
    )


def read_ati_cal_file(path: str | Path) -> tuple[AtiCalFileContents, bytes]:
    """Read and parse an ATI ``.cal`` file; return its contents and its raw bytes."""
    path = Path(path)
    data = read_input_bytes(path)
    return read_ati_cal_bytes(data, str(path)), data
