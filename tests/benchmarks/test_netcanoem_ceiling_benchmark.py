"""The NETCANOEM ceiling benchmark script: the ceiling's arithmetic and the accounting of one short polling run.

No timing assertions: the achieved rate depends on the machine; only its bookkeeping is checked.
"""

import contextlib
import io
import json

import netcanoem_ceiling


def test_ceiling_is_the_frame_layouts_bits_at_one_megabit():
    limits = netcanoem_ceiling.ceilings(1_000_000)
    # request DLC 0 + replies DLC 8 and DLC 6: (44 + 8 DLC + 3) bits each = 47 + 111 + 95, and with worst-case
    # stuffing floor((34 + 8 DLC - 1) / 4) more each = 8 + 24 + 20
    assert limits["bits_per_sample"] == 253
    assert limits["bits_per_sample_worst_case_stuffing"] == 305
    assert limits["ceiling_hz"] == 1_000_000 / 253
    assert limits["ceiling_worst_case_stuffing_hz"] == 1_000_000 / 305


def test_every_request_is_a_delivered_sample_or_counted_as_lost():
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exit_code = netcanoem_ceiling.main(
            ["--rates", "1000", "--seconds", "0.5", "--baseline-s", "0.2", "--json"]
        )
    result = json.loads(printed.getvalue())
    run = result["runs"][0]
    assert exit_code == (0 if result["target_met"] else 1)
    assert (
        run["samples_delivered"] == run["samples_polled"] > 0
    )  # nothing polled was left in the queue
    assert run["blocks_dropped"] == 0
    # every answered request is a delivered or a discarded sample, or one the driver had given up on (a reply later
    # than its timeout, when a busy host starves the board's thread); nothing else is on the bus
    accounted = run["samples_delivered"] + run["samples_discarded"]
    assert accounted <= run["requests_answered_by_board"]
    assert run["requests_answered_by_board"] <= accounted + run["requests_without_reply"]
    assert run["of_ceiling"] == run["achieved_hz"] / result["ceilings"]["ceiling_hz"]
    # every request sent is a delivered sample or a lost one (no reply, or discarded); requests the poller never
    # sent are counted apart, and those it gave up on when resynchronising are among them
    assert run["requests_sent"] == run["samples_delivered"] + run["samples_lost"]
    assert run["samples_lost"] == run["requests_without_reply"] + run["samples_discarded"]
    assert run["requests_skipped_on_resync"] >= 0
    host = result["host"]
    assert host["transport_round_trip_hz"] > 0 and host["board_round_trip_hz"] > 0
    assert run["of_host_round_trip"] == run["achieved_hz"] / host["board_round_trip_hz"]
    assert host["board_round_trip_of_ceiling"] == (
        host["board_round_trip_hz"] / result["ceilings"]["ceiling_hz"]
    )
