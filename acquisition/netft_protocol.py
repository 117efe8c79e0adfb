"""Wire protocol of ATI's Net F/T over UDP (RDT, "Raw Data Transfer") and its calibration XML (no I/O here).

Source: ATI Industrial Automation, *Net F/T Installation and Operation Manual*, document 9620-05-NET FT
(revision 11 read here), section 10 "UDP Interface Using RDT" (Table 10.1 RDT commands, the request and
record structures, 10.3 "Calculating F/T Values for RDT") and section 9.1, the ``netftapi2.xml`` page
(``cfgcpf``, ``cfgcpt``, ``scfgfu``, ``scfgtu``). ATI's Ethernet Axia manuals (9610-05-Ethernet Axia,
section 12) give the same structures.

- Every number travels big-endian ("high byte first").
- Request, 8 bytes: ``uint16 command_header = 0x1234; uint16 command; uint32 sample_count`` (0 = send
  until told to stop). Sent to UDP port 49152; the device answers the address and port it came from.
- Record, 36 bytes: ``uint32 rdt_sequence; uint32 ft_sequence; uint32 status; int32 Fx, Fy, Fz, Tx, Ty,
  Tz`` (counts). ``rdt_sequence`` is 1 for the first record of a request and goes up by one per record
  sent, wrapping to 0 after 2**32 - 1, so a gap is a lost record; ``ft_sequence`` counts the device's
  internal samples (7000 per s) since power-up. Buffered streaming packs several records in a datagram.
- Force = counts / counts per force (``cfgcpf``) in the force unit (``scfgfu``); torque = counts /
  counts per torque (``cfgcpt``) in the torque unit (``scfgtu``).
"""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass

import numpy as np

from ornitail.vehicle.constants import STANDARD_GRAVITY_M_S2

RDT_PORT = 49152
REQUEST_HEADER = 0x1234
COMMAND_STOP_STREAMING = 0x0000
COMMAND_START_REALTIME_STREAMING = 0x0002
COMMAND_START_BUFFERED_STREAMING = 0x0003
COMMAND_START_MULTI_UNIT_STREAMING = 0x0004
COMMAND_RESET_THRESHOLD_LATCH = 0x0041
COMMAND_SET_SOFTWARE_BIAS = 0x0042
INFINITE_SAMPLES = 0
REQUEST_LENGTH = 8
RECORD_LENGTH = 36
INTERNAL_SAMPLE_RATE_HZ = 7000.0
"""The Net F/T samples internally at 7000 Hz; ``ft_sequence`` counts those samples; RDT streams up to it."""
SEQUENCE_MODULUS = 2**32
XML_PAGE = "/netftapi2.xml"

_REQUEST = struct.Struct(">HHI")
RECORD_DTYPE = np.dtype(
    [
        ("rdt_sequence", ">u4"),
        ("ft_sequence", ">u4"),
        ("status", ">u4"),
        ("counts", ">i4", (6,)),
    ]
)
assert RECORD_DTYPE.itemsize == RECORD_LENGTH

# Unit names as the device spells them in scfgfu / scfgtu (compared without case, hyphens or spaces)
# -> factor to N and to N m.
FORCE_UNITS_TO_N = {
    "lbf": 4.4482216152605,
    "n": 1.0,
    "klbf": 4448.2216152605,
    "kn": 1000.0,
    "kgf": STANDARD_GRAVITY_M_S2,
    "kg": STANDARD_GRAVITY_M_S2,
    "gf": 0.00980665,
    "g": 0.00980665,
}
TORQUE_UNITS_TO_N_M = {
    "lbfin": 0.112984829027617,
    "lbfft": 1.3558179483314,
    "nm": 1.0,
    "nmm": 0.001,
    "kgfcm": 0.0980665,
    "kgcm": 0.0980665,
    "knm": 1000.0,
}


def encode_request(command: int, sample_count: int = INFINITE_SAMPLES) -> bytes:
    """The 8-byte RDT request for ``command`` (e.g. ``COMMAND_START_REALTIME_STREAMING``)."""
    if not 0 <= command <= 0xFFFF or not 0 <= sample_count < SEQUENCE_MODULUS:
        raise ValueError(
            f"command {command:#x} must fit 16 bits and sample count {sample_count} 32"
        )
    return _REQUEST.pack(REQUEST_HEADER, command, sample_count)


def decode_request(data: bytes) -> tuple[int, int]:
    """``(command, sample_count)`` of an RDT request; ValueError for a wrong length or header."""
    if len(data) != REQUEST_LENGTH:
        raise ValueError(f"an RDT request has {REQUEST_LENGTH} bytes, got {len(data)}")
    header, command, sample_count = _REQUEST.unpack(data)
    if header != REQUEST_HEADER:
        raise ValueError(f"RDT request header {header:#06x} is not {REQUEST_HEADER:#06x}")
    return command, sample_count


@dataclass
class RdtRecords:
    """Consecutive RDT records.

    rdt_sequence, ft_sequence, status : (n,) uint32. counts : (n, 6) int32, Fx Fy Fz Tx Ty Tz in counts
    (sensor frame; after the device's tool transform, if one is configured).
    """

    rdt_sequence: np.ndarray
    ft_sequence: np.ndarray
    status: np.ndarray
    counts: np.ndarray


def encode_records(records: RdtRecords) -> bytes:
    """The records back to back, 36 bytes each (one per datagram in real-time streaming)."""
    array = np.empty(len(records.rdt_sequence), dtype=RECORD_DTYPE)
    array["rdt_sequence"] = records.rdt_sequence
    array["ft_sequence"] = records.ft_sequence
    array["status"] = records.status
    array["counts"] = records.counts
    return array.tobytes()


def decode_records(data: bytes | bytearray | memoryview) -> RdtRecords:
    """Decode a whole number of 36-byte records (ValueError otherwise) into native-endian arrays."""
    if len(data) % RECORD_LENGTH:
        raise ValueError(
            f"{len(data)} bytes is not a whole number of {RECORD_LENGTH}-byte RDT records"
        )
    array = np.frombuffer(data, dtype=RECORD_DTYPE)
    return RdtRecords(
        rdt_sequence=array["rdt_sequence"].astype(np.uint32),
        ft_sequence=array["ft_sequence"].astype(np.uint32),
        status=array["status"].astype(np.uint32),
        counts=array["counts"].astype(np.int32),
    )


def sequence_steps(later: np.ndarray | int, earlier: np.ndarray | int) -> np.ndarray:
    """How many records ``later`` is after ``earlier`` (``rdt_sequence`` numbers, wrapping at 2**32), as int64 in
    (-2**31, 2**31]: negative for a number the device sent before."""
    offsets = (
        np.asarray(later, dtype=np.int64) - np.asarray(earlier, dtype=np.int64)
    ) % SEQUENCE_MODULUS
    return np.where(offsets > SEQUENCE_MODULUS // 2, offsets - SEQUENCE_MODULUS, offsets)


def lost_records(rdt_sequence: np.ndarray, previous: int) -> int:
    """Records skipped as the newest sequence number advances from ``previous`` through ``rdt_sequence`` (uint32,
    wrapping at 2**32).

    ``previous`` is the newest sequence number received before (:func:`newest_sequence`), or 0 before the first
    record of a request (the device numbers a request's records from 1). A repeat, or a record that arrives after
    a later one (a duplicated or reordered datagram), moves nothing: the hole it fills was counted once, when the
    later record skipped it.
    """
    ahead = _steps_ahead(rdt_sequence, previous)
    newest_before = np.maximum.accumulate(np.concatenate(([0], ahead)))[:-1]
    advances = ahead - newest_before
    return int(np.sum(advances[advances > 1] - 1))


def newest_sequence(rdt_sequence: np.ndarray, previous: int) -> int:
    """The newest sequence number of ``previous`` and ``rdt_sequence`` (wrapping at 2**32)."""
    furthest = max(0, int(_steps_ahead(rdt_sequence, previous).max(initial=0)))
    return (int(previous) + furthest) % SEQUENCE_MODULUS


def _steps_ahead(rdt_sequence: np.ndarray, previous: int) -> np.ndarray:
    """(n,) int64: how many records after ``previous`` each sequence number is (negative: before it)."""
    return sequence_steps(rdt_sequence.astype(np.int64), np.int64(previous))


def in_sequence_order(records: RdtRecords) -> RdtRecords:
    """``records`` sorted by ``rdt_sequence`` (wrapping at 2**32, counted from the first record): datagrams a
    network delivered out of order within one block are put back in the order the device sent them."""
    order = np.argsort(sequence_steps(records.rdt_sequence, records.rdt_sequence[0]), kind="stable")
    return RdtRecords(
        rdt_sequence=records.rdt_sequence[order],
        ft_sequence=records.ft_sequence[order],
        status=records.status[order],
        counts=records.counts[order],
    )


def normalised_unit(name: str) -> str:
    """A unit name without case, hyphens, dots or spaces: ``"N-m"`` and ``"Nm"`` -> ``"nm"``."""
    return "".join(character for character in name.lower() if character not in "-. \u00b7")


@dataclass(frozen=True)
class CountsPerUnit:
    """The device's scaling: counts per force unit and per torque unit, and those units' names."""

    counts_per_force: float
    counts_per_torque: float
    force_unit: str = "N"
    torque_unit: str = "Nm"

    def __post_init__(self) -> None:
        for label, value in (("force", self.counts_per_force), ("torque", self.counts_per_torque)):
            if not np.isfinite(value) or value <= 0:
                raise ValueError(
                    f"counts per {label} unit must be a positive number, got {value!r}"
                )
        if normalised_unit(self.force_unit) not in FORCE_UNITS_TO_N:
            raise ValueError(f"unknown force unit {self.force_unit!r}")
        if normalised_unit(self.torque_unit) not in TORQUE_UNITS_TO_N_M:
            raise ValueError(f"unknown torque unit {self.torque_unit!r}")

    def si_per_count(self) -> np.ndarray:
        """(6,) N per count for Fx, Fy, Fz and N m per count for Tx, Ty, Tz."""
        newton = FORCE_UNITS_TO_N[normalised_unit(self.force_unit)] / self.counts_per_force
        newton_metre = (
            TORQUE_UNITS_TO_N_M[normalised_unit(self.torque_unit)] / self.counts_per_torque
        )
        return np.array([newton] * 3 + [newton_metre] * 3)

    def to_si(self, counts: np.ndarray) -> np.ndarray:
        """(n, 6) counts -> (n, 6) float64 Fx Fy Fz in N and Tx Ty Tz in N m (sensor frame)."""
        return np.asarray(counts, dtype=np.float64) * self.si_per_count()

    def to_counts(self, wrench_si: np.ndarray) -> np.ndarray:
        """(n, 6) N and N m -> (n, 6) int32 counts, rounded to the nearest count and clipped to int32."""
        counts = np.rint(np.asarray(wrench_si, dtype=np.float64) / self.si_per_count())
        limits = np.iinfo(np.int32)
        return np.clip(counts, limits.min, limits.max).astype(np.int32)


def parse_netftapi2(xml_text: str | bytes) -> CountsPerUnit:
    """Counts per unit and units from the device's ``netftapi2.xml`` (elements ``cfgcpf``, ``cfgcpt``,
    ``scfgfu``, ``scfgtu`` anywhere below the root). ValueError naming what is missing or malformed."""
    try:
        root = ElementTree.fromstring(xml_text)
    except ElementTree.ParseError as error:
        raise ValueError(f"netftapi2.xml is not well-formed XML ({error})") from None
    values: dict[str, str] = {}
    for name in ("cfgcpf", "cfgcpt", "scfgfu", "scfgtu"):
        element = root.find(f".//{name}")
        text = (element.text or "").strip() if element is not None else ""
        if not text:
            raise ValueError(f"netftapi2.xml has no <{name}> value")
        values[name] = text
    try:
        counts_per_force = float(values["cfgcpf"])
        counts_per_torque = float(values["cfgcpt"])
    except ValueError:
        raise ValueError(
            f"netftapi2.xml counts per unit are not numbers: cfgcpf={values['cfgcpf']!r}, "
            f"cfgcpt={values['cfgcpt']!r}"
        ) from None
    return CountsPerUnit(counts_per_force, counts_per_torque, values["scfgfu"], values["scfgtu"])


def format_netftapi2(scaling: CountsPerUnit, *, extra: dict[str, str] | None = None) -> str:
    """A ``netftapi2.xml`` page (root ``<netft>``) carrying ``scaling``; ``extra`` adds elements."""
    root = ElementTree.Element("netft")
    fields = {
        "cfgcpf": _xml_number(scaling.counts_per_force),
        "cfgcpt": _xml_number(scaling.counts_per_torque),
        "scfgfu": scaling.force_unit,
        "scfgtu": scaling.torque_unit,
        **(extra or {}),
    }
    for name, text in fields.items():
        ElementTree.SubElement(root, name).text = text
    return '<?xml version="1.0"?>' + ElementTree.tostring(root, encoding="unicode")


def _xml_number(value: float) -> str:
    """``1000000.0`` -> ``"1000000"`` as the device writes it; other values in full precision."""
    return str(int(value)) if float(value).is_integer() else repr(float(value))
