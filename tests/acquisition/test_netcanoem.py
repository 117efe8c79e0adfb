"""NETCANOEM: identifiers and payloads, the CAN rate ceiling, the driver on a virtual bus."""

import struct
import time
import uuid

import numpy as np
import pytest

from ornitail.acquisition import netcanoem_protocol as protocol
from ornitail.acquisition.instrument_errors import InstrumentDisconnected
from ornitail.acquisition.netcanoem_driver import NetCanOemDriver, PollSchedule
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.core.errors import UserInputError
from ornitail.simulated_instruments.netcanoem_board import GAUGE_VOLTS_PER_COUNT
from ornitail.simulated_instruments.pytest_plugin import PACKAGED_CALIBRATION


@pytest.mark.parametrize(
    ("base_id", "opcode", "identifier"),
    [
        (0x20, 0x0, 0x200),
        (0x20, 0x1, 0x201),
        (0x20, 0xF, 0x20F),
        (0x7F, 0xE, 0x7FE),
        (0x00, 0x5, 0x005),
    ],
)
def test_identifier_is_base_shifted_by_four_or_opcode(base_id, opcode, identifier):
    assert protocol.arbitration_id(base_id, opcode) == identifier
    assert protocol.split_arbitration_id(identifier) == (base_id, opcode)


def test_identifier_refuses_out_of_range_fields():
    with pytest.raises(ValueError):
        protocol.arbitration_id(0x80, 0)
    with pytest.raises(ValueError):
        protocol.arbitration_id(0x20, 0x10)


def test_gauge_replies_split_status_and_even_gauges_then_odd_gauges_big_endian():
    first, second = protocol.encode_gauge_replies(0x8001, np.array([1, -2, 300, -32768, 32767, 0]))
    assert first == bytes.fromhex("80010001012c7fff")  # status, g0, g2, g4
    assert second == bytes.fromhex("fffe80000000")  # g1, g3, g5
    status, gauges = protocol.decode_gauge_replies(first, second)
    assert status == 0x8001
    assert gauges.tolist() == [1, -2, 300, -32768, 32767, 0]
    assert protocol.saturated_gauges(gauges).tolist() == [False, False, False, True, True, False]


def test_matrix_row_is_six_big_endian_float32_over_three_frames():
    row = np.array([1.5, -2.0, 0.25, 100.0, -0.125, 3.0])
    replies = protocol.encode_matrix_row_replies(row)
    assert replies[0] == struct.pack(">ff", 1.5, -2.0) == bytes.fromhex("3fc00000c0000000")
    assert [len(r) for r in replies] == [8, 8, 8]
    np.testing.assert_array_equal(protocol.decode_matrix_row(replies), row)


def test_other_payloads():
    assert protocol.encode_counts_per_unit(1_000_000, 1000) == bytes.fromhex("000f4240000003e8")
    assert protocol.decode_counts_per_unit(bytes.fromhex("000f4240000003e8")) == (1_000_000, 1000)
    assert protocol.encode_firmware_version(2, 1, 7) == bytes.fromhex("02010007")
    assert protocol.decode_firmware_version(bytes.fromhex("02010007")) == "2.1.7"
    assert protocol.encode_serial_number("FT8884") == b"FT8884\0\0"
    assert protocol.decode_serial_number(b"FT8884\0\0") == "FT8884"


@pytest.mark.parametrize(
    ("divisor", "bit_rate"), [(0, 2_000_000), (1, 1_000_000), (3, 500_000), (7, 250_000)]
)
def test_bit_rate_divisor(divisor, bit_rate):
    assert protocol.bit_rate_for_divisor(divisor) == bit_rate
    assert protocol.divisor_for_bit_rate(bit_rate) == divisor


def test_rate_ceiling_numbers_computed_by_hand():
    # request DLC 0: 44 + 0 + 3 + floor(33/4)=8 -> 55 bits;
    # reply DLC 8: 44 + 64 + 3 + floor(97/4)=24
    # -> 135; reply DLC 6: 44 + 48 + 3 + floor(81/4)=20 -> 115. Total 305 bits per sample.
    assert [protocol.classic_can_frame_bits(d) for d in (0, 8, 6)] == [55, 135, 115]
    assert protocol.gauge_sample_bits() == 305
    assert protocol.gauge_sample_rate_ceiling_hz(1_000_000) == pytest.approx(1e6 / 305)  # 3279/s
    # Without stuffing: 47 + 111 + 95 = 253 bits -> 3953/s, ATI's "about 3.9 k samples/s".
    assert protocol.gauge_sample_bits(worst_case_stuffing=False) == 253
    assert protocol.gauge_sample_rate_ceiling_hz(1e6, worst_case_stuffing=False) == pytest.approx(
        3952.57, abs=0.01
    )
    assert protocol.gauge_sample_rate_ceiling_hz(250_000) == pytest.approx(250_000 / 305)


@pytest.fixture
def can_driver(simulated_netcanoem):
    driver = NetCanOemDriver(
        interface="virtual", channel=simulated_netcanoem.channel, name="test NETCANOEM"
    )
    driver.open()
    yield driver
    driver.close()


def test_polling_faster_than_the_bus_allows_is_refused_with_the_ceiling(can_driver):
    # 1 Mbit/s / 253 bits = 3953 samples/s (ATI's "about 3.9 k"); 3279/s with worst-case stuffing.
    with pytest.raises(UserInputError, match=r"ceiling of 3953 samples/s .* 3279/s guaranteed"):
        can_driver.check_sample_rate(4000.0)
    with pytest.raises(UserInputError):
        can_driver.start_polling(10_000.0)
    with pytest.warns(UserWarning, match="above the 3279/s the bus guarantees"):
        can_driver.check_sample_rate(3500.0)


def test_queries_read_the_board_calibration(can_driver):
    calibration = AtiCalibration.from_file(PACKAGED_CALIBRATION)
    assert can_driver.read_serial_number() == "FT8884"
    assert can_driver.read_firmware_version() == "2.1.7"
    assert can_driver.read_counts_per_unit() == (1_000_000, 1_000_000)
    assert can_driver.read_unit_codes() == (2, 3)
    can_driver.set_active_calibration(1)
    matrix = can_driver.read_matrix()
    # board matrix = matrix_si * volts per count * counts per unit, stored as float32 (rel. 6e-8)
    np.testing.assert_allclose(
        matrix, calibration.matrix_si * GAUGE_VOLTS_PER_COUNT * 1e6, rtol=1e-7
    )


def test_board_wrench_equals_the_calibration_applied_to_the_digitised_voltages(can_driver):
    calibration = AtiCalibration.from_file(PACKAGED_CALIBRATION)
    matrix = can_driver.read_matrix()
    reading = can_driver.read_gauges()
    wrench = can_driver.wrench_from_gauges(
        reading.gauges[None, :], matrix, (1_000_000, 1_000_000), (2, 3)
    )
    expected = calibration.matrix_si @ (reading.gauges * GAUGE_VOLTS_PER_COUNT)
    # float32 matrix coefficients: relative error ~1e-7 of each term; terms are below 1e3 N
    np.testing.assert_allclose(wrench[0], expected, rtol=0, atol=1e-4)
    assert reading.status_word == 0 and not reading.saturated.any()


def test_polling_delivers_blocks_flags_saturation_and_counts_error_frames(
    simulated_netcanoem, can_driver
):
    can_driver.start_polling(500.0)
    first = can_driver.get_block(timeout_s=2.0)
    assert first is not None and first.gauges.shape[1] == 6
    simulated_netcanoem.force_gauge(3, protocol.GAUGE_SATURATION_LOW)
    simulated_netcanoem.inject_error_frames(4)
    simulated_netcanoem.set_status_word(0x0040)
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline:
        block = can_driver.get_block(timeout_s=1.0)
        if block is not None and block.saturated[:, 3].any():
            break
    can_driver.stop_polling()
    last = np.flatnonzero(block.saturated[:, 3])[-1]
    assert block.gauges[last, 3] == -32768
    assert block.saturated[last].tolist() == [False, False, False, True, False, False]
    assert block.status_words[last] == 0x0040
    assert can_driver.error_frames == 4
    assert can_driver.missed_replies == 0


def test_board_that_stops_answering_raises_disconnected(simulated_netcanoem, can_driver):
    can_driver.start_polling(200.0)
    assert can_driver.get_block(timeout_s=2.0) is not None
    simulated_netcanoem.unplug()
    with pytest.raises(
        InstrumentDisconnected, match="test NETCANOEM: 3 gauge requests in a row got no reply"
    ):
        for _ in range(50):
            can_driver.get_block(timeout_s=1.0)
    with pytest.raises(InstrumentDisconnected):
        can_driver.stop_polling()


def test_single_query_to_a_silent_bus_names_the_instrument():
    driver = NetCanOemDriver(
        interface="virtual",
        channel="ornitail-nobody-here",
        name="balance CAN",
        reply_timeout_s=0.05,
    )
    with pytest.raises(
        InstrumentDisconnected, match=r"balance CAN: no reply to opcode 0x5 within 0.05 s"
    ):
        driver.open()
    driver.close()


def test_bus_that_cannot_be_opened_names_the_instrument():
    driver = NetCanOemDriver(
        interface="socketcan", channel="ornitail_no_such_can", name="balance CAN"
    )
    with pytest.raises(
        InstrumentDisconnected, match="balance CAN: cannot open CAN interface 'socketcan'"
    ):
        driver.open()


def test_bus_error_while_polling_raises_disconnected(simulated_netcanoem):
    # A bus whose send fails the way a bus-off controller does: python-can's virtual bus raises
    # CanOperationError once shut down. The driver must turn it into InstrumentDisconnected.
    driver = NetCanOemDriver(
        interface="virtual", channel=simulated_netcanoem.channel, name="CAN balance"
    )
    driver.open()
    driver.start_polling(200.0)
    assert driver.get_block(timeout_s=2.0) is not None
    driver._bus.shutdown()
    with pytest.raises(InstrumentDisconnected, match="CAN balance: CAN bus error"):
        for _ in range(50):
            driver.get_block(timeout_s=1.0)
    driver._bus = None
    driver.close()


# -- the poller's schedule: catch-up and resynchronisation, on a fake clock ----------------------


class FakeTime:
    """Clock seconds that pass only when the poller sleeps or a scripted board takes time to answer."""

    def __init__(self) -> None:
        self.now_s = 0.0

    def clock(self) -> float:
        return self.now_s

    def sleep(self, seconds: float) -> None:
        self.now_s += seconds


def timed_replies(fake_time: FakeTime, round_trip_s):
    """The answer to gauge request k: gauge 0 = k, after ``round_trip_s(k)`` of fake time.

    The fake time advances before the replies go out, so the poller reads it only once the round trip is over:
    the send times the poller stamps depend on the script alone, not on thread timing.
    """

    def answer(k: int) -> list[tuple[int, bytes]]:
        fake_time.now_s += round_trip_s(k)
        first, second = protocol.encode_gauge_replies(0, np.array([k % 32768, 0, 0, 0, 0, 0]))
        return [(protocol.OPCODE_READ_GAUGES, first), (protocol.OPCODE_GAUGES_SECOND_REPLY, second)]

    return answer


def poll_on_fake_clock(board_class, rate_hz: float, round_trip_s, samples: int):
    """Poll a scripted board (``board_class``: the ``scripted_can_board`` fixture) answering with
    :func:`timed_replies` at ``rate_hz`` until ``samples`` arrived: (request numbers, send times s, driver)."""
    fake_time = FakeTime()
    channel = f"ornitail-schedule-{uuid.uuid4().hex[:8]}"
    board = board_class(channel, timed_replies(fake_time, round_trip_s))
    driver = NetCanOemDriver(
        interface="virtual",
        channel=channel,
        reply_timeout_s=10.0,  # wall seconds: a loaded host must not turn a slow thread into a missed reply
        clock=fake_time.clock,
        sleep=fake_time.sleep,
    )
    blocks = []
    try:
        driver.open()
        driver.start_polling(rate_hz)
        while sum(len(block.host_time_s) for block in blocks) < samples:
            block = driver.get_block(timeout_s=10.0)
            assert block is not None
            blocks.append(block)
        driver.stop_polling()
    finally:
        driver.close()
        board.close()
    numbers = np.concatenate([block.gauges[:, 0] for block in blocks])[:samples]
    times = np.concatenate([block.host_time_s for block in blocks])[:samples]
    return numbers.tolist(), times, driver


def test_poller_makes_up_a_stall_shorter_than_the_catch_up_limit(scripted_can_board):
    # 1000/s, round trips of 0.4 ms, request 10 stalls 5 ms: requests 11..18 are late and go back to back (one
    # outstanding, 0.4 ms apart) until request 19 is on time again; every sample k >= 19 is sent at k ms.
    def round_trip_s(k):
        return 5.4e-3 if k == 10 else 0.4e-3

    numbers, times, driver = poll_on_fake_clock(scripted_can_board, 1000.0, round_trip_s, 40)
    assert numbers == list(range(40))
    expected_ms = list(range(11)) + [15.4 + 0.4 * i for i in range(8)] + list(range(19, 40))
    np.testing.assert_allclose(times, np.array(expected_ms) * 1e-3, rtol=0, atol=1e-9)
    assert driver.requests_skipped == 0
    assert driver.missed_replies == driver.discarded_samples == 0


def test_poller_holds_the_rate_on_average_through_runs_of_round_trips_longer_than_the_period(
    scripted_can_board,
):
    # In every 8 requests, 3 round trips of 1.6 ms then 5 of 0.2 ms: 0.725 ms a request on average, under the
    # 1 ms period. The poller falls 3 x 0.6 ms behind and makes it up, so sample k is sent at k ms + at most
    # 1.8 ms, for ever. Waiting a period after each late request, as `max(previous + period, now)` did, loses
    # the time a request is more than a period late, and the lag grows without bound.
    def round_trip_s(k):
        return 1.6e-3 if k % 8 < 3 else 0.2e-3

    numbers, times, driver = poll_on_fake_clock(scripted_can_board, 1000.0, round_trip_s, 400)
    assert numbers == list(range(400))
    lag_s = times - np.arange(400) * 1e-3
    assert lag_s.min() >= -1e-9
    assert lag_s.max() <= 1.8e-3 + 1e-9
    assert driver.requests_skipped == 0


def test_poller_resynchronises_after_a_stall_longer_than_the_catch_up_limit(scripted_can_board):
    # Request 10 stalls 100 ms, over the 50 ms limit: request 11 (due at 11 ms) goes out at 110.4 ms, the 99
    # requests due before then are counted as skipped, and the schedule restarts there, one request a period,
    # without a burst.
    def round_trip_s(k):
        return 100.4e-3 if k == 10 else 0.4e-3

    numbers, times, driver = poll_on_fake_clock(scripted_can_board, 1000.0, round_trip_s, 40)
    assert numbers == list(range(40))
    expected_ms = list(range(11)) + [110.4 + i for i in range(29)]
    np.testing.assert_allclose(times, np.array(expected_ms) * 1e-3, rtol=0, atol=1e-9)
    assert driver.requests_skipped == 99
    # every slot of the schedule up to the first request after the stall was sent or skipped: 111 slots, 0..110 ms
    assert numbers.index(11) + 1 + driver.requests_skipped == 111


def test_requests_sent_are_delivered_samples_plus_requests_without_a_sample(simulated_netcanoem):
    driver = NetCanOemDriver(interface="virtual", channel=simulated_netcanoem.channel)
    driver.open()
    try:
        driver.start_polling(500.0)
        assert driver.get_block(timeout_s=2.0) is not None
        driver.stop_polling()
    finally:
        driver.close()
    lost = driver.missed_replies + driver.discarded_samples
    assert driver.requests_sent == driver.samples_polled + lost > 0


@pytest.mark.parametrize(
    ("late_s", "skipped", "next_due_s"),
    [
        (0.0, 0, 0.002),  # on time
        (0.0015, 0, 0.002),  # late within the limit: the next request keeps its slot
        (0.0049, 0, 0.002),  # just within the limit: still made up
        (
            0.0051,
            5,
            0.0071,
        ),  # over it: 5 whole periods given up, the schedule restarts at the send (6.1 ms)
    ],
)
def test_schedule_counts_the_slots_it_gives_up(late_s, skipped, next_due_s):
    schedule = PollSchedule(period_s=0.001, start_s=0.0, catch_up_limit_s=0.005)
    assert schedule.sent(0.0) == 0
    assert schedule.due_s == 0.001
    assert schedule.sent(0.001 + late_s) == skipped
    assert schedule.due_s == pytest.approx(next_due_s, abs=1e-12)


def test_batch_decode_matches_the_decoding_of_each_sample():
    gauges = np.array([[1, -2, 300, -32768, 32767, 0], [7, 6, 5, 4, 3, -1]])
    replies = [
        protocol.encode_gauge_replies(status, row)
        for status, row in zip((0x8001, 0), gauges, strict=True)
    ]
    status_words, decoded = protocol.decode_gauge_reply_batch(
        b"".join(first for first, _ in replies), b"".join(second for _, second in replies)
    )
    assert status_words.dtype == np.uint16 and decoded.dtype == np.int16
    assert status_words.tolist() == [0x8001, 0]
    assert decoded.tolist() == gauges.tolist()
    with pytest.raises(ValueError):
        protocol.decode_gauge_reply_batch(replies[0][0], b"")
