"""The one interface the rig and the live stream use for a balance, whatever device and transport carry it.

Like python-can's ``BusABC`` (and :mod:`actuator_interfaces` for the actuators): :class:`Rig` and
:class:`LiveBalance` know only :class:`BalanceStream`; a backend (the ORNI-DAQ9 serial board, the ATI NETCANOEM on
CAN, or either of the CAN balance with the serial board as an auxiliary acquisition, see :mod:`balance_backends`)
implements it. Blocks are in volts in ``daq_protocol.CHANNEL_NAMES`` order (six gauges, hot-wire bridge,
thermocouple, Hall line) with one sample counter per row, so recordings look the same whichever backend made them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ornitail.acquisition.actuator_interfaces import Reading
from ornitail.calibration.signal_channels import GAUGE_CHANNELS


@dataclass
class BalanceBlock:
    """Consecutive rows of a balance stream.

    counters : (n,) unsigned sample counters (consecutive unless samples were lost).
    volts : (n, channels) float64, V, in the backend's :attr:`BalanceStream.channel_names` order.
    host_time_s : when the block reached the host (arrival, not sampling, time), in the backend's clock, s.
    saturated : (n,) bool, a channel at its ADC limit or the device's over-range status (None: not known).
    """

    counters: np.ndarray
    volts: np.ndarray
    host_time_s: float
    saturated: np.ndarray | None = field(default=None)


@dataclass(frozen=True)
class LinkCounts:
    """Running totals of a stream's link health since it was opened: CRC failures, samples lost (counter gaps),
    bytes outside valid frames and the stretches of them (resyncs), frames of another node with the device's ids."""

    crc_failures: int = 0
    lost_samples: int = 0
    garbage_bytes: int = 0
    resyncs: int = 0
    foreign_frames: int = 0


class CheckedDevice(ABC):
    """One device behind a balance as ``ornitail rig check`` checks it, in a row of its own: identify it, read one
    sample, leave it not streaming, close. Nothing is moved."""

    name: str
    """Instrument name used in messages and in the check's row."""
    rig_file_key: str
    """Where the rig file sets the device's route (``[balance.serial_daq].port``)."""

    @property
    @abstractmethod
    def route(self) -> str:
        """Where it is connected: a port path, ``interface:channel`` or ``udp:host:port``."""

    @abstractmethod
    def check_identity(self) -> tuple[str, str | None]:
        """Open the device exclusively and identify it: its identity as text, and why it is not the model its driver
        speaks (None when it is). Raises ``InstrumentError``; :meth:`close` is safe after it."""

    @abstractmethod
    def check_reading(self) -> Reading:
        """One sample, keyed with its unit (``gauge_0_v``, ``fx_n``)."""

    @abstractmethod
    def safe_state(self) -> None:
        """Not streaming."""

    @abstractmethod
    def close(self) -> None:
        """Close; safe to call twice or after a failure."""


class BalanceStream(ABC):
    """A balance (possibly with an auxiliary acquisition) that streams blocks of samples.

    Life cycle: ``open()`` (exclusive, identified, not streaming), ``start_stream(rate)``, ``read_block()`` until
    ``stop_stream()``, ``close()``. The safe state of a balance is "not streaming" (:meth:`safe_state`).
    """

    name: str
    """Instrument name used in messages ("acquisition board", "NETCANOEM balance")."""

    @property
    @abstractmethod
    def channel_names(self) -> tuple[str, ...]:
        """Names of the columns of :attr:`BalanceBlock.volts`."""

    @property
    def carries_flap_channels(self) -> bool:
        """True when the blocks hold the hot-wire, thermocouple and Hall line with the gauges (a sweep needs them)."""
        return {"hotwire_bridge_v", "thermocouple_v", "hall_v"} <= set(self.channel_names)

    @abstractmethod
    def open(self) -> Any:
        """Open the port or bus exclusively, bring the device to a known state, identify it (returned)."""

    @abstractmethod
    def close(self) -> None:
        """Stop streaming if needed and close; safe to call twice or after a failure."""

    @abstractmethod
    def start_stream(self, sample_rate_hz: float) -> float:
        """Start streaming at ``sample_rate_hz`` (samples per rig second); return the rate the device runs at."""

    @abstractmethod
    def stop_stream(self) -> None:
        """Stop streaming; raises the reader's error if it ended with one."""

    @abstractmethod
    def read_block(self, timeout_s: float) -> BalanceBlock | None:
        """The next block, or None after ``timeout_s``; raises the stream's error (e.g. ``InstrumentDisconnected``)."""

    @abstractmethod
    def raise_if_failed(self) -> None:
        """Raise the stream's error, if it ended with one."""

    @abstractmethod
    def link_counts(self) -> LinkCounts:
        """Link health since the stream was opened."""

    @property
    @abstractmethod
    def blocks_dropped(self) -> int:
        """Blocks the driver discarded because its consumer did not keep up."""

    @abstractmethod
    def adc_limits_v(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) volts of the analog channels' ADC ranges (the first 8 of ``CHANNEL_NAMES``), V; a value at
        or beyond them is clipped. Valid once open."""

    def safe_state(self) -> None:
        """Not streaming (a balance moves nothing): stop the stream if it runs."""
        self.stop_stream()

    def alignment_values(self) -> dict[str, float | int]:
        """How well the devices of the stream are aligned in time, for a set point's journal entry (empty for a
        single device, whose channels share one sample clock)."""
        return {}

    def hold_alignment(self) -> None:
        """Keep placing samples on the host clock as now until :meth:`release_alignment` (a set point's record is
        taken in between); nothing to hold for a single device or a balance stamped by its own requests."""
        return None

    def release_alignment(self) -> float:
        """Let the placement on the host clock follow the devices' timing again; how far it moved while held, s
        (0 for a single device)."""
        return 0.0

    def recording_description(self) -> dict[str, Any]:
        """What a recording stores about this stream beyond the rig file's route (empty: nothing more)."""
        return {}

    @abstractmethod
    def checked_devices(self) -> tuple[CheckedDevice, ...]:
        """The devices behind the stream, each checked on its own by ``ornitail rig check`` (one row each)."""


@dataclass
class TimedGauges:
    """Gauge samples placed on the host clock.

    sample_time_s : (n,) increasing host (rig) time at which each sample was taken, s.
    volts : (n, 6) float64 gauge volts, V. flagged : (n,) bool, a saturated gauge or the device's status.
    """

    sample_time_s: np.ndarray
    volts: np.ndarray
    flagged: np.ndarray


class TimedGaugeBalance(BalanceStream, CheckedDevice):
    """A balance that carries only the six gauges and knows when, on the host clock, each sample was taken: what
    :class:`~ornitail.acquisition.aligned_balance.AlignedBalance` puts beside the auxiliary board (the NETCANOEM,
    stamped by its requests; the Net F/T, placed by a clock model of its own sample counter)."""

    timing_method: str
    """How the samples are placed on the host clock, for ``run.json``."""
    _blocks_dropped_count: int = 0

    @property
    def blocks_dropped(self) -> int:
        """Blocks discarded because the queue was full."""
        return self._blocks_dropped_count

    @blocks_dropped.setter
    def blocks_dropped(self, value: int) -> None:
        self._blocks_dropped_count = int(value)

    @property
    def channel_names(self) -> tuple[str, ...]:
        """The six gauges."""
        return GAUGE_CHANNELS

    def checked_devices(self) -> tuple[CheckedDevice, ...]:
        """The balance itself: one device."""
        return (self,)

    @abstractmethod
    def check_sample_rate(self, sample_rate_hz: float) -> None:
        """Refuse (``UserInputError``) a rate the device or its transport cannot deliver, samples/s."""

    @abstractmethod
    def read_timed_gauges(self, timeout_s: float) -> TimedGauges | None:
        """The next samples with their host sampling times, or None after ``timeout_s`` (s)."""

    @abstractmethod
    def sample_time_uncertainty_s(self) -> float:
        """How late, at most and not counting the transport's floor, a sample's host time may be, s."""
