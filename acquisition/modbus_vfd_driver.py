"""The ``modbus_vfd`` fan backend: a variable-frequency drive over Modbus RTU (docs/instrument-protocols.md).

The drive is run and stopped through its control register and given a frequency set point; its output frequency
is read back. Velocity (m/s) -> fan rpm (tunnel table) -> drive frequency (``fan_rpm_per_hz``) -> register counts
(``frequency_scale_hz_per_count``). The register map comes from ``[fan.modbus]``; its defaults are the address
list of Delta's VFD-E/VFD-ED/MS300 drives (2000H control, 2001H frequency command in 0.01 Hz, 2102H frequency
command and 2103H output frequency read back), which docs/instrument-protocols.md cites; set them from your own
drive's manual.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Self

from ornitail.acquisition.actuator_interfaces import (
    ActuatorContext,
    ConnectedOverOnePort,
    Reading,
    TunnelFan,
)
from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.acquisition.modbus_rtu import MAX_UNIT_ID, MIN_UNIT_ID
from ornitail.acquisition.modbus_rtu_connection import PARITIES, ModbusRtuConnection
from ornitail.core.errors import UserInputError, require_finite
from ornitail.core.toml_table import TomlTable

MODBUS_VFD = "modbus_vfd"


@dataclass(frozen=True)
class ModbusVfdSettings:
    """``[fan.modbus]``: the drive's address, serial framing and register map.

    Registers are zero-based protocol addresses (the manual's ``2001H`` is ``0x2001``); frequencies in Hz.
    """

    unit_id: int = 1
    parity: str = "N"
    stop_bits: int = 2
    control_register: int = 0x2000
    run_command: int = 0x0002
    stop_command: int = 0x0001
    frequency_setpoint_register: int = 0x2001
    frequency_scale_hz_per_count: float = 0.01
    frequency_command_register: int = 0x2102
    output_frequency_register: int = 0x2103
    fan_rpm_per_hz: float = 0.0
    """Fan speed per hertz of drive output, rev/min/Hz (required in the rig file)."""

    @classmethod
    def from_table(cls, table: TomlTable) -> ModbusVfdSettings:
        """Check ``[fan.modbus]``; every mistake names the file, table and key."""
        defaults = cls()

        def register(key: str) -> int:
            return table.integer(key, getattr(defaults, key), minimum=0, maximum=0xFFFF)

        parity = table.text("parity", defaults.parity, choices=tuple(PARITIES))
        stop_bits = table.integer("stop_bits", defaults.stop_bits, minimum=1, maximum=2)
        return cls(
            unit_id=table.integer(
                "unit_id", defaults.unit_id, minimum=MIN_UNIT_ID, maximum=MAX_UNIT_ID
            ),
            parity=parity,
            stop_bits=stop_bits,
            control_register=register("control_register"),
            run_command=register("run_command"),
            stop_command=register("stop_command"),
            frequency_setpoint_register=register("frequency_setpoint_register"),
            frequency_scale_hz_per_count=table.number(
                "frequency_scale_hz_per_count", defaults.frequency_scale_hz_per_count, positive=True
            ),
            frequency_command_register=register("frequency_command_register"),
            output_frequency_register=register("output_frequency_register"),
            fan_rpm_per_hz=table.number("fan_rpm_per_hz", positive=True),
        )


MODBUS_SETTINGS_KEYS = frozenset(ModbusVfdSettings.__dataclass_fields__)


@dataclass(frozen=True)
class VfdStatus:
    """What the drive reports: its frequency command and its output frequency, Hz."""

    frequency_command_hz: float
    output_frequency_hz: float


class ModbusVfdTunnelFan(ConnectedOverOnePort, TunnelFan):
    """Tunnel fan on a variable-frequency drive speaking Modbus RTU.

    Parameters
    ----------
    port : str
        Serial device or pty path.
    settings : ModbusVfdSettings
        Address, framing, register map and ``fan_rpm_per_hz``.
    speed_map : FanSpeedMap
        Velocity <-> rpm <-> frequency (its ``fan_rpm_per_hz`` is the settings').
    max_fan_rpm : float
        Fan speed at the rig's velocity limit, rev/min (set points above are refused before sending).
    """

    backend: ClassVar[str] = MODBUS_VFD
    settings_table: ClassVar[str | None] = "modbus"
    settings_keys: ClassVar[frozenset[str]] = MODBUS_SETTINGS_KEYS
    default_baud: ClassVar[int] = 9600

    def __init__(
        self,
        port: str,
        *,
        settings: ModbusVfdSettings,
        speed_map: FanSpeedMap,
        max_fan_rpm: float,
        name: str = "tunnel fan",
        baud: int = 9600,
        reply_timeout_s: float = 1.0,
    ) -> None:
        self.name = name
        self.settings = settings
        self.speed_map = speed_map
        self.max_frequency_hz = speed_map.frequency_hz_for_rpm(max_fan_rpm)
        self.connection = ModbusRtuConnection(
            port,
            name=name,
            unit_id=settings.unit_id,
            baud=baud,
            parity=settings.parity,
            stop_bits=settings.stop_bits,
            reply_timeout_s=reply_timeout_s,
        )

    @classmethod
    def read_settings(cls, table: TomlTable) -> ModbusVfdSettings:
        return ModbusVfdSettings.from_table(table)

    @classmethod
    def from_rig(cls, context: ActuatorContext) -> Self:
        settings: ModbusVfdSettings = context.settings
        return cls(
            context.port,
            settings=settings,
            speed_map=FanSpeedMap(context.tunnel_table, settings.fan_rpm_per_hz),
            max_fan_rpm=context.max_fan_rpm,
            name=context.name,
            baud=context.baud,
            reply_timeout_s=context.reply_timeout_s,
        )

    # -- connection -------------------------------------------------------------------------
    def open(self) -> str:
        """Open the port and read the drive's frequency registers (a drive that answers them is identified)."""
        self.connection.open()
        try:
            status = self.read_status()
        except BaseException:
            self.connection.close()
            raise
        return (
            f"Modbus RTU unit {self.settings.unit_id}: frequency command "
            f"{status.frequency_command_hz:.2f} Hz, output {status.output_frequency_hz:.2f} Hz"
        )

    def close(self) -> None:
        self.connection.close()

    # -- commands ---------------------------------------------------------------------------
    def safe_state(self) -> None:
        """Write the stop command, then a zero frequency set point (each write confirmed by its echo)."""
        settings = self.settings
        self.connection.write_register(settings.control_register, settings.stop_command)
        self.connection.write_register(settings.frequency_setpoint_register, 0)

    def set_frequency_hz(self, frequency_hz: float) -> None:
        """Set the drive's frequency (Hz) and run it (stop it at 0); refused above the rig limit before sending."""
        require_finite("frequency_hz", frequency_hz)
        if not 0.0 <= frequency_hz <= self.max_frequency_hz * (1 + 1e-9):
            raise UserInputError(
                "frequency_hz",
                f"{frequency_hz:g} Hz is outside the rig limit 0..{self.max_frequency_hz:g} Hz ({self.name})",
            )
        settings = self.settings
        counts = round(frequency_hz / settings.frequency_scale_hz_per_count)
        if counts > 0xFFFF:
            raise UserInputError(
                "frequency_hz",
                f"{frequency_hz:g} Hz is {counts} counts of {settings.frequency_scale_hz_per_count:g} Hz, "
                f"more than a 16-bit register holds ({self.name})",
            )
        self.connection.write_register(settings.frequency_setpoint_register, counts)
        command = settings.run_command if counts > 0 else settings.stop_command
        self.connection.write_register(settings.control_register, command)

    def set_velocity(self, velocity_m_s: float) -> None:
        require_finite("velocity_m_s", velocity_m_s)
        fan_rpm = self.speed_map.rpm_for_velocity(velocity_m_s)
        self.set_frequency_hz(
            min(self.speed_map.frequency_hz_for_rpm(fan_rpm), self.max_frequency_hz)
        )

    def read_status(self) -> VfdStatus:
        """Frequency command and output frequency, Hz (one read when the two registers are adjacent)."""
        settings = self.settings
        command_register = settings.frequency_command_register
        output_register = settings.output_frequency_register
        if output_register == command_register + 1:
            command, output = self.connection.read_registers(command_register, 2)
        else:
            (command,) = self.connection.read_registers(command_register, 1)
            (output,) = self.connection.read_registers(output_register, 1)
        scale = settings.frequency_scale_hz_per_count
        return VfdStatus(command * scale, output * scale)

    def read_output_frequency_hz(self) -> float:
        """The drive's output frequency, Hz."""
        (counts,) = self.connection.read_registers(self.settings.output_frequency_register, 1)
        return counts * self.settings.frequency_scale_hz_per_count

    def read_velocity_m_s(self) -> float:
        return self.speed_map.velocity_for_frequency_hz(self.read_output_frequency_hz())

    def check_reading(self) -> Reading:
        status = self.read_status()
        return {
            "frequency_command_hz": status.frequency_command_hz,
            "output_frequency_hz": status.output_frequency_hz,
            "fan_rpm": self.speed_map.rpm_for_frequency_hz(status.output_frequency_hz),
        }
