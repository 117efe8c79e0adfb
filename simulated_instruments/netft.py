"""A simulated ATI Net F/T on the loopback: RDT over real UDP and ``netftapi2.xml`` over real HTTP.

The protocol is ATI's (:mod:`ornitail.acquisition.netft_protocol`); this simulator is ornitail's own, written
from the manual, not ATI's firmware. One thread answers the RDT requests on a UDP socket bound to 127.0.0.1 and
streams records to the address that sent the last start request, paced by the monotonic clock: at each wake-up
it sends every record that is due (a burst after a late wake-up), so the average rate is the set rate. Another
thread serves ``/netftapi2.xml`` with the simulator's counts per unit and units (``http.server``).

Loads come from ``load_function(times_s) -> (n, 6)`` (Fx Fy Fz in N, Tx Ty Tz in N m, sensor frame) at the
times the device took the records' samples, on ``clock`` (by default seconds since power-up, so ``ft_sequence /
7000``); they are converted to counts with the simulator's counts per unit (rounded to the nearest count) less the
software bias. On a simulated rig ``clock`` is the rig's simulated clock, the loads are the shared tunnel signals'
and the device's own crystal runs ``rate_error_ppm`` off nominal (its ``ft_sequence`` is not the host's time, as on
a real device). Fault injection: ``drop_rdt_sequences`` (records of a continuous stream numbered so are counted but
not sent), ``late_rdt_sequences`` (records numbered so are sent after the record that follows them, as a network
that reorders datagrams delivers them), :meth:`set_status`.
"""

from __future__ import annotations

import select
import socket
import threading
import time
from collections.abc import Callable, Iterable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np

from ornitail.acquisition import netft_protocol as protocol
from ornitail.simulated_instruments.device import SimulatedDevice

LoadFunction = Callable[[np.ndarray], np.ndarray]
"""(n,) device times, s -> (n, 6) Fx Fy Fz in N and Tx Ty Tz in N m."""

IDLE_WAIT_S = 0.05
STREAMING_WAIT_S = 0.0005


def constant_load(wrench_si: Iterable[float]) -> LoadFunction:
    """A load function that always returns ``wrench_si`` (6 values, N and N m)."""
    wrench = np.asarray(list(wrench_si), dtype=np.float64).reshape(1, 6)
    return lambda times_s: np.repeat(wrench, len(times_s), axis=0)


def _seconds_since(start_s: float) -> Callable[[], float]:
    """A clock reading monotonic seconds since ``start_s``."""
    return lambda: time.monotonic() - start_s


def zero_load(times_s: np.ndarray) -> np.ndarray:
    """No load: the default load function."""
    return np.zeros((len(times_s), 6))


class SimulatedNetFt(SimulatedDevice):
    """A Net F/T simulator on 127.0.0.1.

    Parameters
    ----------
    load_function : callable
        Loads at the records' device times, see :data:`LoadFunction`.
    rate_hz : float
        RDT output rate, records/s: 7000 divided by a whole number (7000, 3500, 2333.3, ...).
    counts_per_unit : CountsPerUnit
        Scaling served in ``netftapi2.xml`` and used to digitise the loads.
    rdt_port, http_port : int
        Ports to bind; 0 picks a free one (read the bound ports from the attributes).
    drop_rdt_sequences : iterable of int
        ``rdt_sequence`` numbers never sent in a stream until stopped (sample count 0), counted in
        :attr:`records_dropped`; a request for a given number of records is always answered whole.
    late_rdt_sequences : iterable of int
        ``rdt_sequence`` numbers sent just after the next record of the stream instead of before it.
    clock : callable returning s, or None
        The time records are paced by and loads taken at (a rig's simulated clock); None: the monotonic clock,
        counted from power-up (construction).
    rate_error_ppm : float
        How much faster than 7000 samples per ``clock`` second the device's internal sampling runs, ppm.
    """

    def __init__(
        self,
        load_function: LoadFunction = zero_load,
        *,
        rate_hz: float = protocol.INTERNAL_SAMPLE_RATE_HZ,
        counts_per_unit: protocol.CountsPerUnit | None = None,
        rdt_port: int = 0,
        http_port: int = 0,
        drop_rdt_sequences: Iterable[int] = (),
        late_rdt_sequences: Iterable[int] = (),
        clock: Callable[[], float] | None = None,
        rate_error_ppm: float = 0.0,
    ) -> None:
        samples_per_record = protocol.INTERNAL_SAMPLE_RATE_HZ / rate_hz
        if not (rate_hz > 0 and samples_per_record >= 1 and samples_per_record.is_integer()):
            raise ValueError(f"RDT rate {rate_hz:g} Hz must be 7000 Hz divided by a whole number")
        self.host = "127.0.0.1"
        self.load_function = load_function
        self.rate_hz = float(rate_hz)
        self.counts_per_unit = counts_per_unit or protocol.CountsPerUnit(1_000_000, 1_000_000)
        self.drop_rdt_sequences = frozenset(int(n) for n in drop_rdt_sequences)
        self.late_rdt_sequences = frozenset(int(n) for n in late_rdt_sequences)
        self._held_datagram: bytes | None = None  # a late record, sent after the next one
        self.commands_received: list[int] = []
        self.records_sent = 0
        self.records_dropped = 0
        self.streaming = False
        self._samples_per_record = int(samples_per_record)
        self._status = 0
        self._bias_counts = np.zeros(6, dtype=np.int64)
        self._client: tuple[str, int] | None = None
        self._stream_first_sample = 0  # ft_sequence of the stream's first record (unwrapped)
        self._stream_limit = 0  # records the request asked for; 0 = until stopped
        self._stream_position = 0  # records of this request generated so far (sent or dropped)
        if clock is None:
            clock, power_up_s = _seconds_since(time.monotonic()), 0.0
        else:
            power_up_s = clock()
        self._clock = clock
        self._power_up_s = power_up_s  # internal sample k is taken at power-up + k / true rate
        self.true_internal_rate_hz = protocol.INTERNAL_SAMPLE_RATE_HZ * (
            1.0 + rate_error_ppm * 1e-6
        )
        self._lock = threading.Lock()
        self._udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._udp.bind((self.host, rdt_port))  # blocking: a full send buffer waits, loses nothing
        self.rdt_port: int = self._udp.getsockname()[1]
        self._http = ThreadingHTTPServer((self.host, http_port), self._http_handler())
        self._http.daemon_threads = True
        self.http_port: int = self._http.server_address[1]
        self._http_thread = threading.Thread(
            target=self._http.serve_forever, name="simulated Net F/T web server", daemon=True
        )
        self._prepare_thread("simulated Net F/T")

    def start(self) -> SimulatedNetFt:
        """Start answering RDT requests and serving ``netftapi2.xml``; returns self."""
        self._http_thread.start()
        return super().start()

    def _close_transport(self) -> None:
        if self._http_thread.is_alive():
            self._http.shutdown()
        self._http.server_close()
        self._udp.close()

    def set_status(self, status: int) -> None:
        """Status word sent with every record from now on (0 = healthy)."""
        with self._lock:
            self._status = int(status) & 0xFFFFFFFF

    def netftapi2_xml(self) -> str:
        """The page served at ``/netftapi2.xml``."""
        return protocol.format_netftapi2(
            self.counts_per_unit,
            extra={
                "prodname": "ornitail simulated Net F/T",
                "comrdtrate": f"{self.rate_hz:g}",
                "runrate": f"{protocol.INTERNAL_SAMPLE_RATE_HZ:g}",
            },
        )

    # -- device loop ------------------------------------------------------------------------
    def _run(self) -> None:
        while not self._closing.is_set():
            wait_s = STREAMING_WAIT_S if self.streaming else IDLE_WAIT_S
            readable, _, _ = select.select([self._udp], [], [], wait_s)
            if readable:
                self._read_requests()
            if self.streaming:
                self._send_due_records()

    def _read_requests(self) -> None:
        while True:
            try:
                data, sender = self._udp.recvfrom(2048, socket.MSG_DONTWAIT)
            except BlockingIOError:
                return
            try:
                command, sample_count = protocol.decode_request(data)
            except ValueError:
                continue  # the device ignores what is not an RDT request
            self._answer(command, sample_count, sender)

    def _answer(self, command: int, sample_count: int, sender: tuple[str, int]) -> None:
        with self._lock:
            self.commands_received.append(command)
            if command == protocol.COMMAND_STOP_STREAMING:
                self.streaming = False
            elif command in (
                protocol.COMMAND_START_REALTIME_STREAMING,
                protocol.COMMAND_START_BUFFERED_STREAMING,
            ):
                self._client = sender
                elapsed_s = self._clock() - self._power_up_s
                self._stream_first_sample = int(np.ceil(elapsed_s * self.true_internal_rate_hz))
                self._stream_limit = sample_count
                self._stream_position = 0
                self._held_datagram = None  # a late record of an earlier stream is never sent
                self.streaming = True
            elif command == protocol.COMMAND_SET_SOFTWARE_BIAS:
                loads = self.load_function(np.array([self._clock()]))
                self._bias_counts = self.counts_per_unit.to_counts(loads)[0].astype(np.int64)

    def sample_time_s(self, ft_sequence: np.ndarray) -> np.ndarray:
        """Time on ``clock`` at which the device took the internal samples ``ft_sequence`` (unwrapped), s."""
        return self._power_up_s + np.asarray(ft_sequence, dtype=float) / self.true_internal_rate_hz

    def _send_due_records(self) -> None:
        elapsed_samples = (self._clock() - self._power_up_s) * self.true_internal_rate_hz
        with self._lock:
            first_sample = self._stream_first_sample
            due = int((elapsed_samples - first_sample) // self._samples_per_record) + 1
            if self._stream_limit:
                due = min(due, self._stream_limit)
            first, count = self._stream_position, due - self._stream_position
            if count <= 0:
                return
            self._stream_position = due
            if self._stream_limit and due >= self._stream_limit:
                self.streaming = False
            client, status, bias = self._client, self._status, self._bias_counts
            drop = self._stream_limit == protocol.INFINITE_SAMPLES
        positions = np.arange(first, first + count, dtype=np.int64)
        rdt_sequence = (positions + 1) % protocol.SEQUENCE_MODULUS
        ft_sequence = first_sample + positions * self._samples_per_record
        loads = self.load_function(self.sample_time_s(ft_sequence))
        counts = np.clip(
            self.counts_per_unit.to_counts(loads).astype(np.int64) - bias, -(2**31), 2**31 - 1
        )
        records = protocol.RdtRecords(
            rdt_sequence=rdt_sequence,
            ft_sequence=ft_sequence % protocol.SEQUENCE_MODULUS,
            status=np.full(count, status, dtype=np.uint32),
            counts=counts,
        )
        payload = memoryview(protocol.encode_records(records))
        for index, sequence in enumerate(rdt_sequence.tolist()):
            if drop and sequence in self.drop_rdt_sequences:
                self.records_dropped += 1
                continue
            start = index * protocol.RECORD_LENGTH
            datagram = payload[start : start + protocol.RECORD_LENGTH]
            if sequence in self.late_rdt_sequences and self._held_datagram is None:
                self._held_datagram = bytes(datagram)  # kept past this call's payload
                continue
            self._udp.sendto(datagram, client)
            self.records_sent += 1
            if self._held_datagram is not None:
                self._udp.sendto(self._held_datagram, client)
                self._held_datagram = None
                self.records_sent += 1

    def _http_handler(self) -> type[BaseHTTPRequestHandler]:
        simulator = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 (http.server's name)
                if self.path.split("?")[0] != protocol.XML_PAGE:
                    self.send_error(404)
                    return
                body = simulator.netftapi2_xml().encode("ascii")
                self.send_response(200)
                self.send_header("Content-Type", "text/xml")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, format: str, *args: object) -> None:  # noqa: A002
                return

        return Handler
