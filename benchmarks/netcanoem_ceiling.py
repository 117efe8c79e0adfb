"""Benchmark: how close the real NETCANOEM driver polls to the classic-CAN ceiling of the board's frame layout.

The board streams nothing by itself: in the protocol this project implements (docs/instrument-protocols.md, ATI
document 9610-05-1030 as summarised there) a gauge sample is one request (opcode 0x0, DLC 0) answered by two
frames (opcode 0x0, DLC 8: status and gauges 0, 2, 4; opcode 0x1, DLC 6: gauges 1, 3, 5). No streaming opcode is
documented, so the highest rate is polling at the bus ceiling. Per sample the bus carries

- without stuffing: 47 + 111 + 95 = 253 bits (44 framing bits + 8 per data byte + 3 interframe bits per frame);
- with worst-case stuffing: + floor((34 + 8 DLC - 1) / 4) per frame = 55 + 135 + 115 = 305 bits;

so the ceiling at 1 Mbit/s is 3953 samples/s (ATI's "about 3.9 k", what the driver accepts) and 3279 samples/s
guaranteed whatever the data.

The script starts the simulated board (:class:`SimulatedNetCanOemBoard`, fed by the tunnel simulator at time scale
1) on python-can's in-process ``virtual`` bus, polls it with the real :class:`NetCanOemDriver` at each rate asked
for, and reports the achieved rate (samples delivered per second of polling), its ratio to both ceilings and the
accounting: requests sent = samples delivered + requests without a reply + samples discarded for a foreign frame.
The board's own count of the requests it answered closes the books (delivered + discarded <= answered <= delivered +
discarded + no reply: a reply later than the driver's 1 s timeout is a "no reply" the board did answer). The
driver sends its next request at ``max(previous + period, now)``: a late wake-up of its thread is not made up, so
what the host cannot sustain shows as requests never sent ("short"), not as lost samples.
The virtual bus is a Python queue, not a wire: what limits it is the host (two Python threads exchanging three
frames per sample), so the achieved rate says what this machine sustains, not what a CAN adapter would.

Usage: ``benchmarks/README.md``. Exit code 0 when the fastest rate asked for reached ``--target`` of the ceiling
without stuffing, 1 otherwise, 2 for a bad option.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import uuid
import warnings
from typing import Any

from ornitail.acquisition import netcanoem_protocol as protocol
from ornitail.acquisition.netcanoem_driver import NetCanOemDriver
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.netcanoem_board import SimulatedNetCanOemBoard
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals

BIT_RATE = 1_000_000
"""The board's default bit rate (opcode 0xE divisor 1), bit/s."""
CALIBRATION = DEFAULT_RIG_FILE.parent / "calibration" / "FT8884.cal"


def ceilings(bit_rate: float = BIT_RATE) -> dict[str, float | int]:
    """Bits per sample and the samples/s ceiling at ``bit_rate``, without and with worst-case bit stuffing."""
    return {
        "bit_rate": bit_rate,
        "bits_per_sample": protocol.gauge_sample_bits(worst_case_stuffing=False),
        "bits_per_sample_worst_case_stuffing": protocol.gauge_sample_bits(worst_case_stuffing=True),
        "ceiling_hz": protocol.gauge_sample_rate_ceiling_hz(bit_rate, worst_case_stuffing=False),
        "ceiling_worst_case_stuffing_hz": protocol.gauge_sample_rate_ceiling_hz(
            bit_rate, worst_case_stuffing=True
        ),
    }


def poll(rate_hz: float, seconds: float) -> dict[str, Any]:
    """Poll the simulated board at ``rate_hz`` for ``seconds`` of wall time; achieved rate and accounting."""
    calibration = AtiCalibration.from_file(CALIBRATION)
    signals = SharedTunnelSignals.from_simulator(seed=0)
    channel = f"ceiling-{uuid.uuid4().hex[:8]}"
    board = SimulatedNetCanOemBoard(
        signals, SimulatedClock(1.0), calibration.matrix_si, channel=channel
    ).start()
    driver = NetCanOemDriver(interface="virtual", channel=channel, bit_rate=BIT_RATE)
    delivered = 0
    first_s = last_s = None
    try:
        driver.open()
        answered_before = board.requests_answered  # open() asked its own questions
        # above the rate the bus guarantees with worst-case stuffing the driver warns: that is measured here
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            driver.start_polling(rate_hz)
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            block = driver.get_block(timeout_s=0.5)
            if block is None:
                continue
            delivered += len(block.host_time_s)
            first_s = block.host_time_s[0] if first_s is None else first_s
            last_s = block.host_time_s[-1]
        driver.stop_polling()
        answered = board.requests_answered - answered_before
        while (block := driver.get_block(timeout_s=0.0)) is not None:
            delivered += len(block.host_time_s)
            last_s = block.host_time_s[-1]
    finally:
        driver.close()
        board.close()
    span_s = float(last_s - first_s) if first_s is not None and last_s is not None else 0.0
    achieved = (delivered - 1) / span_s if span_s > 0 else 0.0
    limits = ceilings()
    return {
        "requested_hz": rate_hz,
        "achieved_hz": achieved,
        "of_ceiling": achieved / limits["ceiling_hz"],
        "of_ceiling_worst_case_stuffing": achieved / limits["ceiling_worst_case_stuffing_hz"],
        "samples_delivered": delivered,
        "samples_polled": driver.samples_polled,
        "requests_answered_by_board": answered,
        "requests_without_reply": driver.missed_replies,
        "samples_discarded": driver.discarded_samples,
        "foreign_frames": driver.foreign_frames,
        "blocks_dropped": driver.blocks_dropped,
        "requests_short_of_rate": max(0, round(rate_hz * span_s) + 1 - delivered),
    }


def main(argv: list[str] | None = None) -> int:
    limits = ceilings()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--rates",
        type=float,
        nargs="+",
        default=[500.0, 1000.0, 2000.0, 3000.0, 0.95 * limits["ceiling_hz"], limits["ceiling_hz"]],
        help="polling rates to try, samples/s",
    )
    parser.add_argument("--seconds", type=float, default=5.0, help="wall seconds per rate")
    parser.add_argument("--target", type=float, default=0.95, help="fraction of the ceiling")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead")
    options = parser.parse_args(argv)
    if options.seconds <= 0 or any(not 0 < rate <= limits["ceiling_hz"] for rate in options.rates):
        parser.error(f"--seconds must be > 0 and every rate in (0, {limits['ceiling_hz']:.0f}]")
    results = [poll(rate, options.seconds) for rate in options.rates]
    met = results[-1]["of_ceiling"] >= options.target
    if options.json:
        print(json.dumps({"ceilings": limits, "runs": results, "target_met": met}))
        return 0 if met else 1
    print(
        f"classic CAN at {limits['bit_rate']:.0f} bit/s: {limits['bits_per_sample']} bits per sample "
        f"-> {limits['ceiling_hz']:.0f} samples/s; worst-case stuffing "
        f"{limits['bits_per_sample_worst_case_stuffing']} bits -> "
        f"{limits['ceiling_worst_case_stuffing_hz']:.0f} samples/s"
    )
    print(
        "requested/s  achieved/s  of ceiling  of stuffed ceiling  delivered  no reply  discarded  short"
    )
    for run in results:
        print(
            f"{run['requested_hz']:11.0f}  {run['achieved_hz']:10.0f}  {run['of_ceiling']:10.1%}  "
            f"{run['of_ceiling_worst_case_stuffing']:18.1%}  {run['samples_delivered']:9d}  "
            f"{run['requests_without_reply']:8d}  {run['samples_discarded']:9d}  "
            f"{run['requests_short_of_rate']:5d}"
        )
    print(
        f"target {options.target:.0%} of the ceiling at the fastest rate: {'met' if met else 'not met'}"
    )
    return 0 if met else 1


if __name__ == "__main__":
    sys.exit(main())
