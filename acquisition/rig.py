"""The rig: the instruments a rig file names, their safety limits, connect/close and safe state.

``Rig.from_file(path)`` reads and checks the rig file and its calibration and tunnel-table files;
``connect()`` opens the drivers (for a simulated rig it first reaches the simulated instruments, through the
simulation backend the rig file names (:mod:`rig_simulation`), and the same drivers connect to their ptys and
virtual CAN channel); ``close()`` always brings the
motor and the tunnel fan to a safe state before closing anything, also after an error. Use it as a
context manager so that every exit path goes through ``close()``.

Exclusive access: every driver opens its port or CAN channel exclusively (a lock file per port that names the
holder, and pyserial's ``exclusive=True``; the OS releases both when the process dies), so a second process on the
same rig is refused with :class:`InstrumentInUse` before it sends anything. Known state: each driver drains what
a crashed host left behind (the DAQ board is sent ``STOP`` first), then ``connect()`` commands motor off, fan
stop and strut halt before homing, whatever the instruments were doing.

A rig file with ``[rig].simulator_control`` connects to simulated instruments served by another process
(``python -m ornitail.simulated_instruments.rig_simulator_server``): the ports are real ptys, rig time runs at the
server's time scale and the simulated vehicle is changed through the control socket.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from ornitail.acquisition.actuator_backends import create_actuator
from ornitail.acquisition.actuator_interfaces import (
    ActuatorContext,
    FlappingMotor,
    PitchStrut,
    TunnelFan,
)
from ornitail.acquisition.balance_backends import BalanceContext, create_balance
from ornitail.acquisition.balance_interface import BalanceStream
from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, RigDescription, read_rig_file
from ornitail.acquisition.rig_simulation import RigSimulation, simulation_backend
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.hotwire_laws import HotwireLaw, load_hotwire_law
from ornitail.calibration.tunnel_table import TunnelVelocityTable
from ornitail.core.errors import UserInputError, require_finite

REPLY_TIMEOUT_S = 1.0
"""How long a real instrument may take to answer a command, s."""
SIMULATED_REPLY_TIMEOUT_S = 5.0
"""The same for simulated instruments (threads of a process a loaded machine may starve for a while), s."""


class Rig:
    """A tunnel rig described by a rig file.

    Attributes
    ----------
    description : RigDescription
        The checked rig file.
    calibration : AtiCalibration
        The balance calibration named by ``[balance].calibration``.
    tunnel_table : TunnelVelocityTable
        Fan rpm to velocity, from ``[tunnel].table``.
    fan, strut, motor : TunnelFan, PitchStrut, FlappingMotor
        The actuators (whatever backend ``[fan].backend`` etc. chose), set by :meth:`connect`; the rig calls
        them only through these interfaces (:mod:`actuator_interfaces`).
    balance : BalanceStream
        The balance backend ``[balance].route`` (and ``[balance.aux_daq]``) chose (:mod:`balance_backends`), set
        by :meth:`connect`; the rig calls it only through :class:`BalanceStream`.
    simulators : RigSimulation | None
        The simulated instruments of a simulated rig once reached (ornitail's own expose each simulator, for
        fault injection in tests), else None.
    safe_state_outcome : dict[str, str]
        The last :meth:`safe_state` (also run by :meth:`close`), per actuator created (fan, motor, strut):
        ``"safe"`` (confirmed), ``"failed"`` (no confirmation) or ``"not connected"`` (its port never opened).
    """

    def __init__(self, description: RigDescription) -> None:
        self.description = description
        self._simulation = simulation_backend(description)
        self.calibration = AtiCalibration.from_file(description.calibration_path)
        self.tunnel_table = TunnelVelocityTable.from_csv(description.tunnel_table_path)
        self._hotwire_law = (
            None
            if description.hotwire_law_path is None
            else load_hotwire_law(description.hotwire_law_path)
        )
        limits = description.limits
        table_low, table_high = (
            float(self.tunnel_table.velocity_m_s[0]),
            float(self.tunnel_table.velocity_m_s[-1]),
        )
        if limits.velocity_min_m_s < table_low or limits.velocity_max_m_s > table_high:
            raise UserInputError(
                f"{description.path}: [limits].velocity_m_s",
                f"{limits.velocity_min_m_s:g}..{limits.velocity_max_m_s:g} m/s is not inside the "
                f"tunnel table's range {table_low:g}..{table_high:g} m/s "
                f"({description.tunnel_table_path})",
            )
        self.speed_map = FanSpeedMap(self.tunnel_table)
        self.max_fan_rpm = self.speed_map.rpm_for_velocity(limits.velocity_max_m_s)
        self.fan: TunnelFan | None = None
        self.strut: PitchStrut | None = None
        self.motor: FlappingMotor | None = None
        self.balance: BalanceStream | None = None
        self.simulators: RigSimulation | None = None
        self.safe_state_outcome: dict[str, str] = {}
        self._time_scale = description.time_scale if self._simulation is not None else 1.0
        self._balance_clock: tuple[float, float] | None = None  # (rig time at start, s; rate, Hz)

    @classmethod
    def from_file(
        cls, path: str | Path = DEFAULT_RIG_FILE, *, time_scale: float | None = None
    ) -> Rig:
        """Read a rig file; ``time_scale`` overrides ``[rig].time_scale`` of a simulated rig."""
        description = read_rig_file(path)
        if time_scale is not None:
            require_finite("time_scale", time_scale)
            if time_scale <= 0:
                raise UserInputError("time_scale", f"{time_scale!r} must be > 0")
            description = dataclasses.replace(description, time_scale=float(time_scale))
        return cls(description)

    # -- connection -------------------------------------------------------------------------
    def connect(self, *, home_strut: bool = True) -> Rig:
        """Open every instrument exclusively (starting the simulators first if simulated), command the safe
        state (motor off, fan stop, strut halt), home the strut.

        Raises
        ------
        InstrumentInUse
            Another process holds one of the rig's ports (nothing was sent to any instrument).
        InstrumentError
            An instrument is absent or does not answer; the instruments already open are made safe and closed.
        """
        try:
            self.start_simulation()
            fan, motor, strut, balance = self.create_drivers()
            for driver in (fan, motor, strut, balance):
                driver.open()
            errors = self.safe_state()  # whatever a crashed host left running
            if errors:
                raise errors[0]
            if home_strut:
                strut.home(timeout_s=max(5.0, 60.0 / self._time_scale))
        except BaseException:
            self.close(raise_errors=False)
            raise
        return self

    def start_simulation(self) -> None:
        """Reach the rig's simulated instruments through the simulation backend its rig file names (start them in
        this process for ``[rig].simulated``, reach their server for ``[rig].simulator_control``) and take their
        time scale; nothing for real instruments.

        Raises
        ------
        InstrumentDisconnected
            The simulator server's control socket does not answer.
        """
        if self._simulation is not None and self.simulators is None:
            self.simulators = self._simulation.start(
                self.description, self.calibration, self.tunnel_table
            )
            self._time_scale = self.simulators.time_scale

    def create_drivers(
        self,
    ) -> tuple[TunnelFan, FlappingMotor, PitchStrut, BalanceStream]:
        """Create (not open) the fan, motor, strut and balance drivers on the rig file's ports, or on the
        simulators' ptys and virtual CAN channel once :meth:`start_simulation` started them; they become
        :attr:`fan`, :attr:`motor`, :attr:`strut` and :attr:`balance`, which :meth:`close` makes safe and closes
        (the simulated Net F/T's loopback address replaces ``[balance.netft]``'s).
        Each actuator is built by the backend its rig-file section names (:mod:`actuator_backends`)."""
        description = self.description
        ports = {
            "fan": description.fan.port,
            "strut": description.strut.port,
            "motor": description.motor.port,
            "daq": description.serial_daq.port,
            "aux_daq": description.aux_daq.port if description.aux_daq else "",
        }
        can_interface, can_channel = description.can.interface, description.can.channel
        netft = description.netft
        if self.simulators is not None:
            ports.update(self.simulators.ports())
            can_interface, can_channel = self.simulators.can_bus() or (can_interface, can_channel)
            address = self.simulators.netft_address()
            if address is not None and netft is not None:
                host, rdt_port, http_port = address
                netft = dataclasses.replace(
                    netft, host=host, rdt_port=rdt_port, http_port=http_port
                )
        simulated = self._simulation is not None
        reply_timeout_s = SIMULATED_REPLY_TIMEOUT_S if simulated else REPLY_TIMEOUT_S

        def actuator(role: str, name: str) -> Any:
            settings = getattr(description, role)
            context = ActuatorContext(
                name=name,
                port=ports[role],
                baud=settings.baud,
                reply_timeout_s=reply_timeout_s,
                settings=settings.settings,
                limits=description.limits,
                tunnel_table=self.tunnel_table,
                max_fan_rpm=self.max_fan_rpm,
                rig_file=description.path,
            )
            return create_actuator(
                role, settings.backend_class, context, f"{description.path}: [{role}].backend"
            )

        self.fan = actuator("fan", "tunnel fan")
        self.motor = actuator("motor", "flapping motor")
        self.strut = actuator("strut", "strut pitch actuator")
        self.balance = create_balance(
            BalanceContext(
                description=description,
                calibration_matrix_si=self.calibration.matrix_si,
                ports=ports,
                can_interface=can_interface,
                can_channel=can_channel,
                reply_timeout_s=reply_timeout_s,
                clock=self.now_s,
                time_scale=self._time_scale,
                netft=netft,
            )
        )
        return self.fan, self.motor, self.strut, self.balance

    def __enter__(self) -> Rig:
        return self.connect()

    def __exit__(self, exc_type: object, *exc_info: object) -> None:
        self.close(raise_errors=exc_type is None)

    def safe_state(self) -> list[InstrumentError]:
        """Motor off, fan to zero, strut halted; every step is tried. Returns the errors met and sets
        :attr:`safe_state_outcome` (kept as it was when the rig is closed: a second close does not erase it)."""
        errors: list[InstrumentError] = []
        drivers = [driver for driver in (self.motor, self.fan, self.strut) if driver is not None]
        if not drivers:
            return errors
        outcome: dict[str, str] = {}
        for driver in drivers:
            outcome[driver.name] = "not connected"
            if driver.is_open:
                try:
                    driver.safe_state()
                    outcome[driver.name] = "safe"
                except InstrumentError as error:
                    errors.append(error)
                    outcome[driver.name] = "failed"
        self.safe_state_outcome = outcome
        return errors

    def safe_state_summary(self, unsafe: Iterable[str] = ()) -> str:
        """What the last :meth:`safe_state` (or :meth:`close`) did, as a clause of one line: the actuators whose
        safe state was confirmed, not confirmed (also those named in ``unsafe``) and never connected."""
        outcome = self.safe_state_outcome
        failed = sorted({*unsafe, *(name for name, said in outcome.items() if said == "failed")})
        safe = sorted(name for name, said in outcome.items() if said == "safe")
        absent = sorted(name for name, said in outcome.items() if said == "not connected")
        if not failed and not safe:
            return "no actuator was connected, so none was brought to its safe state"
        clauses = (
            ("safe state not confirmed", failed),
            ("safe state confirmed", safe),
            ("not connected", absent),
        )
        return "; ".join(f"{what}: {', '.join(names)}" for what, names in clauses if names)

    def close(self, *, raise_errors: bool = True) -> list[InstrumentError]:
        """Safe state first, then close every driver and simulator; raise the first error last (or, with
        ``raise_errors=False``, return the errors met)."""
        errors = self.safe_state()
        if self.balance is not None:
            try:
                self.balance.close()
            except InstrumentError as error:
                errors.append(error)
        for driver in (self.motor, self.fan, self.strut):
            if driver is not None:
                driver.close()
        if self.simulators is not None:
            self.simulators.close()
            self.simulators = None
        self.fan = self.strut = self.motor = self.balance = None
        if errors and raise_errors:
            raise errors[0]
        return errors

    # -- set points -------------------------------------------------------------------------
    def _connected(self, driver):
        if driver is None:
            raise RuntimeError(
                f"rig {self.description.name!r} is not connected; call connect() first"
            )
        return driver

    def set_tunnel_velocity(self, velocity_m_s: float) -> None:
        """Set the fan for jet velocity ``velocity_m_s`` (m/s) through the tunnel table."""
        require_finite("velocity_m_s", velocity_m_s)
        limits = self.description.limits
        if not limits.velocity_min_m_s <= velocity_m_s <= limits.velocity_max_m_s:
            raise UserInputError(
                "velocity_m_s",
                f"{velocity_m_s:g} m/s is outside the rig limit {limits.velocity_min_m_s:g}.."
                f"{limits.velocity_max_m_s:g} m/s "
                f"([limits].velocity_m_s in {self.description.path})",
            )
        self._connected(self.fan).set_velocity(velocity_m_s)

    def read_tunnel_velocity_m_s(self) -> float:
        """Jet velocity from the measured fan speed (or drive frequency) and the tunnel table, m/s."""
        return self._connected(self.fan).read_velocity_m_s()

    def set_pitch(self, pitch_rad: float) -> None:
        """Set the strut pitch angle, rad (limits checked by the strut driver)."""
        self._connected(self.strut).set_pitch(pitch_rad)

    def read_pitch_rad(self) -> float:
        """Measured strut pitch angle, rad."""
        return self._connected(self.strut).read_pitch_rad()

    def set_flapping_frequency(self, flapping_frequency_hz: float) -> None:
        """Set the motor speed for ``flapping_frequency_hz`` (Hz): rpm = f * 60 * gear ratio."""
        require_finite("flapping_frequency_hz", flapping_frequency_hz)
        limits = self.description.limits
        if (
            not limits.flapping_frequency_min_hz
            <= flapping_frequency_hz
            <= limits.flapping_frequency_max_hz
        ):
            raise UserInputError(
                "flapping_frequency_hz",
                f"{flapping_frequency_hz:g} Hz is outside the rig limit "
                f"{limits.flapping_frequency_min_hz:g}..{limits.flapping_frequency_max_hz:g} Hz "
                f"([limits].flapping_frequency_hz in {self.description.path})",
            )
        self._connected(self.motor).set_target_rpm(
            flapping_frequency_hz * 60.0 * self.description.gear_ratio
        )

    def read_flapping_frequency_hz(self) -> float:
        """Flapping frequency from the measured motor speed, Hz."""
        return self._connected(self.motor).read_rpm() / 60.0 / self.description.gear_ratio

    def set_point_limits(self) -> dict[str, tuple[float, float]]:
        """The rig's set-point limits in SI units, keyed by set-point field (for plan checks)."""
        limits = self.description.limits
        return {
            "pitch_rad": (limits.pitch_min_rad, limits.pitch_max_rad),
            "tunnel_velocity_m_s": (limits.velocity_min_m_s, limits.velocity_max_m_s),
            "flapping_frequency_hz": (
                limits.flapping_frequency_min_hz,
                limits.flapping_frequency_max_hz,
            ),
        }

    def recording_description(self) -> dict[str, Any]:
        """What a recording stores about this rig (JSON-serialisable): name, file, simulated, time scale,
        balance route, tool transform (mm, deg), the motor's gear ratio (motor turns per flap, for the
        frequency cross-check in processing) and the backend of each actuator (``{"fan": "modbus_vfd", ...}``)."""
        description = self.description
        return {
            "name": description.name,
            "file": str(description.path),
            "simulated": self._simulation is not None,
            "time_scale": self._time_scale,
            "balance_route": description.balance_route,
            "tool_transform_mm_deg": list(description.tool_transform.as_mm_deg()),
            "gear_ratio": description.gear_ratio,
            "actuator_backends": {
                role: getattr(description, role).backend for role in ("fan", "strut", "motor")
            },
            **(self.balance.recording_description() if self.balance is not None else {}),
        }

    def calibration_files(self) -> dict[str, Path]:
        """The calibration files a recording names and hashes: the balance matrix and the tunnel table."""
        return {
            "balance": self.description.calibration_path,
            "tunnel_table": self.description.tunnel_table_path,
        }

    @property
    def time_scale(self) -> float:
        """Rig seconds per wall second: the simulated rig's time scale, 1 for a real rig."""
        return self._time_scale

    def now_s(self) -> float:
        """Rig time, s: the simulated instruments' clock of a simulated rig, else the monotonic wall clock."""
        if self.simulators is not None:
            return self.simulators.now_s()
        return time.monotonic() * self._time_scale

    def hotwire_law(self) -> HotwireLaw | None:
        """The law of the rig's hot-wire when the rig knows it: the rig file's ``[tunnel].hotwire_law``, else the
        simulated instruments' own, else None."""
        if self._hotwire_law is not None:
            return self._hotwire_law
        return self._simulation.hotwire_law() if self._simulation is not None else None

    def mount_vehicle(self, tail_id: str, x_h_m: float) -> None:
        """Tell a simulated rig which vehicle is on the balance (a real rig has the real one)."""
        if self.simulators is not None:
            self.simulators.mount_vehicle(tail_id, x_h_m)

    def change_tail(self, tail_attached: bool, operator_prompt: Callable[[str], None]) -> None:
        """Fit or remove the tail with motor and tunnel in a safe state.

        On a simulated rig the simulated vehicle changes; on a real rig ``operator_prompt`` is called with the
        instruction and must return once the operator has done it.
        """
        errors = self.safe_state()
        if errors:
            raise errors[0]
        if self.simulators is not None:
            self.simulators.set_tail_attached(tail_attached)
            return
        action = "Fit the tail" if tail_attached else "Remove the tail (keep the base tail mount)"
        operator_prompt(f"{action}; motor and tunnel are off.")

    def wait_simulated_s(self, simulated_seconds: float) -> None:
        """Sleep ``simulated_seconds`` of rig time (wall time / time scale on a simulated rig)."""
        time.sleep(max(0.0, simulated_seconds) / self._time_scale)

    # -- balance ----------------------------------------------------------------------------
    def start_balance(self, sample_rate_hz: float | None = None) -> None:
        """Start the balance stream at ``sample_rate_hz`` (default: the rig file's rate of its route)."""
        balance = self._connected(self.balance)
        before_start_s = self.now_s()
        rate_hz = balance.start_stream(sample_rate_hz or self.description.balance_sample_rate_hz())
        self._balance_clock = (before_start_s, float(rate_hz))

    def balance_samples_since_start(self) -> int:
        """Samples the balance has taken since its stream started, from the rig time since then.

        The rig time is read before START is sent, so at or before the board's first sample: this count never
        falls short of the board's (crystal drift aside: ~50 ppm), and rows picked from it were sampled now or
        later. Read after START was answered, a slow answer (a loaded host) made records begin that much before
        the point settled: on a simulated rig at 15 x, a 0.4 s stall put a motor spin-up into a record. It lets
        a sweep pick rows by when they were sampled, not by when they reached the host through the transport's
        buffers.
        """
        if self._balance_clock is None:
            raise RuntimeError("the balance is not streaming: start_balance() first")
        started_s, rate_hz = self._balance_clock
        return int(math.ceil((self.now_s() - started_s) * rate_hz))

    def stop_balance(self) -> None:
        """Stop the balance stream or polling."""
        balance = self._connected(self.balance)
        self._balance_clock = None
        balance.stop_stream()
