"""Balance backends by name: the rig file's ``[balance].route`` chooses the class that implements
:class:`~ornitail.acquisition.balance_interface.BalanceStream`.

- ``serial_daq``: :class:`SerialDaqDriver` (ORNI-DAQ9: gauges, hot-wire, thermocouple, Hall line); a
  ``[balance.aux_daq]`` beside it is refused (it carries those itself).
- ``can``: :class:`NetCanOemBalance` (ATI NETCANOEM: gauges only); with ``[balance.aux_daq]``,
  :class:`AlignedBalance` (the ORNI-DAQ9 beside it, aligned on the host clock).
- ``netft``: not yet (refused by the rig file reader).

The rig builds its balance only through :func:`create_balance`; nothing above this module tells backends apart.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ornitail.acquisition.aligned_balance import AlignedBalance
from ornitail.acquisition.balance_interface import BalanceStream
from ornitail.acquisition.netcanoem_balance import NetCanOemBalance
from ornitail.acquisition.rig_file import RigDescription
from ornitail.acquisition.serial_daq_driver import SerialDaqDriver


@dataclass(frozen=True)
class BalanceContext:
    """What a balance backend needs: the checked rig file, the ``.cal`` matrix (N, N m per V), the ports to use
    (``daq``, ``aux_daq``; the simulators' ptys on a simulated rig), the CAN interface and channel, the reply
    timeout (s), and the rig's clock (s) with its time scale (clock seconds per wall second)."""

    description: RigDescription
    calibration_matrix_si: np.ndarray
    ports: dict[str, str]
    can_interface: str
    can_channel: str
    reply_timeout_s: float
    clock: Callable[[], float] = time.monotonic
    time_scale: float = 1.0
    extra: dict[str, object] = field(default_factory=dict)


def _serial_daq(context: BalanceContext) -> BalanceStream:
    description = context.description
    return SerialDaqDriver(
        context.ports["daq"],
        baud=description.serial_daq.baud,
        reply_timeout_s=context.reply_timeout_s,
    )


def _can(context: BalanceContext) -> BalanceStream:
    description = context.description
    aux_settings = description.aux_daq
    aligned = aux_settings is not None
    balance = NetCanOemBalance(
        calibration_matrix_si=context.calibration_matrix_si,
        interface=context.can_interface,
        channel=context.can_channel,
        bit_rate=description.can.bit_rate,
        base_id=description.can.base_id,
        # the aligned stream stamps both devices with rig time; alone, the driver keeps the wall clock
        **(
            {
                "clock": context.clock,
                "time_scale": context.time_scale,
                "block_period_s": 0.01 * context.time_scale,
                # a simulated board's thread may be starved on a busy host (the rig's reply timeout is 5 s then)
                "reply_timeout_s": context.reply_timeout_s,
            }
            if aligned
            else {}
        ),
    )
    if not aligned:
        return balance
    aux = SerialDaqDriver(
        context.ports["aux_daq"],
        baud=aux_settings.baud,
        name="auxiliary board",
        reply_timeout_s=context.reply_timeout_s,
        clock=context.clock,
    )
    return AlignedBalance(
        balance,
        aux,
        aux_sample_rate_hz=aux_settings.sample_rate_hz,
        poll_rate_hz=description.can.sample_rate_hz,
        clock=context.clock,
    )


BUILT_IN_BALANCES: dict[str, Callable[[BalanceContext], BalanceStream]] = {
    "serial_daq": _serial_daq,
    "can": _can,
}
"""``[balance].route`` -> the function building its backend."""


def create_balance(context: BalanceContext) -> BalanceStream:
    """The balance backend ``[balance].route`` names (not opened)."""
    return BUILT_IN_BALANCES[context.description.balance_route](context)
