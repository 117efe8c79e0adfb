"""Base of simulated line-protocol instruments: a pty, a thread, a command handler, physics.

Every ``tick_period_s`` of wall time the thread advances the instrument's physics by the simulated
time elapsed on the shared :class:`SimulatedClock` and answers the complete command lines received.
Subclasses implement :meth:`handle` (one command line -> one reply line) and :meth:`advance`.
"""

from __future__ import annotations

import math
import threading

from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.device import SimulatedDevice
from ornitail.simulated_instruments.pty_transport import PseudoTerminalPair


def first_order_step(
    value: float, target: float, dt_s: float, time_constant_s: float, rate_limit_per_s: float
) -> float:
    """Advance a first-order lag with a rate limit by ``dt_s``.

    Exact exponential approach ``target + (value - target) exp(-dt/tau)`` (tau = 0 jumps), with the
    change per step capped at ``rate_limit_per_s * dt_s``.
    """
    lagged = (
        target
        if time_constant_s <= 0
        else target + (value - target) * math.exp(-dt_s / time_constant_s)
    )
    step_limit = rate_limit_per_s * dt_s
    return value + max(-step_limit, min(step_limit, lagged - value))


class SimulatedLineInstrument(SimulatedDevice):
    """A simulated ASCII line instrument behind a pty; the driver opens :attr:`port_path`."""

    model = "ORNI-GENERIC"

    def __init__(
        self,
        clock: SimulatedClock,
        *,
        serial_number: str = "SIM00001",
        tick_period_s: float = 0.005,
    ) -> None:
        self.clock = clock
        self.serial_number = serial_number
        self.tick_period_s = tick_period_s
        self._pty = PseudoTerminalPair.open_raw()
        self.port_path = self._pty.slave_path
        self._unplug_requested = threading.Event()
        self._state_lock = threading.Lock()
        self._prepare_thread(f"simulated {self.model}")
        self._last_time_s = clock.now_s()
        self.unplugged = False

    def _close_transport(self) -> None:
        self._pty.close()

    def unplug(self) -> None:
        """Close the pty master, as a pulled cable."""
        self._unplug_requested.set()

    def identity_reply(self) -> str:
        """Reply to ``ID?``."""
        return f"ID model={self.model} serial={self.serial_number} firmware=1.0.0"

    def handle(self, command: str) -> str | None:
        """Answer one command line (subclasses); return the reply line without newline (None: no reply)."""
        raise NotImplementedError

    def advance(self, dt_s: float) -> None:
        """Advance the physics by ``dt_s`` simulated seconds (subclasses)."""
        raise NotImplementedError

    def _run(self) -> None:
        buffer = b""
        outgoing = b""
        while not self._closing.is_set():
            if self._unplug_requested.is_set():
                self.unplugged = True
                self._pty.close_master()
                return
            incoming = self._pty.read_available(self.tick_period_s)
            if incoming is None:
                return
            now_s = self.clock.now_s()
            with self._state_lock:
                self.advance(now_s - self._last_time_s)
                self._last_time_s = now_s
                buffer += incoming
                while b"\n" in buffer:
                    line, buffer = buffer.split(b"\n", 1)
                    text = line.decode("ascii", errors="replace").strip()
                    if text:
                        reply = (
                            self.identity_reply() if text.upper() == "ID?" else self.handle(text)
                        )
                        if reply is not None:  # None: a message the instrument ignores
                            outgoing += reply.encode("ascii") + b"\n"
            while outgoing:
                written = self._pty.write_some(outgoing)
                if written == 0:
                    break
                outgoing = outgoing[written:]
