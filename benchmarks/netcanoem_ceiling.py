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
accounting: requests sent = samples delivered + samples lost (requests without a reply + samples discarded for a
foreign frame), and requests never sent (the poller could not keep up; those it gave up on when it resynchronised
after falling more than its catch-up limit behind are counted apart). The board's own count of the requests it
answered closes the books (delivered + discarded <= answered <= delivered + discarded + no reply: a reply later than
the driver's timeout is a "no reply" the board did answer).

The virtual bus is a Python queue, not a wire: two Python threads (the poller and the board) exchange three frames
per sample under one interpreter lock, and the board runs the tunnel simulator for every request. So the script
measures, in the same process, before and after the polling runs, what this host allows:

- the transport floor: round trips per second of the same three frames between two bare threads (a responder that
  sends two prebuilt replies; no board, no driver);
- the host's round trip: back-to-back gauge requests per second from a bare requester (send, two receives, no
  checks) to the simulated board. No poller with one request outstanding can go faster on this host; the driver's
  rate is reported as a ratio of it as well as of the bus ceiling. The baseline runs at other moments than the
  polling, so on a host whose load changes a run can come out above it: compare the before and after halves.

Usage: ``benchmarks/README.md``. Exit code 0 when the fastest rate asked for reached ``--target`` of the ceiling
without stuffing, 1 otherwise, 2 for a bad option.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
import uuid
import warnings
from typing import Any

import can

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
SIGNAL_LOOKAHEAD_S = 0.004
"""The simulated board's signals generated this far ahead, s (16 requests a call at the ceiling): without it the
tunnel simulator's ~0.1 ms per call, not the driver, sets the host's round trip (``SharedTunnelSignals``)."""


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


def _board(channel: str) -> SimulatedNetCanOemBoard:
    """A started simulated board on ``channel``, fed by a fresh tunnel simulator in real time."""
    calibration = AtiCalibration.from_file(CALIBRATION)
    signals = SharedTunnelSignals.from_simulator(seed=0, lookahead_s=SIGNAL_LOOKAHEAD_S)
    return SimulatedNetCanOemBoard(
        signals, SimulatedClock(1.0), calibration.matrix_si, channel=channel
    ).start()


def _back_to_back_round_trips_hz(requester: can.BusABC, seconds: float) -> float:
    """Send gauge requests back to back on ``requester`` for ``seconds``, reading the two replies of each and
    checking nothing; round trips per second."""
    request = can.Message(
        arbitration_id=protocol.arbitration_id(
            protocol.DEFAULT_BASE_ID, protocol.OPCODE_READ_GAUGES
        ),
        is_extended_id=False,
    )
    round_trips = 0
    started = time.perf_counter()
    end = started + seconds
    while time.perf_counter() < end:
        requester.send(request)
        if requester.recv(1.0) is None or requester.recv(1.0) is None:
            raise RuntimeError("no reply within 1 s to a back-to-back request")
        round_trips += 1
    return round_trips / (time.perf_counter() - started)


def transport_round_trip_hz(seconds: float) -> float:
    """Round trips per second of a request (DLC 0) and two replies (DLC 8, 6) between two bare Python threads on
    the virtual bus, the responder sending prebuilt replies: python-can's floor on this host."""
    channel = f"floor-{uuid.uuid4().hex[:8]}"
    requester = can.Bus(interface="virtual", channel=channel)
    responder = can.Bus(interface="virtual", channel=channel)
    replies = [
        can.Message(
            arbitration_id=protocol.arbitration_id(protocol.DEFAULT_BASE_ID, opcode),
            is_extended_id=False,
            data=bytes(length),
        )
        for opcode, length in (
            (protocol.OPCODE_READ_GAUGES, 8),
            (protocol.OPCODE_GAUGES_SECOND_REPLY, 6),
        )
    ]
    stop = threading.Event()

    def respond() -> None:
        while not stop.is_set():
            if responder.recv(0.05) is not None:
                for reply in replies:
                    responder.send(reply)

    thread = threading.Thread(target=respond, daemon=True)
    thread.start()
    try:
        return _back_to_back_round_trips_hz(requester, seconds)
    finally:
        stop.set()
        thread.join()
        requester.shutdown()
        responder.shutdown()


def board_round_trip_hz(seconds: float) -> float:
    """Gauge requests per second a bare requester gets answered by the simulated board, back to back: the most a
    poller with one request outstanding can reach on this host."""
    channel = f"round-trip-{uuid.uuid4().hex[:8]}"
    board = _board(channel)
    requester = can.Bus(interface="virtual", channel=channel)
    try:
        return _back_to_back_round_trips_hz(requester, seconds)
    finally:
        requester.shutdown()
        board.close()


def baseline(seconds: float) -> dict[str, float]:
    """Transport floor and host round trip, samples/s, each measured for ``seconds``."""
    return {
        "transport_round_trip_hz": transport_round_trip_hz(seconds),
        "board_round_trip_hz": board_round_trip_hz(seconds),
    }


def poll(rate_hz: float, seconds: float) -> dict[str, Any]:
    """Poll the simulated board at ``rate_hz`` for ``seconds`` of wall time; achieved rate and accounting."""
    channel = f"ceiling-{uuid.uuid4().hex[:8]}"
    board = _board(channel)
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
        "requests_sent": driver.requests_sent,
        "requests_answered_by_board": answered,
        "samples_lost": driver.requests_sent - delivered,
        "requests_without_reply": driver.missed_replies,
        "samples_discarded": driver.discarded_samples,
        "foreign_frames": driver.foreign_frames,
        "blocks_dropped": driver.blocks_dropped,
        "requests_never_sent": max(0, round(rate_hz * span_s) + 1 - driver.requests_sent),
        "requests_skipped_on_resync": driver.requests_skipped,
        "poller_cpu_us_per_request": driver.poller_cpu_s / max(driver.requests_sent, 1) * 1e6,
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
    parser.add_argument(
        "--baseline-s",
        type=float,
        default=2.0,
        help="wall seconds of each round-trip baseline, half before the runs and half after",
    )
    parser.add_argument("--target", type=float, default=0.95, help="fraction of the ceiling")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead")
    options = parser.parse_args(argv)
    if (
        options.seconds <= 0
        or options.baseline_s <= 0
        or any(not 0 < rate <= limits["ceiling_hz"] for rate in options.rates)
    ):
        parser.error(
            f"--seconds and --baseline-s must be > 0 and every rate in (0, {limits['ceiling_hz']:.0f}]"
        )
    before = baseline(options.baseline_s / 2)
    results = [poll(rate, options.seconds) for rate in options.rates]
    after = baseline(options.baseline_s / 2)
    host = {key: (before[key] + after[key]) / 2 for key in before}
    host["board_round_trip_of_ceiling"] = host["board_round_trip_hz"] / limits["ceiling_hz"]
    for run in results:
        run["of_host_round_trip"] = run["achieved_hz"] / host["board_round_trip_hz"]
    met = results[-1]["of_ceiling"] >= options.target
    if options.json:
        print(
            json.dumps(
                {
                    "ceilings": limits,
                    "host": host,
                    "host_before": before,
                    "host_after": after,
                    "runs": results,
                    "target_met": met,
                }
            )
        )
        return 0 if met else 1
    print(
        f"classic CAN at {limits['bit_rate']:.0f} bit/s: {limits['bits_per_sample']} bits per sample "
        f"-> {limits['ceiling_hz']:.0f} samples/s; worst-case stuffing "
        f"{limits['bits_per_sample_worst_case_stuffing']} bits -> "
        f"{limits['ceiling_worst_case_stuffing_hz']:.0f} samples/s"
    )
    print(
        f"this host: transport floor {host['transport_round_trip_hz']:.0f} round trips/s "
        f"(before {before['transport_round_trip_hz']:.0f}, after {after['transport_round_trip_hz']:.0f}); "
        f"round trip with the simulated board {host['board_round_trip_hz']:.0f}/s "
        f"(before {before['board_round_trip_hz']:.0f}, after {after['board_round_trip_hz']:.0f}) = "
        f"{host['board_round_trip_of_ceiling']:.1%} of the ceiling"
    )
    print(
        "requested/s  achieved/s  of ceiling  of stuffed ceiling  of host round trip  delivered  lost "
        "(no reply, discarded)  never sent (skipped on resync)  poller CPU us/request"
    )
    for run in results:
        print(
            f"{run['requested_hz']:11.0f}  {run['achieved_hz']:10.0f}  {run['of_ceiling']:10.1%}  "
            f"{run['of_ceiling_worst_case_stuffing']:18.1%}  {run['of_host_round_trip']:18.1%}  "
            f"{run['samples_delivered']:9d}  {run['samples_lost']:4d} ({run['requests_without_reply']}, "
            f"{run['samples_discarded']}){'':12}  {run['requests_never_sent']:10d} "
            f"({run['requests_skipped_on_resync']}){'':14}  {run['poller_cpu_us_per_request']:.0f}"
        )
    print(
        f"target {options.target:.0%} of the ceiling at the fastest rate: {'met' if met else 'not met'}"
    )
    return 0 if met else 1


if __name__ == "__main__":
    sys.exit(main())
