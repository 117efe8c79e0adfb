"""Hot-wire calibration laws (King's law, polynomial) and their TOML/JSON files.

Both laws are stated at a reference temperature ``T_ref``: a voltage read at flow temperature
``T_flow`` is first corrected with ``E_corr = E sqrt((T_w - T_ref)/(T_w - T_flow))``.

- King's law: ``E_corr^2 = A + B U^n``, so ``U = ((E_corr^2 - A) / B)^(1/n)``.
- Polynomial: ``U = sum_k c_k E_corr^k``.

Velocities below the law's zero (``E_corr^2 < A``) are returned as 0 m/s.

Saved law file (``.toml`` or ``.json``, same keys)::

    law = "king"                    # or "polynomial"
    reference_temperature_k = 293.15
    wire_temperature_k = 523.15
    a_v2 = 1.6                      # king: A, V^2
    b = 0.9                         # king: B, V^2 (s/m)^n
    exponent_n = 0.45               # king: n
    coefficients = [0.1, 0.2]       # polynomial: c_0..c_k, m/s per V^k
    points_content_hash = "sha256:..."
    point_count = 15
    rms_residual_m_s = 0.004
    max_abs_residual_m_s = 0.009

A law loaded from a file carries the file's content hash; a freshly fitted law carries the hash of
the bytes :func:`save_hotwire_law` writes for a ``.json`` file.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ornitail.calibration.hotwire_points import temperature_corrected_voltage
from ornitail.core.errors import UserInputError
from ornitail.core.hashing import content_hash_of_bytes
from ornitail.core.input_files import (
    decode_text,
    parse_json_text,
    parse_toml_text,
    read_input_bytes,
)
from ornitail.core.toml_table import TomlTable


@dataclass(frozen=True, eq=False)
class HotwireFitProvenance:
    """Where a law came from: the points file's hash and the fit's residual summary (m/s)."""

    points_content_hash: str
    point_count: int
    rms_residual_m_s: float
    max_abs_residual_m_s: float


def _law_field_names(law_class: type[KingsLaw | PolynomialHotwireLaw]) -> list[str]:
    """The law's own fields a law file holds (besides ``law`` and the provenance's fields)."""
    return [
        item.name
        for item in dataclasses.fields(law_class)
        if item.name not in ("provenance", "content_hash", "path")
    ]


def _law_fields_as_dict(law: KingsLaw | PolynomialHotwireLaw) -> dict[str, Any]:
    fields = {"law": law.law_name}
    for name in _law_field_names(type(law)):
        value = getattr(law, name)
        fields[name] = value.tolist() if isinstance(value, np.ndarray) else float(value)
    fields.update(dataclasses.asdict(law.provenance))
    return fields


def _canonical_json_bytes(law: KingsLaw | PolynomialHotwireLaw) -> bytes:
    return (json.dumps(_law_fields_as_dict(law), indent=2) + "\n").encode()


class _HotwireLawBase:
    """Shared behaviour: temperature correction and content hash."""

    reference_temperature_k: float
    wire_temperature_k: float

    def __post_init__(self) -> None:
        if not self.content_hash:
            json_bytes = _canonical_json_bytes(self)
            object.__setattr__(self, "content_hash", content_hash_of_bytes(json_bytes))

    def corrected_voltage(
        self, voltage_v: float | np.ndarray, flow_temperature_k: float | np.ndarray
    ) -> np.ndarray:
        """Return the voltage corrected to the law's reference temperature (V)."""
        return temperature_corrected_voltage(
            voltage_v, flow_temperature_k, self.reference_temperature_k, self.wire_temperature_k
        )


@dataclass(frozen=True, eq=False)
class KingsLaw(_HotwireLawBase):
    """King's law ``E_corr^2 = a_v2 + b U^exponent_n``.

    Attributes
    ----------
    a_v2 : float
        A, V^2 (the squared zero-flow voltage).
    b : float
        B, V^2 (s/m)^n.
    exponent_n : float
        n, dimensionless (about 0.45-0.5 for a hot wire).
    reference_temperature_k, wire_temperature_k : float
        Reference flow temperature of the law and wire temperature, K.
    """

    a_v2: float
    b: float
    exponent_n: float
    reference_temperature_k: float
    wire_temperature_k: float
    provenance: HotwireFitProvenance
    content_hash: str = ""
    path: Path | None = None
    law_name = "king"

    def velocity_from_voltage(
        self, voltage_v: float | np.ndarray, flow_temperature_k: float | np.ndarray
    ) -> np.ndarray:
        """Return flow velocity (m/s) for bridge voltage(s) ``voltage_v`` at ``T_flow`` (K)."""
        corrected = self.corrected_voltage(voltage_v, flow_temperature_k)
        base = np.maximum((corrected**2 - self.a_v2) / self.b, 0.0)
        return base ** (1.0 / self.exponent_n)


@dataclass(frozen=True, eq=False)
class PolynomialHotwireLaw(_HotwireLawBase):
    """Polynomial law ``U = sum_k coefficients[k] * E_corr^k``.

    Attributes
    ----------
    coefficients : numpy.ndarray
        c_0..c_order, m/s per V^k, ascending powers.
    reference_temperature_k, wire_temperature_k : float
        Reference flow temperature of the law and wire temperature, K.
    """

    coefficients: np.ndarray
    reference_temperature_k: float
    wire_temperature_k: float
    provenance: HotwireFitProvenance
    content_hash: str = ""
    path: Path | None = None
    law_name = "polynomial"

    def velocity_from_voltage(
        self, voltage_v: float | np.ndarray, flow_temperature_k: float | np.ndarray
    ) -> np.ndarray:
        """Return flow velocity (m/s) for bridge voltage(s) ``voltage_v`` at ``T_flow`` (K)."""
        corrected = self.corrected_voltage(voltage_v, flow_temperature_k)
        return np.maximum(np.polynomial.polynomial.polyval(corrected, self.coefficients), 0.0)


HotwireLaw = KingsLaw | PolynomialHotwireLaw


def _toml_value(value: Any) -> str:
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    return repr(value)


def hotwire_law_file_bytes(law: HotwireLaw, path: str | Path) -> bytes:
    """Return the bytes of ``law`` as a ``.toml`` or ``.json`` file (chosen by ``path``)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".json":
        return _canonical_json_bytes(law)
    if suffix == ".toml":
        lines = ["# ornitail hot-wire calibration law (see docs/calibration.md)"]
        fields = _law_fields_as_dict(law)
        lines += [f"{key} = {_toml_value(value)}" for key, value in fields.items()]
        return ("\n".join(lines) + "\n").encode()
    raise UserInputError(str(path), "hot-wire law file must end in .toml or .json")


def save_hotwire_law(law: HotwireLaw, path: str | Path) -> HotwireLaw:
    """Write ``law`` to ``path`` (.toml or .json); return it carrying the file's hash and path."""
    path = Path(path)
    data = hotwire_law_file_bytes(law, path)
    try:
        path.write_bytes(data)
    except OSError as error:
        raise UserInputError(str(path), f"cannot write file ({error.strerror or error})") from None
    return dataclasses.replace(law, content_hash=content_hash_of_bytes(data), path=path)


def load_hotwire_law(path: str | Path) -> HotwireLaw:
    """Read a hot-wire law file written by :func:`save_hotwire_law`."""
    path = Path(path)
    source = str(path)
    suffix = path.suffix.lower()
    if suffix not in (".json", ".toml"):
        raise UserInputError(source, "hot-wire law file must end in .toml or .json")
    data = read_input_bytes(path)
    text = decode_text(data, source)
    document = parse_json_text(text, source) if suffix == ".json" else parse_toml_text(text, source)
    laws = {law_class.law_name: law_class for law_class in (KingsLaw, PolynomialHotwireLaw)}
    # the law's name first: it decides which keys the file may have
    everything = document if isinstance(document, dict) else {}
    law_name = TomlTable(path, "", document, everything).text("law", choices=tuple(laws))
    law_class = laws[law_name]
    provenance_keys = [item.name for item in dataclasses.fields(HotwireFitProvenance)]
    fields = TomlTable(path, "", document, ["law", *_law_field_names(law_class), *provenance_keys])
    provenance = HotwireFitProvenance(
        points_content_hash=fields.text("points_content_hash", "", empty=True),
        point_count=fields.integer("point_count"),
        rms_residual_m_s=fields.number("rms_residual_m_s"),
        max_abs_residual_m_s=fields.number("max_abs_residual_m_s"),
    )
    reference_temperature_k = fields.number("reference_temperature_k")
    wire_temperature_k = fields.number("wire_temperature_k")
    if wire_temperature_k <= reference_temperature_k:
        raise UserInputError(
            fields.where("wire_temperature_k"),
            f"{wire_temperature_k:g} must be above reference_temperature_k {reference_temperature_k:g}",
        )
    common = {
        "reference_temperature_k": reference_temperature_k,
        "wire_temperature_k": wire_temperature_k,
        "provenance": provenance,
        "content_hash": content_hash_of_bytes(data),
        "path": path,
    }
    if law_class is KingsLaw:
        return KingsLaw(
            a_v2=fields.number("a_v2"),
            b=fields.number("b", positive=True),
            exponent_n=fields.number("exponent_n", positive=True),
            **common,
        )
    coefficients = fields.numbers("coefficients", 2, "c_0..c_k (m/s per V^k)", or_more=True)
    return PolynomialHotwireLaw(coefficients=np.array(coefficients), **common)
