"""Reading and checking a rig file (TOML): instruments, ports, calibration files, safety limits.

The format is documented in ``docs/rig-file.md``. Every mistake raises ``UserInputError`` naming the
file and the field (``rig.toml: [limits].pitch_deg``). Paths inside the file are relative to the rig
file's folder. Unknown sections and keys are refused, so a typo cannot silently drop a limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ornitail.acquisition.actuator_backends import DEFAULT_BACKEND, backend_class
from ornitail.acquisition.actuator_interfaces import Actuator
from ornitail.acquisition.daq_protocol import (
    DEFAULT_BAUD,
    DEFAULT_SAMPLE_RATE_HZ,
    link_ceiling_frames_per_s,
)
from ornitail.acquisition.netcanoem_protocol import DEFAULT_BASE_ID, gauge_sample_rate_ceiling_hz
from ornitail.acquisition.netft_driver import NetFtSettings, netft_settings_from_table
from ornitail.acquisition.netft_protocol import INTERNAL_SAMPLE_RATE_HZ
from ornitail.calibration.tool_transform import ToolTransform
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_toml_file
from ornitail.core.toml_table import REQUIRED, TomlTable
from ornitail.vehicle.constants import DELFLY_GEAR_RATIO

DEFAULT_RIG_FILE = Path(__file__).parent / "data" / "simulated_rig.toml"
BALANCE_ROUTES = ("serial_daq", "can", "netft")
GAUGE_ONLY_ROUTES = ("can", "netft")
"""Balances that carry only the gauges: the auxiliary board (``[balance.aux_daq]``) may stand beside them."""
MIN_BAUD = 1200
"""Slowest serial line rate accepted, bit/s."""
MAX_BAUD = 12_000_000
"""Fastest serial line rate accepted, bit/s (the fastest USB-serial bridges, e.g. FTDI FT2232H)."""

_ALLOWED_KEYS = {
    "rig": {"name", "simulated", "time_scale", "seed", "simulator_control"},
    "balance": {
        "route",
        "calibration",
        "tool_transform_mm_deg",
        "serial_daq",
        "can",
        "netft",
        "aux_daq",
    },
    "balance.serial_daq": {"port", "baud", "sample_rate_hz"},
    "balance.aux_daq": {"port", "baud", "sample_rate_hz"},
    "balance.can": {"interface", "channel", "bit_rate", "base_id", "sample_rate_hz"},
    "tunnel": {"table", "hotwire_law"},
    "fan": {"port", "baud", "backend"},
    "strut": {"port", "baud", "backend"},
    "motor": {"port", "baud", "backend", "gear_ratio"},
    "limits": {"pitch_deg", "velocity_m_s", "flapping_frequency_hz", "max_motor_rpm"},
}
_REQUIRED_SECTIONS = ("rig", "balance", "tunnel", "fan", "strut", "motor", "limits")


@dataclass(frozen=True)
class SerialDaqSettings:
    """``[balance.serial_daq]``: port, baud and sample rate (Hz) of the ORNI-DAQ9 board."""

    port: str
    baud: int
    sample_rate_hz: float


@dataclass(frozen=True)
class CanSettings:
    """``[balance.can]``: python-can interface, channel, bit rate (bit/s), base id, rate (Hz)."""

    interface: str
    channel: str
    bit_rate: int
    base_id: int
    sample_rate_hz: float


@dataclass(frozen=True)
class ActuatorSettings:
    """``[fan]``, ``[strut]`` or ``[motor]``: port, baud, backend name and class, and the backend's checked
    sub-table (``[fan.modbus]``; None for a backend without one)."""

    port: str
    baud: int
    backend: str
    backend_class: type[Actuator]
    settings: Any = None


@dataclass(frozen=True)
class SafetyLimits:
    """``[limits]`` in SI: pitch (rad), velocity (m/s), flapping frequency (Hz), motor rpm."""

    pitch_min_rad: float
    pitch_max_rad: float
    velocity_min_m_s: float
    velocity_max_m_s: float
    flapping_frequency_min_hz: float
    flapping_frequency_max_hz: float
    max_motor_rpm: float


@dataclass(frozen=True)
class RigDescription:
    """Everything a rig file says, checked, with paths made absolute."""

    path: Path
    name: str
    simulated: bool
    time_scale: float
    seed: int
    balance_route: str
    calibration_path: Path
    tool_transform: ToolTransform
    serial_daq: SerialDaqSettings
    can: CanSettings
    tunnel_table_path: Path
    fan: ActuatorSettings
    strut: ActuatorSettings
    motor: ActuatorSettings
    gear_ratio: float
    limits: SafetyLimits
    simulator_control: Path | None = None
    """Control socket of simulated instruments served by another process (``rig_simulator_server``), or None."""
    hotwire_law_path: Path | None = None
    """``[tunnel].hotwire_law``: the rig's hot-wire calibration (a law file of ``ornitail calibrate hotwire``), or
    None."""
    aux_daq: SerialDaqSettings | None = None
    """``[balance.aux_daq]``: the ORNI-DAQ9 board as auxiliary acquisition beside a CAN or Net F/T balance, or
    None."""
    netft: NetFtSettings | None = None
    """``[balance.netft]``: the Net F/T's address, ports, RDT rate and scaling (route ``netft``), else None."""

    @property
    def simulation(self) -> tuple[str, str] | None:
        """The simulation backend this rig file chooses and the field that chooses it: ``("simulated",
        "[rig].simulated")`` or ``("simulator_server", "[rig].simulator_control")``; None for real instruments."""
        if self.simulated:
            return "simulated", "[rig].simulated"
        if self.simulator_control is not None:
            return "simulator_server", "[rig].simulator_control"
        return None

    @property
    def simulation_setting(self) -> str:
        """The value of the field that chooses the simulation, as text: the control socket's path, or ``true``."""
        return "true" if self.simulated else str(self.simulator_control)

    @property
    def carries_flap_channels(self) -> bool:
        """True when the balance stream holds the Hall line, hot-wire and thermocouple (what a sweep records):
        the ORNI-DAQ9 balance, or a CAN or Net F/T balance with ``[balance.aux_daq]``."""
        return self.balance_route == "serial_daq" or self.aux_daq is not None

    def balance_sample_rate_hz(self) -> float:
        """The rate of the balance stream's rows the rig file sets, samples/s: the ORNI-DAQ9's, the auxiliary
        board's beside a CAN or Net F/T balance (rows on its grid, the balance at its own rate), or the CAN
        polling rate or the Net F/T's RDT rate alone."""
        if self.balance_route == "serial_daq":
            return self.serial_daq.sample_rate_hz
        if self.aux_daq is not None:
            return self.aux_daq.sample_rate_hz
        if self.netft is not None:
            return self.netft.rdt_rate_hz
        return self.can.sample_rate_hz

    def balance_sample_rate_ceiling_hz(self) -> float:
        """The highest row rate of the balance stream: the serial line's frames/s of the board that carries the
        Hall line, or for a balance alone the CAN polling ceiling or the Net F/T's 7000 records/s."""
        if self.balance_route == "serial_daq":
            return link_ceiling_frames_per_s(self.serial_daq.baud)
        if self.aux_daq is not None:
            return link_ceiling_frames_per_s(self.aux_daq.baud)
        if self.netft is not None:
            return INTERNAL_SAMPLE_RATE_HZ
        return gauge_sample_rate_ceiling_hz(self.can.bit_rate, worst_case_stuffing=False)


def _fields(path: Path, section: str, table: Any) -> TomlTable:
    """One table of the rig file, checked against the keys it may have."""
    return TomlTable(path, section, table, _ALLOWED_KEYS[section])


def _tool_transform(table: TomlTable, key: str) -> ToolTransform:
    values = table.numbers(key, 6, "[dx, dy, dz (mm), rx, ry, rz (deg)]", default=[0.0] * 6)
    return ToolTransform.from_mm_deg(*values)


def _actuator(
    path: Path, role: str, table: Any, simulated: bool
) -> tuple[TomlTable, ActuatorSettings]:
    """``[fan]``, ``[strut]`` or ``[motor]``: the backend named (built-in or installed), then the keys it allows
    (its own sub-table, e.g. ``[fan.modbus]``, checked by the backend class)."""
    everything = table if isinstance(table, dict) else {}
    backend_name = TomlTable(path, role, table, everything).text("backend", DEFAULT_BACKEND)
    where = f"{path}: [{role}].backend"
    backend = backend_class(role, backend_name, where)
    sub_table = backend.settings_table
    fields = TomlTable(
        path, role, table, _ALLOWED_KEYS[role] | ({sub_table} if sub_table else set())
    )
    settings = None
    if sub_table:
        raw = fields.table.get(sub_table, {})
        sub_fields = TomlTable(path, f"{role}.{sub_table}", raw, backend.settings_keys)
        try:
            settings = backend.read_settings(sub_fields)
        except UserInputError:
            raise
        except (
            Exception
        ) as error:  # a third party's settings reader failing: one line, not its traceback
            raise UserInputError(
                f"{path}: [{role}.{sub_table}]",
                f"backend {backend_name!r} could not read it: {type(error).__name__}: {error}",
            ) from None
    return fields, ActuatorSettings(
        port=fields.text("port", "simulated" if simulated else REQUIRED),
        baud=fields.integer("baud", backend.default_baud, minimum=MIN_BAUD, maximum=MAX_BAUD),
        backend=backend_name,
        backend_class=backend,
        settings=settings,
    )


def _aux_daq(
    path: Path, balance: TomlTable, route: str, simulated: bool
) -> SerialDaqSettings | None:
    """``[balance.aux_daq]``: the serial board beside a CAN or Net F/T balance (None when absent)."""
    if "aux_daq" not in balance.table:
        return None
    if route not in GAUGE_ONLY_ROUTES:
        raise UserInputError(
            f"{path}: [balance.aux_daq]",
            f"only beside a CAN or Net F/T balance; route {route!r} carries the Hall line, hot-wire and "
            "thermocouple itself",
        )
    aux = _fields(path, "balance.aux_daq", balance.table["aux_daq"])
    settings = SerialDaqSettings(
        port=aux.text("port", "simulated" if simulated else REQUIRED),
        baud=aux.integer("baud", DEFAULT_BAUD, minimum=MIN_BAUD, maximum=MAX_BAUD),
        sample_rate_hz=aux.number("sample_rate_hz", DEFAULT_SAMPLE_RATE_HZ, positive=True),
    )
    if settings.sample_rate_hz > link_ceiling_frames_per_s(settings.baud):
        raise UserInputError(
            aux.where("sample_rate_hz"),
            f"{settings.sample_rate_hz:g} Hz exceeds the serial link ceiling "
            f"{link_ceiling_frames_per_s(settings.baud):g} Hz at {settings.baud} baud",
        )
    return settings


def read_rig_file(path: str | Path) -> RigDescription:
    """Read and check a rig file; see ``docs/rig-file.md``."""
    path = Path(path)
    document = read_toml_file(path)
    unknown = sorted(set(document) - set(_REQUIRED_SECTIONS))
    if unknown:
        raise UserInputError(
            f"{path}: [{unknown[0]}]", f"unknown section; allowed: {', '.join(_REQUIRED_SECTIONS)}"
        )
    for section in _REQUIRED_SECTIONS:
        if section not in document:
            raise UserInputError(f"{path}: [{section}]", "section missing")

    rig = _fields(path, "rig", document["rig"])
    balance = _fields(path, "balance", document["balance"])
    route = balance.text("route", choices=BALANCE_ROUTES)
    simulated = rig.boolean("simulated", False)
    simulator_control = None
    if "simulator_control" in rig.table:
        simulator_control = (path.parent / rig.text("simulator_control")).resolve()
        if simulated:
            raise UserInputError(
                rig.where("simulator_control"),
                "a rig served by an external simulator connects to its ports: set simulated = false",
            )
    daq = _fields(path, "balance.serial_daq", balance.table.get("serial_daq", {}))
    can = _fields(path, "balance.can", balance.table.get("can", {}))
    needs_daq = route == "serial_daq"
    needs_can = route == "can"
    serial_daq = SerialDaqSettings(
        port=daq.text("port", "simulated" if simulated or not needs_daq else REQUIRED),
        baud=daq.integer("baud", DEFAULT_BAUD, minimum=MIN_BAUD, maximum=MAX_BAUD),
        sample_rate_hz=daq.number("sample_rate_hz", DEFAULT_SAMPLE_RATE_HZ, positive=True),
    )
    can_settings = CanSettings(
        interface=can.text("interface", "virtual" if simulated or not needs_can else REQUIRED),
        channel=can.text("channel", "ornitail-rig" if simulated or not needs_can else REQUIRED),
        bit_rate=can.integer("bit_rate", 1_000_000, minimum=10_000, maximum=2_000_000),
        base_id=can.integer("base_id", DEFAULT_BASE_ID, minimum=0, maximum=0x7F),
        sample_rate_hz=can.number("sample_rate_hz", 1000.0, positive=True),
    )
    if needs_daq and serial_daq.sample_rate_hz > link_ceiling_frames_per_s(serial_daq.baud):
        raise UserInputError(
            daq.where("sample_rate_hz"),
            f"{serial_daq.sample_rate_hz:g} Hz exceeds the serial link ceiling "
            f"{link_ceiling_frames_per_s(serial_daq.baud):g} Hz at {serial_daq.baud} baud",
        )
    can_ceiling = gauge_sample_rate_ceiling_hz(can_settings.bit_rate, worst_case_stuffing=False)
    if needs_can and can_settings.sample_rate_hz > can_ceiling:
        raise UserInputError(
            can.where("sample_rate_hz"),
            f"{can_settings.sample_rate_hz:g} samples/s exceeds the CAN ceiling {can_ceiling:.0f} "
            f"samples/s at {can_settings.bit_rate} bit/s",
        )
    aux_daq = _aux_daq(path, balance, route, simulated)
    netft = None
    if route == "netft":
        if "netft" not in balance.table:
            raise UserInputError(f"{path}: [balance.netft]", 'required with route = "netft"')
        netft = netft_settings_from_table(path, balance.table["netft"], simulated=simulated)
    elif "netft" in balance.table:
        raise UserInputError(
            f"{path}: [balance.netft]", f'only with route = "netft" (route is {route!r})'
        )
    tunnel = _fields(path, "tunnel", document["tunnel"])
    fan, fan_settings = _actuator(path, "fan", document["fan"], simulated)
    strut, strut_settings = _actuator(path, "strut", document["strut"], simulated)
    motor, motor_settings = _actuator(path, "motor", document["motor"], simulated)
    limits = _fields(path, "limits", document["limits"])

    pitch_min_deg, pitch_max_deg = limits.interval("pitch_deg")
    velocity_min, velocity_max = limits.interval("velocity_m_s")
    frequency_min, frequency_max = limits.interval("flapping_frequency_hz")
    if velocity_min < 0:
        raise UserInputError(
            limits.where("velocity_m_s"), f"minimum {velocity_min:g} m/s must be >= 0"
        )
    if frequency_min < 0:
        raise UserInputError(
            limits.where("flapping_frequency_hz"), f"minimum {frequency_min:g} Hz must be >= 0"
        )
    return RigDescription(
        path=path.resolve(),
        name=rig.text("name", path.stem),
        simulated=simulated,
        time_scale=rig.number("time_scale", 1.0, positive=True),
        seed=rig.integer("seed", 0),
        balance_route=route,
        calibration_path=balance.file("calibration"),
        tool_transform=_tool_transform(balance, "tool_transform_mm_deg"),
        serial_daq=serial_daq,
        can=can_settings,
        tunnel_table_path=tunnel.file("table"),
        hotwire_law_path=tunnel.file("hotwire_law") if "hotwire_law" in tunnel.table else None,
        fan=fan_settings,
        strut=strut_settings,
        motor=motor_settings,
        gear_ratio=motor.number("gear_ratio", DELFLY_GEAR_RATIO, positive=True),
        limits=SafetyLimits(
            pitch_min_rad=math.radians(pitch_min_deg),
            pitch_max_rad=math.radians(pitch_max_deg),
            velocity_min_m_s=velocity_min,
            velocity_max_m_s=velocity_max,
            flapping_frequency_min_hz=frequency_min,
            flapping_frequency_max_hz=frequency_max,
            max_motor_rpm=limits.number("max_motor_rpm", positive=True),
        ),
        simulator_control=simulator_control,
        aux_daq=aux_daq,
        netft=netft,
    )
