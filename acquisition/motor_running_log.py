"""When the flapping motor started and stopped, as rows of the balance stream: the clock of the balance's drift.

A Nano-17 next to the DelFly's motor warms while the motor runs, so processing interpolates the gauge zero
between wind-off tares in running time (:mod:`ornitail.balance.tare_drift`). The motor keeps turning for a while
after it is told to stop (the simulated motor ~2.5 s; a real one its own spin-down), so the moments the sweep
commands it to stop is not the moment it stops. The sweep reads the motor's speed every poll while settling and
recording; this log keeps each change between standing (0 rpm read) and running, on the stream's rows. Placing
the changes matters: a 0.1 s error at every start and stop moved X0 on the simulated rig by about 0.01 mN, two of
its sigmas.
"""

from __future__ import annotations

from typing import Protocol

MOTOR_TRANSITIONS_KEY = "motor_transitions"
"""Journal key (a set point's ``extra``): ``[["started" | "stopped", row index], ...]`` since the previous point; a
change whose sample the link lost carries a third item, the samples lost from it to that row
(``["stopped", row, lost]``: it happened ``lost`` samples of the counter before the row)."""


class _RowLocator(Protocol):
    def row_sampled_at(self, samples_since_start: int) -> tuple[int, int] | None: ...


class MotorRunningLog:
    """Changes of the motor between standing and running, on the balance's sample count.

    A start is placed where the sweep commands it (a standing motor turns as soon as it is told to). A stop is seen
    at the first poll that reads 0 rpm (polls are 0.1 s of rig time apart) and placed halfway between that poll
    and the one before it, so that on average it is placed where it happened. Either becomes a row index once
    that sample has been recorded.
    """

    def __init__(self) -> None:
        self.running = False
        self._previous_reading: int | None = None
        self._unplaced: list[tuple[str, int]] = []
        self._placed: list[list[str | int]] = []

    def commanded(self, frequency_hz: float, samples_since_start: int, stream: _RowLocator) -> None:
        """The sweep told the motor to flap at ``frequency_hz`` when the board had sampled
        ``samples_since_start``: a standing motor starts there."""
        if frequency_hz > 0.0 and not self.running:
            self.running = True
            self._unplaced.append(("started", samples_since_start))
        self._place(stream)

    def start_run(self) -> None:
        """A new run (a new recorder, so new row indices): forget unplaced changes; a motor already running
        is journalled as started at the run's first row."""
        self._unplaced.clear()
        self._previous_reading = None
        self._placed = [["started", 0]] if self.running else []

    def observe(self, running: bool, samples_since_start: int, stream: _RowLocator) -> None:
        """One reading of the motor (running: it read a speed above 0) taken when the board had sampled
        ``samples_since_start``."""
        if running != self.running:
            self.running = running
            previous = (
                samples_since_start if self._previous_reading is None else self._previous_reading
            )
            self._unplaced.append(
                ("started" if running else "stopped", (previous + samples_since_start) // 2)
            )
        self._previous_reading = samples_since_start
        self._place(stream)

    def _place(self, stream: _RowLocator) -> None:
        while self._unplaced:
            kind, samples = self._unplaced[0]
            found = stream.row_sampled_at(samples)
            if found is None:
                return
            row, lost = found
            self._placed.append([kind, row] if lost == 0 else [kind, row, lost])
            self._unplaced.pop(0)

    def journal_values(self, stream: _RowLocator) -> dict[str, list[list[str | int]]]:
        """The changes placed since the last call, for a set point's ``extra``; they are then forgotten."""
        self._place(stream)
        placed, self._placed = self._placed, []
        return {MOTOR_TRANSITIONS_KEY: placed}
