"""The serial DAQ driver against the simulated board over a real pty, including injected faults."""

import time

import numpy as np
import pytest

from ornitail.acquisition.daq_protocol import CHANNEL_NAMES, VOLTS_PER_COUNT
from ornitail.acquisition.instrument_errors import InstrumentDisconnected, InstrumentReplyError
from ornitail.acquisition.serial_daq_driver import SerialDaqDriver
from ornitail.core.errors import UserInputError
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals


@pytest.fixture
def daq_driver(simulated_daq):
    driver = SerialDaqDriver(simulated_daq.port_path, name="test DAQ")
    driver.open()
    yield driver
    driver.close()


def collect(driver: SerialDaqDriver, n_samples: int):
    counters, volts = [], []
    while sum(len(c) for c in counters) < n_samples:
        block = driver.get_block(timeout_s=2.0)
        assert block is not None, "no data from the simulated board within 2 s"
        counters.append(block.counters)
        volts.append(block.volts)
    return np.concatenate(counters), np.vstack(volts)


def test_identify_reports_the_board(daq_driver):
    identity = daq_driver.identity
    assert identity.model == "ORNI-DAQ9"
    assert identity.channels == CHANNEL_NAMES
    assert identity.volts_per_count == (VOLTS_PER_COUNT,) * 8
    assert identity.max_rate_hz == pytest.approx(16_000.0)  # 4 Mbaud / 250 bits


def test_stream_is_the_simulator_signal_sample_for_sample(daq_driver):
    daq_driver.set_sample_rate(10_000)
    assert daq_driver.sample_rate_hz == 10_000
    daq_driver.start()
    counters, volts = collect(daq_driver, 3000)
    daq_driver.stop()
    assert counters[0] == 0 and np.all(np.diff(counters.astype(np.int64)) == 1)
    assert volts.shape[1] == 9
    # A twin source with the same seed gives the same deterministic signal; its random noise draws
    # depend on how the stream is cut into blocks, so compare the Hall pulses (3.3 V vs 5 mV noise:
    # thresholding at 1.65 V is exact) sample for sample, and the slow channels by their means
    # (noise 0.5 mV per sample, averaged over 3000 samples: 1 mV tolerance is > 50 sigma of the mean
    # difference but catches any scaling or channel-order mistake).
    twin = SharedTunnelSignals.from_simulator(seed=0).next_block_at_rate(len(counters), 10_000.0)
    np.testing.assert_array_equal(volts[:, 8] > 1.0, twin[:, 8] > 1.65)
    assert np.count_nonzero(volts[:, 8]) > 0
    np.testing.assert_allclose(volts[:, :8].mean(axis=0), twin[:, :8].mean(axis=0), atol=1e-3)
    stats = daq_driver.statistics
    assert (stats.crc_failures, stats.garbage_bytes, stats.lost_samples) == (0, 0, 0)


def test_a_wind_off_signal_is_digitised_once_and_its_mean_is_unbiased(
    daq_driver, simulated_tunnel_signals
):
    """Motor and fan off: a static signal plus the balance's noise, as in a wind-off tare. The board is the ADC
    (0.3125 mV steps); the simulator hands it analog volts. The mean of 20 000 samples equals the simulator's
    analog mean (gauge bias plus the weight through the inverse calibration) to within 0.02 mV: the noise (~0.2 mV
    per sample, below one step) leaves a standard error of ~2 uV, and one rounding with that dither is unbiased to
    far below it. A signal quantised twice, on the simulator's 20 V / 2^16 grid and then the board's 20.48 V / 2^16,
    keeps up to half a step (0.16 mV) of rounding error here, which the noise cannot average out."""
    source = simulated_tunnel_signals._source
    gauges = source.gauges
    expected = gauges.inverse @ source.true_cycle_average.sensor_loads + gauges.bias_v
    daq_driver.set_sample_rate(10_000)
    daq_driver.start()
    _, volts = collect(daq_driver, 20_000)
    daq_driver.stop()
    np.testing.assert_allclose(volts[:, :6].mean(axis=0), expected, atol=2e-5)


def test_rate_above_link_ceiling_is_refused_before_sending(daq_driver):
    with pytest.raises(UserInputError, match="16000"):
        daq_driver.set_sample_rate(20_000)
    assert daq_driver.query("RATE?") == "RATE 10000"


GARBAGE = b"\x00\xa5\x5a garbage \xa5"  # contains a false sync word and a lone sync byte


def run_with_fault(board, driver, inject) -> None:
    driver.start()
    collect(driver, 200)
    inject(board)
    deadline = time.monotonic() + 5.0
    while board.faults_pending and time.monotonic() < deadline:
        time.sleep(0.005)
    assert board.faults_pending == 0
    collect(driver, 200)  # frames after the damaged block: a loss at its end shows as a gap
    driver.stop()


@pytest.mark.parametrize(
    ("inject", "expected"),
    [
        (lambda b: b.inject_garbage(GARBAGE), {"garbage_bytes": len(GARBAGE), "lost_samples": 0}),
        (
            lambda b: b.truncate_next_frame(9),
            {"truncated_frames": 1, "lost_samples": 1, "garbage_bytes": 9},
        ),
        (lambda b: b.drop_samples(37), {"counter_gaps": 1, "lost_samples": 37, "crc_failures": 0}),
        (
            lambda b: b.corrupt_next_crc(3),
            {"crc_failures": 3, "lost_samples": 3, "garbage_bytes": 75},
        ),
    ],
    ids=["garbage", "truncated", "dropped", "crc"],
)
def test_faults_over_the_pty_are_counted_exactly(simulated_daq, daq_driver, inject, expected):
    run_with_fault(simulated_daq, daq_driver, inject)
    stats = daq_driver.statistics
    for name, value in expected.items():
        assert getattr(stats, name) == value, name
    assert stats.frames_ok >= 400


def test_unplug_mid_run_raises_disconnected_naming_the_instrument(simulated_daq, daq_driver):
    daq_driver.start()
    collect(daq_driver, 100)
    simulated_daq.unplug()
    with pytest.raises(InstrumentDisconnected, match=r"test DAQ: serial port /dev/pts/\d+ failed"):
        for _ in range(100):
            daq_driver.get_block(timeout_s=1.0)
    with pytest.raises(InstrumentDisconnected, match="test DAQ"):
        daq_driver.stop()


def test_stop_returns_to_command_mode_and_restart_continues_counters(daq_driver):
    daq_driver.start()
    first, _ = collect(daq_driver, 100)
    daq_driver.stop()
    assert daq_driver.identify().model == "ORNI-DAQ9"
    daq_driver.start()
    second, _ = collect(daq_driver, 100)
    daq_driver.stop()
    assert second[0] > first[-1]


def test_opening_a_missing_port_names_the_instrument(tmp_path):
    driver = SerialDaqDriver(str(tmp_path / "ttyNOPE"), name="balance DAQ")
    with pytest.raises(InstrumentDisconnected, match="balance DAQ: cannot open"):
        driver.open()


def wait_for(condition, timeout_s=30.0):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "condition not met within the deadline"
        time.sleep(0.01)


def test_a_board_left_streaming_by_a_crashed_host_is_stopped_drained_and_identified(simulated_daq):
    """A host that died mid-stream leaves the board streaming into the port: open() sends STOP, drains the stream
    and the board's full FIFO, then identifies the board; the next stream continues the board's counters."""
    import serial

    crashed_host = serial.Serial(simulated_daq.port_path, 4_000_000, timeout=0.05)
    crashed_host.write(b"START\n")
    wait_for(
        lambda: simulated_daq.samples_sent > 20_000
    )  # frames queued in the pty and the board's FIFO
    crashed_host.close()  # no STOP: the process is gone
    driver = SerialDaqDriver(simulated_daq.port_path, name="test DAQ")
    try:
        identity = driver.open()
        assert identity.model == "ORNI-DAQ9"
        assert driver.stale_bytes_discarded > 25 * 1000
        driver.start()
        counters, _ = collect(driver, 200)
        driver.stop()
    finally:
        driver.close()
    assert np.all(np.diff(counters.astype(np.int64)) == 1)
    assert counters[0] > 20_000  # the board's counter went on; nothing was mistaken for a reply


def test_a_reply_with_binary_bytes_is_named_by_size_not_printed():
    from ornitail.acquisition.serial_port_access import printable_excerpt

    assert printable_excerpt(bytes(range(256)) * 100) == "25600 bytes of binary data"
    assert printable_excerpt(b"ID model=X\n") == "'ID model=X'"


@pytest.mark.parametrize("garbled", ["RATE", "RATE fast", "10000", "RATE -5"])
def test_a_malformed_rate_reply_is_one_instrument_error_naming_it(
    simulated_daq, daq_driver, garbled
):
    """A board answering ``RATE?`` out of protocol (docs/daq-protocol.md: ``RATE 10000``) is refused by name."""
    answer = simulated_daq._handle_command

    def answer_rate_garbled(command: str) -> None:
        if command.strip().upper() == "RATE?":
            simulated_daq._reply(garbled)
        else:
            answer(command)

    simulated_daq._handle_command = answer_rate_garbled
    with pytest.raises(InstrumentReplyError, match=r"malformed reply to 'RATE\?'") as raised:
        daq_driver.set_sample_rate(10_000)
    assert "\n" not in str(raised.value)
