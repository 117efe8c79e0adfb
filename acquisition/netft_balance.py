"""The ATI Net F/T as a :class:`TimedGaugeBalance`: RDT records as gauge volts, placed on the host clock.

The device streams forces and torques (its own calibration applied inside, scaled by its counts per unit); the
recordings (and ``ornitail process``) hold gauge volts and apply the rig file's ATI calibration to them, as for the
ORNI-DAQ9 board. The gauge volts of a record are therefore the loads through the inverse of the ``.cal`` matrix
(``volts = matrix_si^-1 @ wrench``): exact, as both are linear, when the device's active calibration is the ``.cal``
file's sensor. RDT does not report which calibration the device holds, so that is the operator's to ensure (unlike
the NETCANOEM, whose matrix is read and compared at open).

Timing: each record carries ``ft_sequence``, the device's internal sample counter (7000 per second of its own
crystal). Like the auxiliary board's counter it is mapped to host time by a
:class:`~ornitail.acquisition.aux_clock_model.CounterClockModel` fitted under the blocks' arrival times, so the
records' sampling times are on the host clock (rig time) and :class:`AlignedBalance` interpolates them as it does
the NETCANOEM's polls. When a lower arrival moves the line back, a record it would place at or before one already
delivered is left out (the rows are interpolated across it). While a set point is recorded the line is held
(:meth:`NetFtBalance.hold_alignment`).

Link health: ``rdt_sequence`` gaps are lost samples; datagrams that are not whole records are resyncs and their
bytes garbage. The device's status word (non-zero: e.g. a saturated gauge, manual section 18.2) flags a sample.
"""

from __future__ import annotations

import numpy as np

from ornitail.acquisition import netft_protocol as protocol
from ornitail.acquisition.actuator_interfaces import Reading
from ornitail.acquisition.aux_clock_model import CounterClockModel, CounterUnwrapper
from ornitail.acquisition.balance_interface import (
    BalanceBlock,
    LinkCounts,
    TimedGaugeBalance,
    TimedGauges,
)
from ornitail.acquisition.instrument_errors import InstrumentReplyError
from ornitail.acquisition.netft_driver import NetFtDriver, rdt_rate_problem
from ornitail.calibration.signal_channels import GAUGE_CHANNELS
from ornitail.core.errors import UserInputError


class NetFtBalance(NetFtDriver, TimedGaugeBalance):
    """A Net F/T streaming RDT records at its configured rate; blocks hold the six gauges in volts.

    Parameters
    ----------
    host : str
        The device's address.
    calibration_matrix_si : (6, 6) array
        The ``.cal`` file's matrix, N and N m per gauge volt (``AtiCalibration.matrix_si``).
    rdt_rate_hz : float
        The RDT output rate the device is set to, records/s (``[balance.netft].rdt_rate_hz``); checked against
        the records' ``ft_sequence`` steps.
    Other keyword arguments are :class:`NetFtDriver`'s.
    """

    timing_method = "ft_sequence-to-host-time lower envelope"
    rig_file_key = "[balance.netft]"

    def __init__(
        self,
        host: str,
        *,
        calibration_matrix_si: np.ndarray,
        rdt_rate_hz: float,
        **driver_arguments,
    ) -> None:
        super().__init__(host, **driver_arguments)
        self.volts_per_si = np.linalg.inv(np.asarray(calibration_matrix_si, dtype=float))
        self.rdt_rate_hz = float(rdt_rate_hz)
        self._reset_timing()

    def _reset_timing(self) -> None:
        self._model = CounterClockModel(protocol.INTERNAL_SAMPLE_RATE_HZ)
        self._unwrapper = CounterUnwrapper()
        self._last_counter: tuple[int, int] | None = None  # (ft_sequence unwrapped, rdt_sequence)
        self._last_time_s = -np.inf

    # -- BalanceStream ----------------------------------------------------------------------
    def open(self) -> str:
        """Open the device (:meth:`NetFtDriver.open`); its identity: the scaling in use."""
        scaling = super().open()
        return (
            f"counts_per_force={scaling.counts_per_force:.10g} {scaling.force_unit} "
            f"counts_per_torque={scaling.counts_per_torque:.10g} {scaling.torque_unit}"
        )

    def check_sample_rate(self, sample_rate_hz: float) -> None:
        """The device streams at the RDT rate it is set to: refuse another rate (UserInputError)."""
        problem = rdt_rate_problem(sample_rate_hz)
        if problem is None and sample_rate_hz != self.rdt_rate_hz:
            problem = (
                f"{sample_rate_hz:g} records/s: the device streams at its RDT output rate, "
                f"{self.rdt_rate_hz:g} records/s ([balance.netft].rdt_rate_hz)"
            )
        if problem is not None:
            raise UserInputError(f"{self.name}: sample_rate_hz", problem)

    def start_stream(self, sample_rate_hz: float) -> float:
        """Start RDT streaming (the rate must be the device's, :meth:`check_sample_rate`); records/s."""
        self.check_sample_rate(sample_rate_hz)
        self._reset_timing()
        self.start_streaming()
        return self.rdt_rate_hz

    def stop_stream(self) -> None:
        """Stop streaming (the device's safe state)."""
        self.stop()

    def raise_if_failed(self) -> None:
        """Raise the receiver's error, if it ended with one."""
        if self._failure is not None:
            raise self._failure

    def gauge_volts(self, wrench_si: np.ndarray) -> np.ndarray:
        """(n, 6) N and N m -> (n, 6) gauge volts of the ``.cal`` matrix, V."""
        return np.asarray(wrench_si, dtype=float) @ self.volts_per_si.T

    def read_block(self, timeout_s: float) -> BalanceBlock | None:
        """The next records as gauge volts, counted by their ``rdt_sequence`` (a gap is a lost record)."""
        block = self.get_block(timeout_s=timeout_s)
        if block is None:
            return None
        return BalanceBlock(
            block.rdt_sequence.astype(np.uint32),
            self.gauge_volts(block.wrench),
            block.host_time_s,
            block.status != 0,
        )

    def read_timed_gauges(self, timeout_s: float) -> TimedGauges | None:
        """The next records in gauge volts at their sampling times on the host clock (None after ``timeout_s``).

        Raises
        ------
        InstrumentReplyError
            The records are not ``7000 / rdt_rate_hz`` internal samples apart per ``rdt_sequence`` step: the
            device streams at another rate than the rig file says (lost records are not a wrong rate).
        """
        block = self.get_block(timeout_s=timeout_s)
        if block is None:
            return None
        in_order = self._in_order(block.rdt_sequence)
        if not in_order.any():
            return None
        rdt_sequence, wrench = block.rdt_sequence[in_order], block.wrench[in_order]
        counters = self._unwrapper.unwrap(block.ft_sequence[in_order])
        self._check_record_spacing(counters, rdt_sequence)
        self._model.add(int(counters[-1]), block.host_time_s)
        fit = self._model.fit()
        assert fit is not None
        times = fit.time_of(counters)
        later = times > self._last_time_s
        if not later.any():
            return None
        self._last_time_s = float(times[later][-1])
        flagged = block.status[in_order] != 0
        return TimedGauges(times[later], self.gauge_volts(wrench[later]), flagged[later])

    def _in_order(self, rdt_sequence: np.ndarray) -> np.ndarray:
        """(n,) bool: the records that step ``rdt_sequence`` forward from the newest one kept. A datagram that
        arrives after a later one of an earlier block (reordered by the network; within a block the driver puts
        them back in order) or twice is left out of the timed stream, as a record the counter line places before
        one already delivered is: its ``ft_sequence`` step back would read as the counter wrapping round, 2**32
        samples (seven days) on."""
        keep = np.zeros(len(rdt_sequence), dtype=bool)
        newest = None if self._last_counter is None else self._last_counter[1]
        for index, sequence in enumerate(rdt_sequence.tolist()):
            if newest is None or protocol.sequence_steps(sequence, newest) > 0:
                keep[index] = True
                newest = sequence
        return keep

    def _check_record_spacing(self, counters: np.ndarray, rdt_sequence: np.ndarray) -> None:
        """Every record must advance ``ft_sequence`` by ``7000 / rdt_rate_hz`` internal samples per step of
        ``rdt_sequence``: a lost record advances both, so a burst of lost datagrams is not a wrong rate."""
        records = rdt_sequence.astype(np.int64)
        if self._last_counter is not None:
            counters = np.r_[self._last_counter[0], counters]
            records = np.r_[self._last_counter[1], records]
        self._last_counter = (int(counters[-1]), int(records[-1]))
        record_steps = protocol.sequence_steps(records[1:], records[:-1])
        forward = record_steps > 0
        spacing = np.diff(counters)[forward] / record_steps[forward]
        expected = round(protocol.INTERNAL_SAMPLE_RATE_HZ / self.rdt_rate_hz)
        wrong = spacing[spacing != expected]
        if wrong.size:
            raise InstrumentReplyError(
                self.name,
                f"records from {self.address} are {wrong[0]:g} internal samples apart "
                f"({protocol.INTERNAL_SAMPLE_RATE_HZ / max(wrong[0], 1):g} records/s), not {expected} "
                f"({self.rdt_rate_hz:g} records/s, [balance.netft].rdt_rate_hz): set the device's RDT output "
                "rate or the rig file",
            )

    def hold_alignment(self) -> None:
        """Place records with the ``ft_sequence`` line as it is now, until :meth:`release_alignment`."""
        self._model.hold()

    def release_alignment(self) -> float:
        """Place records with the line refitted under every arrival again; how far it moved while held, s."""
        return self._model.release()

    def sample_time_uncertainty_s(self) -> float:
        """How sharply the ``ft_sequence`` line is known (its envelope), s; 0 before the first block."""
        fit = self._model.fit()
        return 0.0 if fit is None else fit.envelope_s

    def link_counts(self) -> LinkCounts:
        """Lost records (``rdt_sequence`` gaps); datagrams that are not whole records as resyncs and garbage."""
        return LinkCounts(
            lost_samples=self.lost_records,
            garbage_bytes=self.malformed_bytes,
            resyncs=self.malformed_datagrams,
        )

    def adc_limits_v(self) -> tuple[np.ndarray, np.ndarray]:
        """Unbounded: the gauges' ADC is inside the device, which reports saturation in its status word (a
        flagged sample), V."""
        infinite = np.full(len(GAUGE_CHANNELS), np.inf)
        return -infinite, infinite

    # -- rig check (CheckedDevice) ------------------------------------------------------------
    @property
    def route(self) -> str:
        """``udp:host:rdt_port``."""
        return f"udp:{self.address}"

    def check_identity(self) -> tuple[str, str | None]:
        """Counts per unit (rig file or ``netftapi2.xml``) and one RDT record (:meth:`open`)."""
        return self.open(), None

    def check_reading(self) -> Reading:
        """One more RDT record: its status word and the wrench in N and N m (it is never left streaming)."""
        record = self.read_record()
        assert self.counts_per_unit is not None
        wrench = self.counts_per_unit.to_si(record.counts)[0]
        names = ("fx_n", "fy_n", "fz_n", "tx_n_m", "ty_n_m", "tz_n_m")
        reading: Reading = {"status_word": int(record.status[0])}
        reading.update(
            {name: round(float(value), 6) for name, value in zip(names, wrench, strict=True)}
        )
        return reading
