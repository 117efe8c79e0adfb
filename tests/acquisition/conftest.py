"""Fixtures of the actuator backend tests: a scripted device on a real pty, and a wait with a generous deadline.

The scripted device is the far end of a raw pty: it reads exactly the bytes a request should have and writes the
reply the test gives (or nothing). The driver under test opens the pty's slave path with pyserial as it would a
USB adapter; nothing of the driver is replaced.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import can
import pytest

from ornitail.acquisition import netcanoem_protocol as protocol
from ornitail.simulated_instruments.pty_transport import PseudoTerminalPair

DEADLINE_S = 30.0
"""Generous deadline for anything a loaded machine may delay, s (never a timing assertion)."""


class ScriptedDevice:
    """Answers a fixed script of (expected request length, reply) on a pty; records what it received."""

    def __init__(self, script: list[tuple[int, bytes | None]]) -> None:
        self._pty = PseudoTerminalPair.open_raw()
        self.port_path = self._pty.slave_path
        self.script = list(script)
        self.received: list[bytes] = []
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._stop = threading.Event()

    def _read_exactly(self, count: int) -> bytes | None:
        data = b""
        deadline = time.monotonic() + DEADLINE_S
        while len(data) < count and not self._stop.is_set():
            if time.monotonic() > deadline:
                return None
            chunk = self._pty.read_available(0.01)
            if chunk is None:
                return None
            data += chunk
        return data

    def _run(self) -> None:
        for length, reply in self.script:
            request = self._read_exactly(length)
            if request is None:
                return
            self.received.append(request)
            if reply is not None:
                self._pty.write_some(reply)

    def __enter__(self) -> ScriptedDevice:
        self._thread.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._stop.set()
        self._thread.join(DEADLINE_S)
        self._pty.close()


def wait_for(predicate, timeout_s: float = DEADLINE_S) -> None:
    """Poll ``predicate`` until true (fails after the generous ``timeout_s``)."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "condition not reached"
        time.sleep(0.01)


@pytest.fixture
def scripted_device() -> Iterator[Callable[[list[tuple[int, bytes | None]]], ScriptedDevice]]:
    """Factory of running :class:`ScriptedDevice` s, closed after the test."""
    devices: list[ScriptedDevice] = []

    def start(script: list[tuple[int, bytes | None]]) -> ScriptedDevice:
        device = ScriptedDevice(script).__enter__()
        devices.append(device)
        return device

    yield start
    for device in devices:
        device.__exit__(None, None, None)


class ScriptedCanBoard:
    """A NETCANOEM board played by a test on its own python-can virtual bus: it answers the serial-number query as
    FT8884 and gauge request k (the k-th other request frame of DLC 0) with the frames ``answer(k)`` gives, in order
    (a test's replies, foreign frames around them, a fake clock advanced first)."""

    def __init__(self, channel: str, answer: Callable[[int], list[tuple[int, bytes]]]) -> None:
        self.bus = can.Bus(interface="virtual", channel=channel)
        self.answer = answer
        self.requests = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def send(self, opcode: int, data: bytes) -> None:
        self.bus.send(
            can.Message(
                arbitration_id=protocol.arbitration_id(protocol.DEFAULT_BASE_ID, opcode),
                is_extended_id=False,
                data=data,
            )
        )

    def _run(self) -> None:
        while not self._stop.is_set():
            message = self.bus.recv(0.05)
            if message is None or message.dlc != 0:
                continue
            opcode = protocol.split_arbitration_id(message.arbitration_id)[1]
            if opcode == protocol.OPCODE_SERIAL_NUMBER:
                self.send(opcode, protocol.encode_serial_number("FT8884"))
                continue
            k = self.requests
            self.requests += 1
            for reply_opcode, data in self.answer(k):
                self.send(reply_opcode, data)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.bus.shutdown()


@pytest.fixture
def scripted_can_board() -> type[ScriptedCanBoard]:
    """:class:`ScriptedCanBoard`, for tests to start with their channel and answer (and close)."""
    return ScriptedCanBoard


@pytest.fixture(name="wait_for")
def wait_for_fixture() -> Callable:
    """:func:`wait_for` as a fixture."""
    return wait_for
