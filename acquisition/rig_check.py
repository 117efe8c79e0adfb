"""Checking a rig before a run: which ports the machine has, and whether each instrument of a rig file answers.

:func:`check_rig` reads the rig file, reaches the simulated instruments if the rig is simulated, and checks each
instrument on its own, so one that fails does not hide the others: open its port exclusively, identify it, read
one sample, bring it to its safe state (fan stopped, strut halted, motor off, board not streaming), close. Nothing
is moved: the strut is not homed and no set point is sent. An instrument whose identity is not the model its
driver speaks is closed without any further command (two ports swapped in the rig file would otherwise get each
other's commands). The result is plain data (:class:`RigCheck`); ``ornitail rig check`` prints it.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import can
from serial.tools import list_ports

from ornitail.acquisition.actuator_interfaces import Actuator, Reading
from ornitail.acquisition.balance_interface import CheckedDevice
from ornitail.acquisition.instrument_errors import InstrumentError, InstrumentInUse
from ornitail.acquisition.rig import Rig

STATUS_OK, STATUS_FAILED, STATUS_IN_USE = "ok", "failed", "in_use"


@dataclass(frozen=True)
class SerialPortFound:
    """A serial port the operating system lists: device path and its description (USB product, ``n/a``)."""

    device: str
    description: str


@dataclass(frozen=True)
class CanChannelFound:
    """A CAN channel python-can detects: interface (``socketcan``, ``pcan``, ...) and channel (``can0``)."""

    interface: str
    channel: str


@dataclass(frozen=True)
class InstrumentCheck:
    """One instrument as checked.

    ``rig_file_key`` names where the rig file sets its route (``[fan].port``); ``route`` is the port or CAN
    interface:channel used (the simulator's pty on a simulated rig). ``status`` is ``"ok"``, ``"failed"`` or
    ``"in_use"`` (another process holds the port); ``problem`` says what failed, in one line. ``reading`` holds
    the sample read, keyed with its unit (``fan_rpm``, ``pitch_deg``, ``gauge_0_v``).
    """

    instrument: str
    rig_file_key: str
    route: str
    status: str
    identity: str | None = None
    reading: Reading = field(default_factory=dict)
    problem: str | None = None

    @property
    def ok(self) -> bool:
        """True when the instrument was identified, read and brought to its safe state."""
        return self.status == STATUS_OK


@dataclass(frozen=True)
class RigCheck:
    """What :func:`check_rig` found: the ports of this machine and one :class:`InstrumentCheck` per instrument."""

    rig_file: Path
    rig_name: str
    simulated: bool
    serial_ports: list[SerialPortFound]
    can_interfaces_searched: list[str]
    can_channels: list[CanChannelFound]
    instruments: list[InstrumentCheck]

    @property
    def ok(self) -> bool:
        """True when every instrument is ok."""
        return all(check.ok for check in self.instruments)


def serial_ports_found() -> list[SerialPortFound]:
    """The serial ports the operating system lists (pyserial's ``list_ports``), sorted by device path."""
    return sorted(
        (SerialPortFound(port.device, port.description) for port in list_ports.comports()),
        key=lambda port: port.device,
    )


def can_channels_found(interfaces: list[str]) -> list[CanChannelFound]:
    """The CAN channels python-can detects on ``interfaces`` (an interface it cannot load finds none)."""
    found = can.detect_available_configs(interfaces=interfaces)
    return sorted(
        {CanChannelFound(str(config["interface"]), str(config["channel"])) for config in found},
        key=lambda channel: (channel.interface, channel.channel),
    )


def _can_interfaces_to_search(rig: Rig) -> list[str]:
    """socketcan on Linux and the rig file's CAN interface (python-can's in-process ``virtual`` bus is not hardware)."""
    interfaces = {"socketcan"} if sys.platform.startswith("linux") else set()
    if rig.description.balance_route == "can":
        interfaces.add(rig.description.can.interface)
    interfaces.discard("virtual")
    return sorted(interfaces)


def check_rig(rig_path: str | Path) -> RigCheck:
    """Check every instrument of the rig file ``rig_path`` (see the module docstring).

    Raises
    ------
    UserInputError
        A mistake in the rig file or the files it names (nothing is opened).
    """
    rig = Rig.from_file(rig_path)
    description = rig.description
    checks: list[InstrumentCheck] = []
    try:
        simulator = _start_simulation(rig)
        if (
            simulator is not None
        ):  # reached through a link of its own (a server's control socket): checked too
            checks.append(simulator)
        checks += _check_instruments(rig)
    finally:
        rig.close(raise_errors=False)
    can_interfaces = _can_interfaces_to_search(rig)
    return RigCheck(
        rig_file=description.path,
        rig_name=description.name,
        simulated=description.simulation is not None,
        serial_ports=serial_ports_found(),
        can_interfaces_searched=can_interfaces,
        can_channels=can_channels_found(can_interfaces),
        instruments=checks,
    )


def _start_simulation(rig: Rig) -> InstrumentCheck | None:
    """Reach the rig's simulated instruments (nothing for real ones): the check of the link they were reached
    through, when their backend names one (a simulator server's control socket), else None."""
    try:
        rig.start_simulation()
    except InstrumentError as error:
        _, key = rig.description.simulation
        return InstrumentCheck(
            error.instrument_name,
            key,
            rig.description.simulation_setting,
            STATUS_FAILED,
            problem=error.problem,
        )
    link = rig.simulators.link() if rig.simulators is not None else None
    if link is None:
        return None
    return InstrumentCheck(
        link.name,
        link.rig_file_key,
        link.route,
        STATUS_OK,
        identity=link.identity,
        reading=link.reading,
    )


def _check_instruments(rig: Rig) -> list[InstrumentCheck]:
    """One row per device behind the balance (a gauge balance and the board beside it: one each), then the fan,
    strut and motor."""
    fan, motor, strut, balance = rig.create_drivers()
    return [
        *(_check_balance_device(device) for device in balance.checked_devices()),
        _check_actuator(fan, "[fan].port"),
        _check_actuator(strut, "[strut].port"),
        _check_actuator(motor, "[motor].port"),
    ]


def _refused(route: str, key: str, name: str, error: InstrumentError) -> InstrumentCheck:
    status = STATUS_IN_USE if isinstance(error, InstrumentInUse) else STATUS_FAILED
    return InstrumentCheck(name, key, route, status, problem=error.problem)


def _read_then_make_safe(
    read: Callable[[], Reading], make_safe: Callable[[], None]
) -> tuple[Reading, str | None]:
    """Read one sample, then bring the instrument to its safe state whatever happened; (reading, problem)."""
    reading: Reading = {}
    problems: list[str] = []
    try:
        reading = read()
    except InstrumentError as error:
        problems.append(error.problem)
    try:
        make_safe()
    except InstrumentError as error:
        problems.append(f"safe state not confirmed: {error.problem}")
    return reading, "; ".join(problems) or None


def _check_actuator(driver: Actuator, key: str) -> InstrumentCheck:
    """Open and identify (ORNI ``ID?``, Modbus frequency registers, Zaber ``get device.id``), one reading, the safe
    state (stop, hold, off), close; whatever the backend, through the actuator interface."""
    route = driver.route
    try:
        reply = driver.open()
    except InstrumentError as error:
        return _refused(route, key, driver.name, error)
    try:
        identity = identity_text(reply)
        problem = driver.identity_problem(reply, key)
        if problem is not None:
            return InstrumentCheck(
                driver.name, key, route, STATUS_FAILED, identity, problem=problem
            )
        reading, problem = _read_then_make_safe(driver.check_reading, driver.safe_state)
    finally:
        driver.close()
    status = STATUS_FAILED if problem else STATUS_OK
    return InstrumentCheck(driver.name, key, route, status, identity, reading, problem)


def identity_text(reply: str) -> str:
    """``ID model=ORNI-FAN serial=SIM00001`` -> ``model=ORNI-FAN serial=SIM00001``; other identities unchanged."""
    fields = dict(word.split("=", 1) for word in reply.split()[1:] if "=" in word)
    if reply.startswith("ID") and fields:
        return " ".join(f"{name}={value}" for name, value in fields.items())
    return reply


def _check_balance_device(device: CheckedDevice) -> InstrumentCheck:
    """Open and identify (ORNI-DAQ9 ``ID?``, NETCANOEM serial number and firmware, Net F/T counts per unit), one
    sample, not streaming, close; whatever the device, through the balance interface."""
    key, route = device.rig_file_key, device.route
    try:
        try:
            identity, problem = device.check_identity()
        except InstrumentError as error:
            return _refused(route, key, device.name, error)
        if problem is not None:
            return InstrumentCheck(
                device.name, key, route, STATUS_FAILED, identity, problem=problem
            )
        reading, problem = _read_then_make_safe(device.check_reading, device.safe_state)
    finally:
        device.close()
    status = STATUS_FAILED if problem else STATUS_OK
    return InstrumentCheck(device.name, key, route, status, identity, reading, problem)
