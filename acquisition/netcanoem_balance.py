"""The ATI NETCANOEM board as a :class:`BalanceStream`: polled gauges, in volts, with sample counters.

The board reports raw gauge counts; the recordings (and ``ornitail process``) hold gauge volts and apply the rig
file's ATI calibration to them, as for the ORNI-DAQ9 board. The volts per gauge count follow from the two
calibrations of the one sensor: the board's own matrix (read at open: ``matrix / counts per unit`` in N or N m per
gauge count) divided element by element by the ``.cal`` file's matrix (N or N m per volt). The ratio must be the
same for every element (within ``CALIBRATION_MATCH_TOLERANCE``): a board holding another sensor's calibration is
refused at open.

A CAN balance alone carries no Hall line, hot-wire or thermocouple: sweeps need the serial board beside it
(``[balance.aux_daq]``, :mod:`aligned_balance`).
"""

from __future__ import annotations

import numpy as np

from ornitail.acquisition import netcanoem_protocol as protocol
from ornitail.acquisition.actuator_interfaces import Reading
from ornitail.acquisition.balance_interface import (
    BalanceBlock,
    LinkCounts,
    TimedGaugeBalance,
    TimedGauges,
)
from ornitail.acquisition.instrument_errors import InstrumentReplyError
from ornitail.acquisition.netcanoem_driver import NetCanOemDriver
from ornitail.calibration.signal_channels import GAUGE_CHANNELS

CALIBRATION_MATCH_TOLERANCE = 1e-3
"""Largest relative spread of (board matrix / .cal matrix) over the elements that matter: the board stores its
matrix as float32 (relative rounding 6e-8), so a larger spread means another sensor's calibration."""


def volts_per_gauge_count(
    board_si_per_count: np.ndarray, cal_si_per_volt: np.ndarray
) -> float | None:
    """The one ratio (V per count) between the board's matrix (SI per count) and the ``.cal`` matrix (SI per V),
    or None when the elements disagree by more than ``CALIBRATION_MATCH_TOLERANCE``."""
    board = np.asarray(board_si_per_count, dtype=float)
    cal = np.asarray(cal_si_per_volt, dtype=float)
    significant = np.abs(cal) > 1e-3 * np.abs(cal).max(axis=1, keepdims=True)
    ratios = board[significant] / cal[significant]
    ratio = float(np.median(ratios))
    if ratio <= 0 or np.max(np.abs(ratios / ratio - 1.0)) > CALIBRATION_MATCH_TOLERANCE:
        return None
    return ratio


class NetCanOemBalance(NetCanOemDriver, TimedGaugeBalance):
    """A NETCANOEM board polled at the stream's rate; blocks hold the six gauges in volts.

    Parameters
    ----------
    calibration_matrix_si : (6, 6) array
        The ``.cal`` file's matrix, N and N m per gauge volt (``AtiCalibration.matrix_si``).
    Other keyword arguments are :class:`NetCanOemDriver`'s.
    """

    timing_method = "request time stamps"
    rig_file_key = "[balance.can]"

    def __init__(self, *, calibration_matrix_si: np.ndarray, **driver_arguments) -> None:
        super().__init__(**driver_arguments)
        self.calibration_matrix_si = np.asarray(calibration_matrix_si, dtype=float)
        self.volts_per_count: float | None = None
        self._next_counter = 0

    # -- BalanceStream ----------------------------------------------------------------------
    def open(self) -> str:
        """Open the bus (:meth:`NetCanOemDriver.open`), read the board's calibration, derive its volts per count.

        Raises
        ------
        InstrumentReplyError
            The board's calibration is not the ``.cal`` file's (another sensor, or another active calibration).
        """
        serial_number = super().open()
        try:
            matrix = self.read_matrix()
            counts_per_unit = self.read_counts_per_unit()
            unit_codes = self.read_unit_codes()
            board_si_per_count = self.wrench_from_gauges(
                np.eye(6), matrix, counts_per_unit, unit_codes
            ).T
            ratio = volts_per_gauge_count(board_si_per_count, self.calibration_matrix_si)
            if ratio is None:
                raise InstrumentReplyError(
                    self.name,
                    f"the board's calibration (serial {serial_number}) does not match the rig file's "
                    "[balance].calibration; select the sensor's calibration on the board or name its .cal file",
                )
            self.volts_per_count = ratio
        except BaseException:
            self.close()
            raise
        return serial_number

    def start_stream(self, sample_rate_hz: float) -> float:
        """Poll at ``sample_rate_hz`` (checked against the bus ceiling); that rate, Hz."""
        self.start_polling(sample_rate_hz)
        return float(sample_rate_hz)

    def stop_stream(self) -> None:
        """End the polling thread."""
        self.stop_polling()

    def raise_if_failed(self) -> None:
        """Raise the poller's error, if it ended with one."""
        if self._failure is not None:
            raise self._failure

    def gauge_volts(self, gauges: np.ndarray) -> np.ndarray:
        """(n, 6) raw gauge counts to volts."""
        if self.volts_per_count is None:
            raise RuntimeError(f"{self.name}: open() before reading gauges in volts")
        return np.asarray(gauges, dtype=float) * self.volts_per_count

    def read_timed_gauges(self, timeout_s: float) -> TimedGauges | None:
        """The next polled samples in volts, each at the time its request was sent (None after ``timeout_s``)."""
        block = self.get_block(timeout_s=timeout_s)
        if block is None:
            return None
        return TimedGauges(block.host_time_s, self.gauge_volts(block.gauges), block.flagged)

    def sample_time_uncertainty_s(self) -> float:
        """The board samples when the request frame has arrived: one DLC-0 frame after its stamp, s."""
        return protocol.classic_can_frame_bits(0, worst_case_stuffing=False) / self.bit_rate

    def read_block(self, timeout_s: float) -> BalanceBlock | None:
        """The next polled samples as gauge volts, counted in the order they were polled."""
        block = self.get_block(timeout_s=timeout_s)
        if block is None:
            return None
        count = len(block.host_time_s)
        counters = (self._next_counter + np.arange(count, dtype=np.int64)).astype(np.uint32)
        self._next_counter += count
        return BalanceBlock(
            counters,
            self.gauge_volts(block.gauges),
            float(block.host_time_s[-1]),
            block.flagged,
        )

    def link_counts(self) -> LinkCounts:
        """Requests without a reply and samples discarded for a foreign frame count as lost."""
        return LinkCounts(
            lost_samples=self.missed_replies + self.discarded_samples,
            foreign_frames=self.foreign_frames,
        )

    def adc_limits_v(self) -> tuple[np.ndarray, np.ndarray]:
        """-32768 and +32767 gauge counts in volts, per gauge."""
        if self.volts_per_count is None:
            raise RuntimeError(f"{self.name}: open() before adc_limits_v()")
        ones = np.ones(len(GAUGE_CHANNELS))
        return -32768 * self.volts_per_count * ones, 32767 * self.volts_per_count * ones

    # -- rig check (CheckedDevice) ------------------------------------------------------------
    @property
    def route(self) -> str:
        """``interface:channel``."""
        return f"{self.interface}:{self.channel}"

    def check_identity(self) -> tuple[str, str | None]:
        """Serial number (:meth:`open`, which also compares the board's calibration) and firmware."""
        serial_number = self.open()
        return f"serial={serial_number} firmware={self.read_firmware_version()}", None

    def check_reading(self) -> Reading:
        """One polled gauge sample: the status word and the six gauges in counts (it is never left polling)."""
        gauges = self.read_gauges()
        reading: Reading = {"status_word": int(gauges.status_word)}
        reading.update(
            {f"gauge_{index}_counts": int(value) for index, value in enumerate(gauges.gauges)}
        )
        return reading
