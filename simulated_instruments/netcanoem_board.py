"""Simulated NETCANOEM board on python-can's virtual bus, answering from the tunnel simulator.

The board opens its own ``can.Bus(interface="virtual", channel=...)`` in a thread and answers the
requests of ``docs/instrument-protocols.md``. A gauge read samples the shared tunnel signals at the
current simulated time and digitises the six gauge voltages with the board's ADC
(``GAUGE_VOLTS_PER_COUNT``, clipped to int16: a clipped gauge reads -32768/+32767, i.e. saturated).
Its calibration matrix is the rig's ATI calibration expressed in counts: row i of the board matrix
is
``matrix_si[i] * GAUGE_VOLTS_PER_COUNT * counts_per_unit_i`` (float32), so that
``matrix @ gauges / counts_per_unit`` gives N and N m, the inverse of the digitisation.

Fault injection (for tests): :meth:`inject_error_frames`, :meth:`force_gauge` (hold a gauge at a
value, e.g. saturation), :meth:`set_status_word`, :meth:`unplug` (stop answering and leave the bus).
"""

from __future__ import annotations

import threading

import can
import numpy as np

from ornitail.acquisition import netcanoem_protocol as protocol
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.device import SimulatedDevice
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

GAUGE_VOLTS_PER_COUNT = 10.24 / 32768.0
COUNTS_PER_FORCE = 1_000_000  # counts per N
COUNTS_PER_TORQUE = 1_000_000  # counts per N m
FORCE_UNIT_CODE = 2  # N
TORQUE_UNIT_CODE = 3  # N-m
FIRMWARE = (2, 1, 7)


class SimulatedNetCanOemBoard(SimulatedDevice):
    """A NETCANOEM simulator on a virtual CAN channel.

    Parameters
    ----------
    signals : SharedTunnelSignals
        Source of the six gauge voltages (first six channels).
    clock : SimulatedClock
        Simulated time at which each request samples the signals.
    calibration_matrix_si : (6, 6) array
        Volts to N / N m (``AtiCalibration.matrix_si`` of the rig's sensor).
    channel : str
        Virtual bus channel; the driver must use the same one.
    base_id : int
        7-bit base identifier the board answers on.
    serial_number : str
        Up to 8 ASCII characters.
    """

    def __init__(
        self,
        signals: SharedTunnelSignals,
        clock: SimulatedClock,
        calibration_matrix_si: np.ndarray,
        *,
        channel: str,
        base_id: int = protocol.DEFAULT_BASE_ID,
        serial_number: str = "FT8884",
    ) -> None:
        self.signals = signals
        self.clock = clock
        self.channel = channel
        self.base_id = base_id
        self.serial_number = serial_number
        counts_per_unit = np.array([COUNTS_PER_FORCE] * 3 + [COUNTS_PER_TORQUE] * 3, dtype=float)
        matrix_si = np.asarray(calibration_matrix_si, dtype=float)
        self.board_matrix = (matrix_si * GAUGE_VOLTS_PER_COUNT * counts_per_unit[:, None]).astype(
            np.float32
        )
        self.active_calibration = 0
        self.status_word = 0
        self.requests_answered = 0
        self._forced_gauges: dict[int, int] = {}
        self._pending_error_frames = 0
        self._lock = threading.Lock()
        self._unplugged = threading.Event()
        self._bus = can.Bus(interface="virtual", channel=channel)
        self._prepare_thread("simulated NETCANOEM")

    def _close_transport(self) -> None:
        self._bus.shutdown()

    # -- fault injection --------------------------------------------------------------------
    def inject_error_frames(self, count: int = 1) -> None:
        """Put ``count`` CAN error frames on the bus before the next reply."""
        with self._lock:
            self._pending_error_frames += int(count)

    def force_gauge(self, index: int, counts: int | None) -> None:
        """Hold gauge ``index`` at ``counts`` (e.g. 32767 = saturated); None releases it."""
        with self._lock:
            if counts is None:
                self._forced_gauges.pop(index, None)
            else:
                self._forced_gauges[index] = int(counts)

    def set_status_word(self, status_word: int) -> None:
        """Status word sent with every gauge sample from now on."""
        self.status_word = int(status_word) & 0xFFFF

    def unplug(self) -> None:
        """Stop answering, as a board whose cable was pulled."""
        self._unplugged.set()

    # -- board loop -------------------------------------------------------------------------
    def _run(self) -> None:
        while not self._closing.is_set():
            message = self._bus.recv(0.05)
            if message is None or self._unplugged.is_set():
                continue
            if message.is_error_frame or message.is_extended_id or message.is_remote_frame:
                continue
            base_id, opcode = protocol.split_arbitration_id(message.arbitration_id)
            if base_id != self.base_id:
                continue
            self._answer(opcode, bytes(message.data))

    def _send(self, opcode: int, data: bytes) -> None:
        error_frames = 0
        if self._pending_error_frames:  # read without the lock: the common case has none to send
            with self._lock:
                error_frames, self._pending_error_frames = self._pending_error_frames, 0
        for _ in range(error_frames):
            self._bus.send(
                can.Message(is_error_frame=True, arbitration_id=0x20000004, is_extended_id=True)
            )
        self._bus.send(
            can.Message(
                arbitration_id=protocol.arbitration_id(self.base_id, opcode),
                is_extended_id=False,
                data=data,
            )
        )

    def _answer(self, opcode: int, data: bytes) -> None:
        if opcode == protocol.OPCODE_READ_GAUGES and not data:
            first, second = protocol.encode_gauge_replies(self.status_word, self._gauge_counts())
            self._send(protocol.OPCODE_READ_GAUGES, first)
            self._send(protocol.OPCODE_GAUGES_SECOND_REPLY, second)
        elif opcode == protocol.OPCODE_READ_MATRIX_ROW and len(data) == 1 and data[0] < 6:
            replies = protocol.encode_matrix_row_replies(self.board_matrix[data[0]])
            for reply_opcode, payload in zip(
                protocol.MATRIX_ROW_REPLY_OPCODES, replies, strict=True
            ):
                self._send(reply_opcode, payload)
        elif opcode == protocol.OPCODE_SERIAL_NUMBER and not data:
            self._send(opcode, protocol.encode_serial_number(self.serial_number))
        elif opcode == protocol.OPCODE_SET_ACTIVE_CALIBRATION and len(data) == 1 and data[0] < 16:
            self.active_calibration = data[0]
            self._send(opcode, data)
        elif opcode == protocol.OPCODE_COUNTS_PER_UNIT and not data:
            self._send(opcode, protocol.encode_counts_per_unit(COUNTS_PER_FORCE, COUNTS_PER_TORQUE))
        elif opcode == protocol.OPCODE_UNIT_CODES and not data:
            self._send(opcode, bytes([FORCE_UNIT_CODE, TORQUE_UNIT_CODE]))
        elif opcode == protocol.OPCODE_FIRMWARE_VERSION and not data:
            self._send(opcode, protocol.encode_firmware_version(*FIRMWARE))
        else:
            return
        self.requests_answered += 1

    def _gauge_counts(self) -> np.ndarray:
        volts = self.signals.sample_at(self.clock.now_s())[:6]
        counts = np.clip(np.rint(volts / GAUGE_VOLTS_PER_COUNT), -32768, 32767).astype(np.int16)
        if self._forced_gauges:  # read without the lock: the common case forces none
            with self._lock:
                for index, value in self._forced_gauges.items():
                    counts[index] = value
        return counts
