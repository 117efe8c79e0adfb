"""Balance backends by name: the rig file's ``[balance].route`` chooses the class that implements
:class:`~ornitail.acquisition.balance_interface.BalanceStream`.

- ``serial_daq``: :class:`SerialDaqDriver` (ORNI-DAQ9: gauges, hot-wire, thermocouple, Hall line); a
  ``[balance.aux_daq]`` beside it is refused (it carries those itself).
- ``can``: :class:`NetCanOemBalance` (ATI NETCANOEM: gauges only); with ``[balance.aux_daq]``,
  :class:`AlignedBalance` (the ORNI-DAQ9 beside it, aligned on the host clock).
- ``netft``: :class:`NetFtBalance` (ATI Net F/T over UDP RDT: gauges only); with ``[balance.aux_daq]``,
  :class:`AlignedBalance` as for ``can`` (one class aligns either balance with the board).

The rig builds its balance only through :func:`create_balance`; nothing above this module tells backends apart.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ornitail.acquisition.aligned_balance import AlignedBalance
from ornitail.acquisition.balance_interface import BalanceStream, TimedGaugeBalance
from ornitail.acquisition.netcanoem_balance import NetCanOemBalance
from ornitail.acquisition.netft_balance import NetFtBalance
from ornitail.acquisition.netft_driver import NetFtSettings
from ornitail.acquisition.rig_file import RigDescription
from ornitail.acquisition.serial_daq_driver import SerialDaqDriver


@dataclass(frozen=True)
class BalanceContext:
    """What a balance backend needs: the checked rig file, the ``.cal`` matrix (N, N m per V), the ports to use
    (``daq``, ``aux_daq``; the simulators' ptys on a simulated rig), the CAN interface and channel, the Net F/T's
    address (the simulator's on the loopback on a simulated rig), the reply timeout (s), and the rig's clock (s)
    with its time scale (clock seconds per wall second)."""

    description: RigDescription
    calibration_matrix_si: np.ndarray
    ports: dict[str, str]
    can_interface: str
    can_channel: str
    reply_timeout_s: float
    clock: Callable[[], float] = time.monotonic
    time_scale: float = 1.0
    netft: NetFtSettings | None = None
    extra: dict[str, object] = field(default_factory=dict)


def _serial_daq(context: BalanceContext) -> BalanceStream:
    description = context.description
    return SerialDaqDriver(
        context.ports["daq"],
        baud=description.serial_daq.baud,
        reply_timeout_s=context.reply_timeout_s,
        check_sample_rate_hz=description.serial_daq.sample_rate_hz,
    )


def _rig_timing(context: BalanceContext) -> dict[str, object]:
    """Driver options of a balance beside the auxiliary board: stamped with rig time like the board, and the rig's
    reply timeout (a simulated device's thread may be starved on a busy host; the rig's timeout is 5 s then).
    Alone, a driver keeps the wall clock."""
    if context.description.aux_daq is None:
        return {}
    return {"clock": context.clock, "reply_timeout_s": context.reply_timeout_s}


def _with_aux_board(
    context: BalanceContext, balance: TimedGaugeBalance, balance_rate_hz: float
) -> BalanceStream:
    """``balance`` alone, or with the ORNI-DAQ9 of ``[balance.aux_daq]`` beside it (:class:`AlignedBalance`)."""
    aux_settings = context.description.aux_daq
    if aux_settings is None:
        return balance
    aux = SerialDaqDriver(
        context.ports["aux_daq"],
        baud=aux_settings.baud,
        name="auxiliary board",
        reply_timeout_s=context.reply_timeout_s,
        clock=context.clock,
        rig_file_key="[balance.aux_daq].port",
        check_sample_rate_hz=aux_settings.sample_rate_hz,
    )
    return AlignedBalance(
        balance,
        aux,
        aux_sample_rate_hz=aux_settings.sample_rate_hz,
        balance_rate_hz=balance_rate_hz,
        clock=context.clock,
    )


def _can(context: BalanceContext) -> BalanceStream:
    description = context.description
    timing = _rig_timing(context)
    balance = NetCanOemBalance(
        calibration_matrix_si=context.calibration_matrix_si,
        interface=context.can_interface,
        channel=context.can_channel,
        bit_rate=description.can.bit_rate,
        base_id=description.can.base_id,
        # the poller paces itself on the clock: its blocks about every 10 ms of wall time
        **(
            {
                **timing,
                "time_scale": context.time_scale,
                "block_period_s": 0.01 * context.time_scale,
            }
            if timing
            else {}
        ),
    )
    return _with_aux_board(context, balance, description.can.sample_rate_hz)


def _netft(context: BalanceContext) -> BalanceStream:
    settings = context.netft or context.description.netft
    assert settings is not None  # the rig file reader requires [balance.netft] for this route
    balance = NetFtBalance(
        settings.host,
        rdt_port=settings.rdt_port,
        http_port=settings.http_port,
        counts_per_unit=settings.counts_per_unit,
        calibration_matrix_si=context.calibration_matrix_si,
        rdt_rate_hz=settings.rdt_rate_hz,
        **_rig_timing(context),
    )
    return _with_aux_board(context, balance, settings.rdt_rate_hz)


BUILT_IN_BALANCES: dict[str, Callable[[BalanceContext], BalanceStream]] = {
    "serial_daq": _serial_daq,
    "can": _can,
    "netft": _netft,
}
"""``[balance].route`` -> the function building its backend."""


def create_balance(context: BalanceContext) -> BalanceStream:
    """The balance backend ``[balance].route`` names (not opened)."""
    return BUILT_IN_BALANCES[context.description.balance_route](context)
