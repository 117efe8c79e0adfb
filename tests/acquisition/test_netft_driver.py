"""Net F/T driver against the simulated device over real UDP and HTTP on the loopback.

Waits are on conditions (records received, commands seen) with generous deadlines, never on sleeps.
"""

import socket
import time

import numpy as np
import pytest

from ornitail.acquisition import netft_protocol as protocol
from ornitail.acquisition.instrument_errors import InstrumentDisconnected
from ornitail.acquisition.netft_driver import (
    NetFtDriver,
    WrenchBlock,
    netft_settings_from_table,
)
from ornitail.core.errors import UserInputError
from ornitail.simulated_instruments.netft import SimulatedNetFt, constant_load

DEADLINE_S = 30.0
RATE_HZ = 1000.0  # 7000 / 7: ft_sequence advances by 7 per record

# A sensor set up in lbf and lbf-in (not SI), 2000 counts per lbf and 50 000 per lbf-in.
IMPERIAL = protocol.CountsPerUnit(2000, 50_000, "lbf", "lbf-in")


def flapping_load(times_s: np.ndarray) -> np.ndarray:
    """Known loads: a 7 Hz sine of a different amplitude and offset on each axis, N and N m."""
    amplitude = np.array([0.8, -1.5, 2.5, 0.02, -0.03, 0.004])
    offset = np.array([0.1, 0.0, -4.0, 0.0, 0.01, -0.002])
    return offset + np.sin(2 * np.pi * 7.0 * np.asarray(times_s))[:, None] * amplitude


def collect(driver: NetFtDriver, until, deadline_s: float = DEADLINE_S) -> list[WrenchBlock]:
    """Blocks until ``until(blocks)`` holds; fails after ``deadline_s``."""
    blocks: list[WrenchBlock] = []
    deadline = time.monotonic() + deadline_s
    while not (blocks and until(blocks)):
        assert time.monotonic() < deadline, "condition not reached before the deadline"
        block = driver.get_block(timeout_s=0.5)
        if block is not None:
            blocks.append(block)
    return blocks


def wait_for(condition, deadline_s: float = DEADLINE_S) -> None:
    deadline = time.monotonic() + deadline_s
    while not condition():
        assert time.monotonic() < deadline, "condition not reached before the deadline"
        time.sleep(0.005)  # polling interval only; the condition decides


def records_through(last: int):
    return lambda blocks: int(blocks[-1].rdt_sequence[-1]) >= last


def driver_for(device: SimulatedNetFt, **options) -> NetFtDriver:
    """A driver for ``device`` that reads its counts per unit from the device's web server."""
    return NetFtDriver(
        device.host,
        rdt_port=device.rdt_port,
        http_port=device.http_port,
        name="test Net F/T",
        **options,
    )


def free_port() -> int:
    """A loopback port number nothing listens on (UDP; for TCP it is just as unused here)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_known_loads_come_back_in_si_within_one_count_using_the_devices_xml():
    device = SimulatedNetFt(flapping_load, rate_hz=RATE_HZ, counts_per_unit=IMPERIAL)
    with device, driver_for(device) as driver:
        assert driver.counts_per_unit == IMPERIAL  # read over HTTP from netftapi2.xml
        driver.start_streaming()
        blocks = collect(driver, records_through(300))
        driver.stop()
    ft_sequence = np.concatenate([b.ft_sequence for b in blocks]).astype(np.int64)
    wrench = np.vstack([b.wrench for b in blocks])
    expected = flapping_load(ft_sequence / protocol.INTERNAL_SAMPLE_RATE_HZ)
    newton_per_count = 4.4482216152605 / 2000
    newton_metre_per_count = 0.112984829027617 / 50_000
    resolution = np.array([newton_per_count] * 3 + [newton_metre_per_count] * 3)
    # digitised to the nearest count: within half a count (plus float rounding)
    assert np.all(np.abs(wrench - expected) <= 0.5 * resolution * (1 + 1e-9))
    assert np.ptp(wrench[:, 2]) > 4.0  # the sine is really there (Fz swings 5 N peak to peak)
    assert set(np.diff(ft_sequence).tolist()) == {7}
    rdt_sequence = np.concatenate([b.rdt_sequence for b in blocks])
    assert rdt_sequence[0] == 1 and driver.lost_records == 0


def test_counts_per_unit_from_the_rig_file_need_no_web_server():
    load = constant_load([1, 2, 3, 0.1, 0.2, 0.3])
    with SimulatedNetFt(load, rate_hz=RATE_HZ) as device:
        table = {
            "host": device.host,
            "rdt_port": device.rdt_port,
            "http_port": free_port(),  # nothing serves HTTP there: the driver must not ask
            "counts_per_force": 1_000_000,
            "counts_per_torque": 1_000_000,
            "force_unit": "N",
            "torque_unit": "N-m",
            "rdt_rate_hz": RATE_HZ,
        }
        settings = netft_settings_from_table("rig.toml", table)
        with NetFtDriver.from_settings(settings) as driver:
            assert driver.counts_per_unit == protocol.CountsPerUnit(1e6, 1e6, "N", "N-m")
            driver.start_streaming()
            blocks = collect(driver, records_through(20))
    np.testing.assert_allclose(blocks[-1].wrench[-1], [1, 2, 3, 0.1, 0.2, 0.3], atol=5e-7)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        (
            {"host": "10.0.0.2", "counts_per_force": 1e6},
            r"\[balance.netft\].counts_per_torque: give all of",
        ),
        (
            {"host": "10.0.0.2", "rdt_rate_hz": 1000, "rdt_port": 70000},
            r"\[balance.netft\].rdt_port: 70000 must be in 1..65535",
        ),
        (
            {
                "host": "h",
                "counts_per_force": 1,
                "counts_per_torque": 1,
                "force_unit": "N",
                "torque_unit": "N",
            },
            r"\[balance.netft\].torque_unit: unknown unit 'N'",
        ),
        ({"host": "h", "port": 1}, r"\[balance.netft\].port: unknown key"),
        ({}, r"\[balance.netft\].host: required key is missing"),
        ({"host": "h"}, r"\[balance.netft\].rdt_rate_hz: required key is missing"),
        (
            {"host": "h", "rdt_rate_hz": 3000},
            r"\[balance.netft\].rdt_rate_hz: 3000 records/s is not an RDT output rate",
        ),
    ],
)
def test_rig_table_mistakes_name_file_and_key(table, message):
    with pytest.raises(UserInputError, match=r"rig.toml: " + message):
        netft_settings_from_table("rig.toml", table)


def test_rig_table_without_scaling_reads_it_from_the_device():
    settings = netft_settings_from_table("rig.toml", {"host": "10.0.0.2", "rdt_rate_hz": 7000})
    driver = NetFtDriver.from_settings(settings)
    assert (driver.host, driver.rdt_port, driver.http_port) == ("10.0.0.2", 49152, 80)
    assert driver.counts_per_unit is None and settings.rdt_rate_hz == 7000


def test_dropped_records_are_counted_exactly_from_sequence_gaps():
    dropped = {1, 5, 6, 7, 150, 299}
    with (
        SimulatedNetFt(rate_hz=RATE_HZ, drop_rdt_sequences=dropped) as device,
        driver_for(device) as driver,
    ):
        driver.start_streaming()
        blocks = collect(driver, records_through(300))
        driver.stop()
        received = np.concatenate([b.rdt_sequence for b in blocks])
        last = int(received[-1])
        assert received.tolist() == [n for n in range(1, last + 1) if n not in dropped]
        assert driver.lost_records == len(dropped) == device.records_dropped
        assert driver.link_health().lost_records == len(dropped)


def test_stop_sends_the_stop_command_and_the_device_stops_streaming():
    with SimulatedNetFt(rate_hz=RATE_HZ) as device, driver_for(device) as driver:
        driver.start_streaming()
        collect(driver, records_through(50))
        health = driver.link_health()
        assert health.records_received >= 50 and health.seconds_since_last_datagram >= 0
        driver.stop()
        wait_for(lambda: not device.streaming)
        assert device.commands_received[-1] == protocol.COMMAND_STOP_STREAMING
        sent_after_stop = device.records_sent
        # a later request round-trips through the device's loop: no record went out meanwhile
        driver.set_software_bias()
        wait_for(lambda: device.commands_received[-1] == protocol.COMMAND_SET_SOFTWARE_BIAS)
        assert device.records_sent == sent_after_stop
    assert device.commands_received[:2] == [
        protocol.COMMAND_START_REALTIME_STREAMING,  # open(): one record to check the device answers
        protocol.COMMAND_START_REALTIME_STREAMING,
    ]


def test_software_bias_zeroes_the_present_load():
    load = constant_load([0.5, -0.5, 2.0, 0.01, 0.0, -0.01])
    with SimulatedNetFt(load, rate_hz=RATE_HZ) as device, driver_for(device) as driver:
        driver.start_streaming()
        collect(driver, records_through(10))
        driver.set_software_bias()
        blocks = collect(driver, lambda blocks: not blocks[-1].wrench[-1].any())
    assert blocks[-1].wrench[-1].tolist() == [0.0] * 6


def test_a_non_zero_status_word_is_delivered_and_counted():
    with SimulatedNetFt(rate_hz=RATE_HZ) as device, driver_for(device) as driver:
        driver.start_streaming()
        collect(driver, records_through(5))
        device.set_status(0x80010000)
        blocks = collect(driver, lambda blocks: blocks[-1].status[-1] != 0)
        assert blocks[-1].status[-1] == 0x80010000
        assert driver.link_health().status_flagged_records >= 1


def test_a_port_where_nothing_answers_is_one_line_naming_instrument_and_address():
    port = free_port()
    driver = NetFtDriver(
        "127.0.0.1",
        rdt_port=port,
        counts_per_unit=protocol.CountsPerUnit(1_000_000, 1_000_000),
        name="test Net F/T",
        reply_timeout_s=0.5,
    )
    with pytest.raises(InstrumentDisconnected) as raised:
        driver.open()
    message = str(raised.value)
    assert message.startswith("test Net F/T: ") and f"127.0.0.1:{port}" in message
    assert "refused" in message or "no RDT record" in message
    assert (
        "\n" not in message and raised.value.__suppress_context__
    )  # raised from None: no chained trace
    driver.close()  # safe after a failed open


def test_a_device_that_never_answers_times_out_in_one_line():
    with socket.socket(
        socket.AF_INET, socket.SOCK_DGRAM
    ) as silent:  # takes datagrams, answers none
        silent.bind(("127.0.0.1", 0))
        port = silent.getsockname()[1]
        driver = NetFtDriver(
            "127.0.0.1",
            rdt_port=port,
            counts_per_unit=protocol.CountsPerUnit(1_000_000, 1_000_000),
            name="test Net F/T",
            reply_timeout_s=0.2,
        )
        with pytest.raises(
            InstrumentDisconnected,
            match=rf"^test Net F/T: no RDT record from UDP 127\.0\.0\.1:{port} within 0\.2 s \(check",
        ):
            driver.open()
        assert silent.recv(64) == protocol.encode_request(
            protocol.COMMAND_START_REALTIME_STREAMING, 1
        )


def test_a_web_server_that_is_not_there_is_one_line_naming_the_page():
    port = free_port()
    driver = NetFtDriver("127.0.0.1", http_port=port, name="test Net F/T", reply_timeout_s=0.5)
    with pytest.raises(
        InstrumentDisconnected,
        match=rf"^test Net F/T: cannot read counts per unit from http://127\.0\.0\.1:{port}/netftapi2\.xml: ",
    ) as raised:
        driver.open()
    assert "\n" not in str(raised.value)


def test_a_stream_that_goes_silent_raises_disconnected():
    device = SimulatedNetFt(rate_hz=RATE_HZ).start()
    driver = NetFtDriver(
        device.host,
        rdt_port=device.rdt_port,
        http_port=device.http_port,
        name="test Net F/T",
        silence_limit_s=0.3,
    )
    try:
        driver.open()
        driver.start_streaming()
        collect(driver, records_through(5))
        device.close()  # the device is gone: no more datagrams
        with pytest.raises(
            InstrumentDisconnected, match=r"test Net F/T: no RDT record from UDP .* for 0\.3 s"
        ):
            collect(driver, lambda blocks: False)
    finally:
        driver.close()
