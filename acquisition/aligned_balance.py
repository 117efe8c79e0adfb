"""A gauge balance (ATI NETCANOEM on CAN, ATI Net F/T over UDP) with the ORNI-DAQ9 serial board beside it as
auxiliary acquisition, aligned on the host clock. One class serves both routes: the balance is any
:class:`~ornitail.acquisition.balance_interface.TimedGaugeBalance`, which places its own samples on the host clock.

- The NETCANOEM is polled: each gauge sample is stamped with the host time its request was sent (the board samples
  when the request arrives, one CAN frame later: 47 bit times, 47 us at 1 Mbit/s).
- The Net F/T streams records numbered by its own sample counter (``ft_sequence``, 7000 per s of its crystal); that
  counter is mapped to host time by a :class:`~ornitail.acquisition.aux_clock_model.CounterClockModel`, exactly as
  the auxiliary board's.
- The serial board samples the hot-wire bridge, the thermocouple and the Hall line on its own crystal and stamps
  nothing; its sample counter is mapped to host time by a ``CounterClockModel`` (the line under the block arrival
  times).

All are thus on one clock, the host's (rig time).

The stream's rows lie on a uniform grid of that clock, row ``k`` at ``t0 + k / rate`` (``rate``: the sweep's sample
rate, by default the auxiliary board's), so a recording looks exactly like the single-board one (nine channels in
``CHANNEL_NAMES`` order, consecutive counters, one sample rate) and processing reads it unchanged; the balance runs
at its own rate (``[balance.can].sample_rate_hz`` polls, ``[balance.netft].rdt_rate_hz`` records per second). Rows as
dense as the auxiliary board's samples keep the Hall edges as sharp as the single board's: cycle averaging cuts
cycles at whole rows, and at the balance's rate (0.5-1 kHz, 40-70 rows per flap) that cut alone biased the cycle
means by a few mN. At each row the gauges are interpolated linearly between the two balance samples around it (over
a whole flap this is the trapezoid rule on them, exact for the mean up to harmonics near the balance's rate), the
hot-wire and thermocouple linearly between the two auxiliary samples around it, and the Hall line is the auxiliary
sample at or before it (its edges keep the auxiliary board's resolution). A row without both balance samples within
``MAX_POLL_GAP_PERIODS`` periods, or without its two auxiliary samples, is not emitted: its counter is missing, so the
recording shows the loss as a counter gap.

Each set point's journal entry gets the alignment of the auxiliary clock (:meth:`AlignedBalance.alignment_values`).
While a set point's record is taken both lines are held (:meth:`AlignedBalance.hold_alignment`): a line refitted
inside the record moved one device's samples against the other's by 0.2-7 ms at a time on a loaded host, which cut or
repeated that much of a flap and moved the cycle means by several of their sigmas.
"""

from __future__ import annotations

import contextlib
import queue
from collections.abc import Callable
from typing import Any

import numpy as np

from ornitail.acquisition.aux_clock_model import ClockFit, CounterClockModel, CounterUnwrapper
from ornitail.acquisition.balance_interface import (
    BalanceBlock,
    BalanceStream,
    CheckedDevice,
    LinkCounts,
    TimedGaugeBalance,
)
from ornitail.acquisition.daq_protocol import CHANNEL_NAMES
from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.serial_daq_driver import SerialDaqDriver

MAX_POLL_GAP_PERIODS = 3.0
"""Rows between two balance samples further apart than this many of the balance's periods are lost (a missed reply,
a stalled poller, lost records)."""
MAX_BLOCKS_PER_READ = 64
"""At most this many blocks of each device are merged per :meth:`AlignedBalance.read_block` call, so one call stays
short however far the reader fell behind (a few seconds of blocks at the drivers' block periods)."""
AUX_COLUMNS = slice(6, 9)
"""Hot-wire bridge, thermocouple, Hall line: the auxiliary board's columns the stream takes."""


class AlignedBalance(BalanceStream):
    """Gauges from ``balance``, hot-wire, thermocouple and Hall line from ``aux``, on one grid of the host clock.

    Parameters
    ----------
    balance : TimedGaugeBalance
        The gauge balance, NETCANOEM or Net F/T (its clock must be ``clock``).
    aux : SerialDaqDriver
        The auxiliary ORNI-DAQ9 board (its clock must be ``clock``).
    aux_sample_rate_hz : float
        The auxiliary board's rate, samples per clock second (``[balance.aux_daq].sample_rate_hz``).
    balance_rate_hz : float
        The balance's rate, samples per clock second (CAN polls, Net F/T records).
    clock : callable returning s
        The host clock both devices are stamped with (rig time).
    """

    def __init__(
        self,
        balance: TimedGaugeBalance,
        aux: SerialDaqDriver,
        *,
        aux_sample_rate_hz: float,
        balance_rate_hz: float,
        clock: Callable[[], float],
    ) -> None:
        self.balance = balance
        self.aux = aux
        self.name = f"{balance.name} with {aux.name}"
        self.aux_sample_rate_hz = float(aux_sample_rate_hz)
        self.balance_rate_hz = float(balance_rate_hz)
        self._clock = clock
        self._rate_hz = 0.0
        self._reset()

    def _reset(self) -> None:
        self._model = CounterClockModel(self.aux_sample_rate_hz)
        self._t0 = 0.0
        self._next_row = 0
        self._rows_lost = 0
        self._moved_while_held_s = 0.0
        self._poll_times = np.empty(0)
        self._poll_volts = np.empty((0, 6))
        self._poll_flags = np.empty(0, dtype=bool)
        self._aux_counters = np.empty(0, dtype=np.int64)
        self._aux_volts = np.empty((0, 3))
        self._aux_flags = np.empty(0, dtype=bool)
        self._aux_unwrapper = CounterUnwrapper()

    # -- BalanceStream ----------------------------------------------------------------------
    @property
    def channel_names(self) -> tuple[str, ...]:
        """The nine channels of ``CHANNEL_NAMES``, as the ORNI-DAQ9 alone records them."""
        return tuple(CHANNEL_NAMES)

    @property
    def blocks_dropped(self) -> int:
        """Blocks either driver discarded."""
        return self.balance.blocks_dropped + self.aux.blocks_dropped

    def open(self) -> str:
        """Open the balance, then the auxiliary board (the balance is closed again if the board fails)."""
        serial_number = self.balance.open()
        try:
            identity = self.aux.open()
        except BaseException:
            self.balance.close()
            raise
        return f"{self.balance.name} {serial_number}; {identity.model} {identity.serial_number}"

    def checked_devices(self) -> tuple[CheckedDevice, ...]:
        """The gauge balance and the auxiliary board: two devices, each checked on its own."""
        return (*self.balance.checked_devices(), *self.aux.checked_devices())

    def close(self) -> None:
        """Close both; the balance's error (if any) is raised after the board was closed."""
        try:
            self.balance.close()
        finally:
            self.aux.close()

    def start_stream(self, sample_rate_hz: float) -> float:
        """Start the auxiliary board at its rate, then the balance at its rate; rows at ``sample_rate_hz``
        (returned)."""
        self._reset()
        self._rate_hz = float(sample_rate_hz)
        self.balance.check_sample_rate(self.balance_rate_hz)
        self.aux.start_stream(self.aux_sample_rate_hz)
        try:
            self._t0 = self._clock()
            self.balance.start_stream(self.balance_rate_hz)
        except BaseException:
            with contextlib.suppress(InstrumentError):
                self.aux.stop_stream()
            raise
        return self._rate_hz

    def stop_stream(self) -> None:
        """Stop both streams; the first error is raised once both were stopped."""
        try:
            self.balance.stop_stream()
        finally:
            self.aux.stop_stream()

    def raise_if_failed(self) -> None:
        """Raise either stream's error."""
        self.balance.raise_if_failed()
        self.aux.raise_if_failed()

    def link_counts(self) -> LinkCounts:
        """The serial link's counts; lost samples: the grid rows not emitted (any device's loss shows there)."""
        aux = self.aux.link_counts()
        return LinkCounts(
            crc_failures=aux.crc_failures,
            lost_samples=self._rows_lost,
            garbage_bytes=aux.garbage_bytes,
            resyncs=aux.resyncs,
            foreign_frames=self.balance.link_counts().foreign_frames,
        )

    def adc_limits_v(self) -> tuple[np.ndarray, np.ndarray]:
        """The balance's gauge limits, then the auxiliary board's hot-wire and thermocouple limits, V."""
        gauge_low, gauge_high = self.balance.adc_limits_v()
        aux_low, aux_high = self.aux.adc_limits_v()
        return np.concatenate((gauge_low, aux_low[6:8])), np.concatenate(
            (gauge_high, aux_high[6:8])
        )

    def read_block(self, timeout_s: float) -> BalanceBlock | None:
        """The grid rows both devices now cover (None when none after ``timeout_s``).

        Every balance block and auxiliary block waiting is taken (up to ``MAX_BLOCKS_PER_READ`` of each), each pile
        grown by one concatenation: a reader that took one balance block per call while stacking every auxiliary
        block onto its pile fell behind for good once the host was busy (the pile it re-copied grew with the lag).
        """
        self._take_aux_blocks()
        taken = []
        gauges = self.balance.read_timed_gauges(timeout_s)
        while gauges is not None:
            taken.append(gauges)
            if len(taken) >= MAX_BLOCKS_PER_READ:
                break
            gauges = self.balance.read_timed_gauges(0.0)
        if taken:
            self._poll_times = np.concatenate([self._poll_times, *(g.sample_time_s for g in taken)])
            self._poll_volts = np.vstack([self._poll_volts, *(g.volts for g in taken)])
            self._poll_flags = np.concatenate([self._poll_flags, *(g.flagged for g in taken)])
        self._take_aux_blocks()
        return self._emit()

    def alignment_values(self) -> dict[str, float | int]:
        """The auxiliary clock's fit: rate error (ppm), latency jitter (rms, max), the envelope's sharpness, how far
        the balance's line moved against the board's while the last record held them, and the alignment estimate
        (that envelope, plus the balance's own timing uncertainty: the CAN request frame or the Net F/T counter
        line's envelope, plus that move: the held lines were off by as much), s; points fitted, the balance's rate
        and grid rows lost."""
        fit = self._model.fit()
        if fit is None:
            return {}
        return {
            "aux_clock_rate_error_ppm": fit.rate_error_ppm,
            "aux_clock_jitter_rms_s": fit.jitter_rms_s,
            "aux_clock_jitter_max_s": fit.jitter_max_s,
            "aux_clock_envelope_s": fit.envelope_s,
            "alignment_moved_while_held_s": self._moved_while_held_s,
            "alignment_error_estimate_s": fit.envelope_s
            + self.balance.sample_time_uncertainty_s()
            + abs(self._moved_while_held_s),
            "aux_clock_points": fit.points,
            "balance_sample_rate_hz": self.balance_rate_hz,
            "aligned_rows_lost": self._rows_lost,
        }

    def hold_alignment(self) -> None:
        """Hold both counter lines (the auxiliary board's and the balance's) as they are now: rows emitted until
        :meth:`release_alignment` place every device's samples with one line each."""
        self._model.hold()
        self.balance.hold_alignment()

    def release_alignment(self) -> float:
        """Let both lines follow their arrivals again; how far the balance's line moved against the auxiliary
        board's while they were held, s (kept for :meth:`alignment_values`)."""
        aux_moved_s = self._model.release()
        self._moved_while_held_s = self.balance.release_alignment() - aux_moved_s
        return self._moved_while_held_s

    def recording_description(self) -> dict[str, Any]:
        """The auxiliary board and the alignment method, for ``run.json``'s ``rig``."""
        return {
            "aux_daq": {
                "instrument": self.aux.name,
                "port": self.aux.port,
                "sample_rate_hz": self.aux_sample_rate_hz,
            },
            "alignment": {
                "method": "counter-to-host-time lower envelope (aux); "
                f"{self.balance.timing_method} (balance)",
                "grid": "rows at t0 + k / sample_rate_hz of the host clock",
                "balance_sample_rate_hz": self.balance_rate_hz,
            },
        }

    def time_of_aux_counter(self, counters: np.ndarray) -> np.ndarray | None:
        """Host time the model gives the auxiliary board's (unwrapped) counters, s (None before its first block)."""
        fit = self._model.fit()
        return None if fit is None else fit.time_of(counters)

    # -- merging ----------------------------------------------------------------------------
    def _take_aux_blocks(self) -> None:
        counters_taken, volts_taken, flags_taken = [], [], []
        low, high = self.aux.adc_limits_v()
        try:
            while len(counters_taken) < MAX_BLOCKS_PER_READ:
                try:
                    block = self.aux.blocks.get_nowait()
                except queue.Empty:
                    return
                if block is None:
                    self.aux.raise_if_failed()
                    return
                counters = self._aux_unwrapper.unwrap(block.counters)
                counters_taken.append(counters)
                volts_taken.append(block.volts[:, AUX_COLUMNS])
                # a clipped hot-wire or thermocouple (the board's status bit also covers its unused gauge inputs)
                analog = block.volts[:, 6:8]
                flags_taken.append(((analog <= low[6:8]) | (analog >= high[6:8])).any(axis=1))
                self._model.add(int(counters[-1]), block.host_time_s)
        finally:
            if counters_taken:
                self._aux_counters = np.concatenate([self._aux_counters, *counters_taken])
                self._aux_volts = np.vstack([self._aux_volts, *volts_taken])
                self._aux_flags = np.concatenate([self._aux_flags, *flags_taken])

    def _emit(self) -> BalanceBlock | None:
        fit = self._model.fit()
        if fit is None or len(self._poll_times) < 2 or len(self._aux_counters) < 2:
            return None
        period = 1.0 / self._rate_hz
        covered_s = min(self._poll_times[-1], float(fit.time_of(self._aux_counters[-1])))
        aux_first_s = float(fit.time_of(self._aux_counters[0]))
        started_s = max(self._poll_times[0], aux_first_s)
        first_row = max(self._next_row, int(np.ceil((started_s - self._t0) / period)))
        last_row = int(np.floor((covered_s - self._t0) / period))
        if last_row < first_row:
            return None
        rows = np.arange(first_row, last_row + 1)
        times = self._t0 + rows * period
        gauges, gauge_ok, gauge_flags = self._gauges_at(times, 1.0 / self.balance_rate_hz)
        aux, aux_ok, aux_flags = self._aux_at(fit.counter_at(times))
        ok = gauge_ok & aux_ok
        self._rows_lost += int(np.count_nonzero(~ok))
        self._next_row = last_row + 1
        self._trim(times[-1], fit)
        if not ok.any():
            return None
        volts = np.hstack((gauges, aux))[ok]
        return BalanceBlock(
            rows[ok].astype(np.uint32), volts, self._clock(), (gauge_flags | aux_flags)[ok]
        )

    def _gauges_at(
        self, times: np.ndarray, period: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        polls = self._poll_times
        after = np.clip(np.searchsorted(polls, times, side="right"), 1, len(polls) - 1)
        before = after - 1
        span = polls[after] - polls[before]
        ok = (
            (polls[before] <= times)
            & (times <= polls[after])
            & (span <= MAX_POLL_GAP_PERIODS * period)
        )
        weight = np.where(span > 0, (times - polls[before]) / np.where(span > 0, span, 1.0), 0.0)
        low, high = self._poll_volts[before], self._poll_volts[after]
        gauges = low + (high - low) * weight[:, None]
        return gauges, ok, self._poll_flags[before] | self._poll_flags[after]

    def _aux_at(self, fractional: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        counters = self._aux_counters
        after = np.clip(np.searchsorted(counters, fractional, side="right"), 1, len(counters) - 1)
        before = after - 1
        ok = (counters[before] <= fractional) & (fractional <= counters[after])
        ok &= (
            counters[after] - counters[before] == 1
        )  # a lost auxiliary sample loses the rows beside it
        weight = np.clip(fractional - counters[before], 0.0, 1.0)
        low, high = self._aux_volts[before], self._aux_volts[after]
        aux = low + (high - low) * weight[:, None]
        aux[:, 2] = low[
            :, 2
        ]  # the Hall line: the level the board last saw (a logic line is not interpolated)
        return aux, ok, self._aux_flags[before] | self._aux_flags[after]

    def _trim(self, emitted_until_s: float, fit: ClockFit) -> None:
        """Forget polls and auxiliary samples no later row needs (keep the two before the next row)."""
        keep_polls = max(0, int(np.searchsorted(self._poll_times, emitted_until_s)) - 2)
        self._poll_times = self._poll_times[keep_polls:]
        self._poll_volts = self._poll_volts[keep_polls:]
        self._poll_flags = self._poll_flags[keep_polls:]
        counter = float(fit.counter_at(emitted_until_s))
        keep_aux = max(0, int(np.searchsorted(self._aux_counters, counter)) - 2)
        self._aux_counters = self._aux_counters[keep_aux:]
        self._aux_volts = self._aux_volts[keep_aux:]
        self._aux_flags = self._aux_flags[keep_aux:]
