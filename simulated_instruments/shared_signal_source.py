"""A lock-guarded handle on one ``TunnelSignalSource`` shared by several simulated instruments.

The fan, strut and motor simulators set the operating point from their own threads while the balance
simulator (DAQ board or NETCANOEM) draws samples from its thread; every call goes through one lock.
"""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np

HISTORY_S = 2.0
"""Simulated seconds of samples kept for instruments that sample by time
(:meth:`SharedTunnelSignals.samples_at_times`)."""


class SharedTunnelSignals:
    """Thread-safe access to a tunnel signal source producing (n, 9) volts at ``sample_rate_hz``.

    Parameters
    ----------
    source : object with ``set_operating_point(**kw)``, ``next_block(n)``, ``motor_rpm``, ``time_s``
        Normally :class:`ornitail.sim.tunnel.TunnelSignalSource`.
    sample_rate_hz : float
        The rate the source was built with, Hz.
    lookahead_s : float
        Simulated seconds generated beyond the latest time :meth:`samples_at_times` is asked for, in the same call
        (default 0). A polled balance asks for one sample per request (NETCANOEM: up to 3953 a second), and each
        call costs about 0.1 ms of the simulator's fixed overhead, more than the driver's whole round trip; the
        NETCANOEM ceiling benchmark generates 4 ms ahead so that the driver, not the simulator, is measured.
        Samples generated ahead take an operating-point change up to ``lookahead_s`` late. The rig's simulated
        instruments keep 0: with 4 ms the backend-agreement test failed twice in a row (X0 3.7 sigma apart between
        two backends); it then failed once without it too (its |z| <= 3 over 27 comparisons alarmed about once in
        14 runs, since corrected), so the lookahead may be innocent, but it is not in the rig until that is checked.
    """

    def __init__(self, source: Any, sample_rate_hz: float, lookahead_s: float = 0.0) -> None:
        self._source = source
        self.sample_rate_hz = float(sample_rate_hz)
        self._lookahead_samples = int(lookahead_s * self.sample_rate_hz)
        self._lock = threading.Lock()
        self._resampling_phase = 0.0
        self._consumed_samples = 0
        self._last_sample = np.zeros(9)
        self._history: np.ndarray | None = (
            None  # ring: source sample i in row i % len, made when first needed
        )
        self._history_from = 0  # the first source sample the ring was given

    @classmethod
    def from_simulator(
        cls,
        *,
        seed: int = 0,
        sample_rate_hz: float = 10_000.0,
        configuration: Any = None,
        effects: Any = None,
        lookahead_s: float = 0.0,
    ) -> SharedTunnelSignals:
        """Build the project's ``TunnelSignalSource`` and wrap it.

        The source feeds simulated acquisition boards, which digitise the gauges with their own ADC; so the
        source's own quantisation (effect ``balance_resolution``) is switched off and the signal is quantised
        once, by the board, as on the real rig (its noise stays).
        """
        from ornitail.sim.effects import EffectSet
        from ornitail.sim.tunnel import TunnelSignalSource

        analog = (effects or EffectSet()).replace_effect("balance_resolution", quantise=False)
        source = TunnelSignalSource(
            configuration=configuration, effects=analog, seed=seed, sample_rate_hz=sample_rate_hz
        )
        return cls(source, sample_rate_hz, lookahead_s)

    def mount_vehicle(self, configuration: Any) -> None:
        """Put another simulated vehicle (an ``ornitail.sim`` configuration) on the balance."""
        with self._lock:
            self._source.mount_vehicle(configuration)

    def set_operating_point(self, **operating_point: Any) -> None:
        """Forward to the source's ``set_operating_point`` (pitch_rad, tunnel_velocity_m_s, ...)."""
        with self._lock:
            self._source.set_operating_point(**operating_point)

    @property
    def motor_rpm(self) -> float:
        """The simulated motor speed the source currently flaps at, rev/min."""
        with self._lock:
            return float(self._source.motor_rpm)

    def operating_point(self) -> dict[str, float | bool]:
        """Current pitch_rad, tunnel_velocity_m_s, flapping_frequency_hz and tail_attached."""
        with self._lock:
            return {
                name: getattr(self._source, name)
                for name in (
                    "pitch_rad",
                    "tunnel_velocity_m_s",
                    "flapping_frequency_hz",
                    "tail_attached",
                )
            }

    @property
    def time_s(self) -> float:
        """Simulated time of the source's next sample, s."""
        with self._lock:
            return float(self._source.time_s)

    def next_block_at_rate(self, n_samples: int, sample_rate_hz: float) -> np.ndarray:
        """Return the next (n, 9) volts sampled at ``sample_rate_hz``.

        At the source's own rate this is ``next_block``; at another rate every output sample is the
        source sample at or just before its time (sample-and-hold, no anti-alias filter), and the
        source advances by the same span of time.
        """
        with self._lock:
            if sample_rate_hz == self.sample_rate_hz:
                block = np.asarray(self._source.next_block(n_samples), dtype=float)
                self._consumed_samples += n_samples
            else:
                ratio = self.sample_rate_hz / sample_rate_hz
                positions = self._resampling_phase + ratio * np.arange(n_samples)
                needed = int(math.floor(positions[-1])) + 1 if n_samples else 0
                source_block = np.asarray(self._source.next_block(needed), dtype=float)
                block = source_block[np.floor(positions).astype(np.int64)]
                self._resampling_phase = self._resampling_phase + ratio * n_samples - needed
                self._consumed_samples += needed
            if block.shape[0]:
                self._last_sample = block[-1].copy()
            return block

    def sample_at(self, simulated_time_s: float, chunk_samples: int = 20_000) -> np.ndarray:
        """Advance the source to ``simulated_time_s`` and return its (9,) sample at that time, V (the source
        sample before ``simulated_time_s * sample_rate_hz``, the first at time 0).

        Used by polled instruments (NETCANOEM) that read one sample per request.
        """
        return self.samples_at_times(np.array([simulated_time_s]), chunk_samples)[0]

    def samples_at_times(
        self, simulated_times_s: np.ndarray, chunk_samples: int = 20_000
    ) -> np.ndarray:
        """(n, 9) samples at increasing simulated times, V, each as :meth:`sample_at` takes it: instruments with
        their own sample clocks (an auxiliary board whose crystal runs off nominal) share one source with a polled
        balance. The source is advanced to the latest time (and the lookahead beyond, in one call); the last
        ``HISTORY_S`` stay available to the others.
        """
        times = np.asarray(simulated_times_s, dtype=float)
        indices = np.maximum((times * self.sample_rate_hz).astype(np.int64), 1) - 1
        with self._lock:
            due = int(indices[-1]) + 1 - self._consumed_samples
            if due > 0:
                due += self._lookahead_samples
            while due > 0:
                count = min(due, chunk_samples)
                block = np.asarray(self._source.next_block(count), dtype=float)
                self._last_sample = block[-1].copy()
                self._remember(block)
                self._consumed_samples += count
                due -= count
            assert self._history is not None
            size = len(self._history)
            oldest = max(0, self._consumed_samples - size)
            if self._history_from > oldest:
                oldest = self._history_from
            rows = np.clip(indices, oldest, self._consumed_samples - 1) % size
            return self._history[rows].copy()

    def _remember(self, block: np.ndarray) -> None:
        """Keep the newest ``HISTORY_S`` of generated samples in the ring (called with the lock held)."""
        if self._history is None:
            self._history = np.zeros((max(int(HISTORY_S * self.sample_rate_hz), 1), 9))
            self._history_from = self._consumed_samples
        size = len(self._history)
        first = self._consumed_samples + max(
            0, len(block) - size
        )  # source index of the first row kept
        block = block[-size:]
        self._history[(np.arange(len(block)) + first) % size] = block
