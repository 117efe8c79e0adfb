"""The simulated rig's instruments in a process of their own, outliving the host that uses them (as hardware does).

Run it as::

    python -m ornitail.simulated_instruments.rig_simulator_server --directory DIR [--rig RIG.toml] [--time-scale 5]

It starts the simulated fan, strut, motor and ORNI-DAQ9 board of a simulated rig file (default: the packaged one,
serial DAQ route) on ptys, writes ``DIR/rig.toml`` (a rig file whose ports are those ptys and whose
``[rig].simulator_control`` names the control socket), prints one JSON line (``rig_file``, ``control``, ``ports``,
``pid``, ``time_scale``) and serves until SIGTERM, SIGINT or the ``shutdown`` command. A host that is killed leaves
the instruments as it left them: the fan and motor keep turning and the board keeps streaming into its pty.

Control: a Unix socket; each request is one JSON object on a line, each reply one JSON object on a line
(``{"ok": true, ...}`` or ``{"ok": false, "error": "..."}``). Commands (``"command"`` field):

- ``state``: clock, and per instrument its physical state, commanded target, ``safe`` (fan and motor commanded to
  zero, strut not moving), ``unplugged``, ``stalled`` and ``safe_commands`` (STOP / OFF / HALT received so far);
  for the board ``streaming``, ``next_counter`` (the counter of the next sample it takes), ``samples_sent``.
- fault injection into the DAQ stream: ``garbage`` (``bytes``: that many random bytes), ``crc`` (``count``
  frames), ``drop`` (``count`` samples never sent), ``truncate`` (``keep_bytes``);
- ``unplug`` (``instrument``: ``fan``, ``strut``, ``motor`` or ``daq``): the pty is closed as a pulled cable;
- ``stall`` (``instrument``, ``stalled``: true/false): the instrument stops reading and answering (its port stays
  open; the board's FIFO fills and then drops samples, counted);
- ``mount`` (``tail_id``, ``x_h_mm``) and ``tail`` (``attached``): the simulated vehicle (a rig connected through
  ``simulator_control`` sends these itself);
- ``shutdown``.

:class:`SimulatorControl` is the client; :class:`ServedRigInstruments`, built on it, is the rig's simulation backend
``simulator_server`` (``[rig].simulator_control``; entry point ``rig.simulator_server`` in the group
``ornitail.instruments``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import signal
import socket
import socketserver
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from ornitail.acquisition.instrument_errors import InstrumentDisconnected
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, RigDescription, read_rig_file
from ornitail.acquisition.rig_simulation import RigSimulation, SimulationLink
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.calibration.hotwire_laws import HotwireLaw
from ornitail.calibration.tunnel_table import TunnelVelocityTable
from ornitail.core.errors import UserInputError
from ornitail.sim.configuration import study_configuration
from ornitail.simulated_instruments.pty_transport import PseudoTerminalPair
from ornitail.simulated_instruments.rig_instruments import (
    SimulatedRigInstruments,
    simulated_hotwire_law,
)

INSTRUMENTS = ("fan", "strut", "motor", "daq")
SAFE_COMMANDS = {"fan": "STOP", "strut": "HALT", "motor": "OFF"}
MAX_SOCKET_PATH = 100
"""Unix socket paths longer than this (the limit is 107 bytes) go to a short temporary folder instead."""


class _StallablePty:
    """A pty pair whose simulator side can be stalled: it then neither reads nor writes (the port stays open)."""

    def __init__(self, pty: PseudoTerminalPair) -> None:
        self._pty = pty
        self.stalled = threading.Event()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._pty, name)

    def read_available(self, timeout_s: float) -> bytes | None:
        if self.stalled.is_set():
            if self._pty.master_fd < 0:
                return None
            time.sleep(timeout_s)
            return b""
        return self._pty.read_available(timeout_s)

    def write_some(self, data: bytes) -> int:
        return 0 if self.stalled.is_set() else self._pty.write_some(data)


class RigSimulatorServer:
    """The simulated instruments of ``description`` on ptys, with a control socket at ``control_path``."""

    def __init__(self, description: RigDescription, control_path: Path) -> None:
        if description.balance_route != "serial_daq":
            raise UserInputError(
                f"{description.path}: [balance].route",
                "the rig simulator server serves the serial DAQ route only (python-can's virtual bus does not "
                'cross processes); use route = "serial_daq"',
            )
        for role in ("fan", "strut", "motor"):
            backend = getattr(description, role).backend
            if backend != "orni_line":
                raise UserInputError(
                    f"{description.path}: [{role}].backend",
                    f"the rig simulator server serves the orni_line backends only (not yet {backend!r}); "
                    "simulate this rig in-process with [rig].simulated = true",
                )
        self.description = description
        self.control_path = control_path
        self.instruments = SimulatedRigInstruments.start(
            description,
            AtiCalibration.from_file(description.calibration_path),
            TunnelVelocityTable.from_csv(description.tunnel_table_path),
        )
        self._ptys: dict[str, _StallablePty] = {}
        self.safe_commands = dict.fromkeys(SAFE_COMMANDS, 0)
        for name in INSTRUMENTS:
            device = self._device(name)
            wrapped = _StallablePty(device._pty)
            device._pty = wrapped
            self._ptys[name] = wrapped
        for name, command in SAFE_COMMANDS.items():
            self._count_safe_commands(name, command)
        self.stopped = threading.Event()
        self._server: socketserver.ThreadingUnixStreamServer | None = None

    def _device(self, name: str) -> Any:
        instruments = self.instruments
        return {
            "fan": instruments.fan,
            "strut": instruments.strut,
            "motor": instruments.motor,
            "daq": instruments.daq_board,
        }[name]

    def _count_safe_commands(self, name: str, safe_command: str) -> None:
        device = self._device(name)
        handle = device.handle

        def counting_handle(command: str) -> str:
            if command.split()[:1] == [safe_command]:
                self.safe_commands[name] += 1
            return handle(command)

        device.handle = counting_handle

    # -- commands ---------------------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        """Every instrument's state (see the module docstring)."""
        fan, strut, motor = self.instruments.fan, self.instruments.strut, self.instruments.motor
        board = self.instruments.daq_board
        assert board is not None
        with fan._state_lock:
            fan_state = {
                "rpm": fan.rpm,
                "target_rpm": fan.target_rpm,
                "safe": fan.target_rpm == 0.0,
            }
        with motor._state_lock:
            motor_state = {
                "rpm": motor.rpm,
                "target_rpm": motor.target_rpm,
                "safe": motor.target_rpm == 0.0,
            }
        with strut._state_lock:
            moving = strut.angle_deg != strut.target_deg
            strut_state = {
                "angle_deg": strut.angle_deg,
                "target_deg": strut.target_deg,
                "homed": strut.homed,
                "moving": moving,
                "safe": not moving,
            }
        daq_state = {
            "streaming": board._streaming,
            "next_counter": board._next_counter,
            "samples_sent": board.samples_sent,
            "samples_dropped_by_board": board.samples_dropped_by_board,
            "sample_rate_hz": board.sample_rate_hz,
        }
        states = {"fan": fan_state, "strut": strut_state, "motor": motor_state, "daq": daq_state}
        for name, values in states.items():
            values["unplugged"] = bool(self._device(name).unplugged)
            values["stalled"] = self._ptys[name].stalled.is_set()
            if name in SAFE_COMMANDS:
                values["safe_commands"] = self.safe_commands[name]
        return {
            "time_s": self.instruments.clock.now_s(),
            "time_scale": self.instruments.clock.time_scale,
            **states,
        }

    def handle(self, request: dict[str, Any]) -> dict[str, Any]:
        """Carry out one control request; return the reply object."""
        command = request.get("command")
        board = self.instruments.daq_board
        assert board is not None
        if command == "state":
            return {"ok": True, **self.state()}
        if command == "garbage":
            board.inject_garbage(os.urandom(int(request.get("bytes", 100))))
        elif command == "crc":
            board.corrupt_next_crc(int(request.get("count", 1)))
        elif command == "drop":
            board.drop_samples(int(request.get("count", 1)))
        elif command == "truncate":
            board.truncate_next_frame(int(request.get("keep_bytes", 10)))
        elif command in ("unplug", "stall"):
            name = request.get("instrument")
            if name not in INSTRUMENTS:
                return {"ok": False, "error": f"instrument must be one of {', '.join(INSTRUMENTS)}"}
            if command == "unplug":
                self._device(name).unplug()
            elif request.get("stalled", True):
                self._ptys[name].stalled.set()
            else:
                self._ptys[name].stalled.clear()
        elif command == "mount":
            configuration = study_configuration(str(request["tail_id"]), float(request["x_h_mm"]))
            self.instruments.signals.mount_vehicle(configuration)
        elif command == "tail":
            self.instruments.set_tail_attached(bool(request["attached"]))
        elif command == "shutdown":
            self.stopped.set()
        else:
            return {"ok": False, "error": f"unknown command {command!r}"}
        return {"ok": True}

    # -- serving ----------------------------------------------------------------------------
    def start_serving(self) -> None:
        """Listen on the control socket (answering in threads) from now on."""
        server_object = self

        class Handler(socketserver.StreamRequestHandler):
            def handle(self) -> None:
                for line in self.rfile:
                    try:
                        reply = server_object.handle(json.loads(line))
                    except Exception as error:  # a bad request must not end the server
                        reply = {"ok": False, "error": f"{type(error).__name__}: {error}"}
                    try:
                        self.wfile.write((json.dumps(reply) + "\n").encode())
                        self.wfile.flush()
                    except OSError:
                        return

        self.control_path.unlink(missing_ok=True)
        self._server = socketserver.ThreadingUnixStreamServer(str(self.control_path), Handler)
        self._server.daemon_threads = True
        thread = threading.Thread(target=self._server.serve_forever, name="control", daemon=True)
        thread.start()

    def close(self) -> None:
        """Stop answering, stop every simulator and remove the control socket."""
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None
        self.instruments.close()
        self.control_path.unlink(missing_ok=True)

    def ports(self) -> dict[str, str]:
        """The pty path of every instrument."""
        return {name: self._device(name).port_path for name in INSTRUMENTS}

    def rig_file_text(self) -> str:
        """A rig file for these ptys, ``simulated = false`` and ``simulator_control`` set."""
        description = self.description
        limits = description.limits
        ports = self.ports()

        def toml(value: Any) -> str:
            return json.dumps(value)

        def degrees(low: float, high: float) -> str:
            return f"[{math.degrees(low)!r}, {math.degrees(high)!r}]"

        return "\n".join(
            [
                "# Written by python -m ornitail.simulated_instruments.rig_simulator_server "
                f"(pid {os.getpid()}): simulated instruments on ptys. Format: docs/rig-file.md",
                "[rig]",
                f"name = {toml(description.name + ' (simulator server)')}",
                "simulated = false",
                f"simulator_control = {toml(str(self.control_path))}",
                f"time_scale = {self.instruments.clock.time_scale!r}",
                f"seed = {description.seed}",
                "",
                "[balance]",
                'route = "serial_daq"',
                f"calibration = {toml(str(description.calibration_path))}",
                "tool_transform_mm_deg = "
                + toml([float(v) for v in description.tool_transform.as_mm_deg()]),
                "",
                "[balance.serial_daq]",
                f"port = {toml(ports['daq'])}",
                f"baud = {description.serial_daq.baud}",
                f"sample_rate_hz = {description.serial_daq.sample_rate_hz!r}",
                "",
                "[tunnel]",
                f"table = {toml(str(description.tunnel_table_path))}",
                "",
                "[fan]",
                f"port = {toml(ports['fan'])}",
                f"baud = {description.fan.baud}",
                "",
                "[strut]",
                f"port = {toml(ports['strut'])}",
                f"baud = {description.strut.baud}",
                "",
                "[motor]",
                f"port = {toml(ports['motor'])}",
                f"baud = {description.motor.baud}",
                f"gear_ratio = {description.gear_ratio!r}",
                "",
                "[limits]",
                f"pitch_deg = {degrees(limits.pitch_min_rad, limits.pitch_max_rad)}",
                f"velocity_m_s = [{limits.velocity_min_m_s!r}, {limits.velocity_max_m_s!r}]",
                "flapping_frequency_hz = "
                f"[{limits.flapping_frequency_min_hz!r}, {limits.flapping_frequency_max_hz!r}]",
                f"max_motor_rpm = {limits.max_motor_rpm!r}",
                "",
            ]
        )


class SimulatorControl:
    """Client of a :class:`RigSimulatorServer`'s control socket (one connection per request).

    Parameters
    ----------
    path : str or Path
        The control socket.
    timeout_s : float
        How long a request may take, s.
    """

    def __init__(self, path: str | Path, timeout_s: float = 10.0) -> None:
        self.path = Path(path)
        self.timeout_s = timeout_s

    def request(self, command: str, **fields: Any) -> dict[str, Any]:
        """Send ``{"command": command, **fields}``; return the reply (raises if it is not ``ok``).

        Raises
        ------
        InstrumentDisconnected
            The server is not there (not started, or ended) or did not answer in time.
        RuntimeError
            The server refused the request.
        """
        try:
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as connection:
                connection.settimeout(self.timeout_s)
                connection.connect(str(self.path))
                connection.sendall((json.dumps({"command": command, **fields}) + "\n").encode())
                reply = b""
                while not reply.endswith(b"\n"):
                    chunk = connection.recv(65536)
                    if not chunk:
                        break
                    reply += chunk
        except OSError as error:
            raise InstrumentDisconnected(
                "rig simulator", f"control socket {self.path} failed: {error}"
            ) from None
        try:
            answer = json.loads(reply)
        except ValueError:
            raise InstrumentDisconnected(
                "rig simulator", f"control socket {self.path} closed without a reply"
            ) from None
        if not answer.get("ok"):
            raise RuntimeError(f"rig simulator refused {command!r}: {answer.get('error')}")
        return answer

    def state(self) -> dict[str, Any]:
        """The instruments' state (see the module docstring)."""
        return self.request("state")


class ServedRigInstruments(RigSimulation):
    """The simulated instruments a :class:`RigSimulatorServer` serves, reached through its control socket: the
    rig file already names their ptys, rig time runs at the server's time scale, the vehicle changes by request."""

    def __init__(self, control: SimulatorControl, time_scale: float) -> None:
        self.control = control
        self._time_scale = time_scale

    @classmethod
    def start(
        cls,
        description: RigDescription,
        calibration: AtiCalibration,
        tunnel_table: TunnelVelocityTable,
    ) -> ServedRigInstruments:
        """Ask the server of ``[rig].simulator_control`` for its time scale.

        Raises
        ------
        InstrumentDisconnected
            The control socket does not answer.
        """
        assert description.simulator_control is not None  # this backend is chosen by it
        control = SimulatorControl(description.simulator_control)
        return cls(control, float(control.state()["time_scale"]))

    @classmethod
    def hotwire_law(cls) -> HotwireLaw:
        """The law of the simulated hot-wire (the server runs the same simulator)."""
        return simulated_hotwire_law()

    @property
    def time_scale(self) -> float:
        """The server's time scale."""
        return self._time_scale

    def link(self) -> SimulationLink:
        """The server's control socket, which answered :meth:`start` with its time scale."""
        return SimulationLink(
            "rig simulator",
            "[rig].simulator_control",
            str(self.control.path),
            "ornitail rig simulator server",
            {"time_scale": self._time_scale},
        )

    def mount_vehicle(self, tail_id: str, x_h_m: float) -> None:
        """Ask the server to mount the vehicle with tail ``tail_id`` at ``x_h_m`` (m)."""
        self.control.request("mount", tail_id=tail_id, x_h_mm=x_h_m * 1000.0)

    def set_tail_attached(self, tail_attached: bool) -> None:
        """Ask the server to fit or remove the tail."""
        self.control.request("tail", attached=tail_attached)

    def close(self) -> None:
        """Nothing to stop: the server and its instruments outlive the rig, as hardware does."""


def _control_path(directory: Path) -> Path:
    path = (directory / "control.sock").resolve()
    if len(str(path)) <= MAX_SOCKET_PATH:
        return path
    return Path(tempfile.mkdtemp(prefix="ornitail-rig-")) / "control.sock"


def main(argv: list[str] | None = None) -> int:
    """Start the server, print its JSON line, serve until told to stop."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--directory", type=Path, required=True, help="where rig.toml is written")
    parser.add_argument("--rig", type=Path, default=DEFAULT_RIG_FILE, help="a simulated rig file")
    parser.add_argument("--time-scale", type=float, default=None, help="simulated s per wall s")
    parser.add_argument("--seed", type=int, default=None, help="seed of the simulator")
    arguments = parser.parse_args(argv)
    try:
        description = read_rig_file(arguments.rig)
        changes: dict[str, Any] = {}
        if arguments.time_scale is not None:
            if not arguments.time_scale > 0:
                raise UserInputError("--time-scale", f"{arguments.time_scale!r} must be > 0")
            changes["time_scale"] = float(arguments.time_scale)
        if arguments.seed is not None:
            changes["seed"] = int(arguments.seed)
        description = dataclasses.replace(description, **changes)
        arguments.directory.mkdir(parents=True, exist_ok=True)
        server = RigSimulatorServer(description, _control_path(arguments.directory))
    except UserInputError as error:
        print(f"rig_simulator_server: error: {error}", file=sys.stderr)
        return 2
    try:
        signal.signal(signal.SIGTERM, lambda *_: server.stopped.set())
        signal.signal(signal.SIGINT, lambda *_: server.stopped.set())
        signal.signal(signal.SIGHUP, signal.SIG_IGN)  # keeps serving when its terminal closes
        rig_file = arguments.directory.resolve() / "rig.toml"
        temporary = rig_file.with_suffix(".toml.tmp")
        temporary.write_text(server.rig_file_text(), encoding="utf-8")
        os.replace(temporary, rig_file)
        server.start_serving()
        print(
            json.dumps(
                {
                    "rig_file": str(rig_file),
                    "control": str(server.control_path),
                    "ports": server.ports(),
                    "pid": os.getpid(),
                    "time_scale": description.time_scale,
                }
            ),
            flush=True,
        )
        server.stopped.wait()
    finally:
        server.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
