"""The ORNI-DAQ9 firmware's portable core against the Python driver, over a real pty.

``firmware/orni-daq9/src`` (framing, CRC, counter, command parser, rate validation) is the code the RP2040
runs; here it is built with the host's C compiler into a harness (``firmware/orni-daq9/host``) that acts as
the board on the master end of a pty, with a deterministic synthetic signal in place of the ADC. The real
:class:`SerialDaqDriver` opens the slave end as it would the board's USB-serial port. The hardware file
(``target/rp2040_main.c``) needs the Pico SDK and is not built here.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import serial

from ornitail.acquisition.crc16 import crc16_ccitt_false
from ornitail.acquisition.daq_protocol import (
    CHANNEL_NAMES,
    STOP_MARKER,
    VOLTS_PER_COUNT,
    DaqFrameParser,
    DaqIdentity,
    encode_frames,
    format_identity,
)
from ornitail.acquisition.serial_daq_driver import SerialDaqDriver
from ornitail.simulated_instruments.pty_transport import PseudoTerminalPair

FIRMWARE = Path(__file__).resolve().parents[2] / "firmware" / "orni-daq9"
PROTOCOL_DOC = Path(__file__).resolve().parents[2] / "docs" / "daq-protocol.md"
DEADLINE_S = 30.0
"""Generous bound on any wait (a loaded machine may be slow); never a timing assertion, s."""

# The harness's synthetic source (host/daq9_host.c): ADC code of channel k for sample n.
MULTIPLIERS = np.array([40503, 9973, 30011, 1021, 65521, 257, 12347, 77], dtype=np.uint64)
CHANNEL_OFFSETS = 4099 * np.arange(8, dtype=np.uint64)


def synthetic_source(counters: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 8) int16 counts and (n,) bool Hall levels the harness sends for these counters."""
    n = np.asarray(counters, dtype=np.uint64)
    codes = (n[:, None] * MULTIPLIERS + CHANNEL_OFFSETS) & 0xFFFF
    codes[:, 2] = np.where(n % 1000 == 999, 0xFFFF, codes[:, 2])  # over-range once per 1000
    counts = (codes.astype(np.int64) - 32768).astype(np.int16)  # offset binary, like the ADS8688
    return counts, ((n >> 5) & 1).astype(bool)


@pytest.fixture(scope="module")
def harness(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The host harness built from the firmware sources into a temporary folder."""
    compiler = next(
        (found for name in ("cc", "gcc", "clang") if (found := shutil.which(name))), None
    )
    if compiler is None:
        pytest.skip("no C compiler (cc, gcc or clang) on PATH to build the firmware's host harness")
    binary = tmp_path_factory.mktemp("orni-daq9") / "daq9_host"
    sources = [FIRMWARE / "host" / "daq9_host.c", *sorted((FIRMWARE / "src").glob("*.c"))]
    command = [compiler, "-std=c11", "-O2", "-Wall", "-Wextra", "-I", str(FIRMWARE / "src")]
    built = subprocess.run(
        [*command, "-o", str(binary), *map(str, sources), "-lm"],
        capture_output=True,
        text=True,
        timeout=DEADLINE_S,
    )
    assert built.returncode == 0, f"the firmware does not compile on the host:\n{built.stderr}"
    return binary


def run_harness(harness: Path, *args: str, records: str = "") -> str:
    """Run a one-shot mode of the harness (``crc``, ``encode``, ``sample``); its standard output."""
    done = subprocess.run(
        [str(harness), *args], input=records, capture_output=True, text=True, timeout=DEADLINE_S
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


class FirmwareBoard:
    """The harness serving as the board on a pty; the driver opens :attr:`port_path`."""

    def __init__(self, harness: Path, *args: str) -> None:
        self._pty = PseudoTerminalPair.open_raw()
        self.port_path = self._pty.slave_path
        self.process = subprocess.Popen(
            [str(harness), "serve", *args], stdin=self._pty.master_fd, stdout=self._pty.master_fd
        )

    def close(self) -> None:
        """Close the pty; the harness sees the line hang up and exits."""
        self._pty.close()
        try:
            self.process.wait(timeout=DEADLINE_S)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


@pytest.fixture
def board(harness: Path) -> Iterator[FirmwareBoard]:
    firmware_board = FirmwareBoard(harness, "--serial", "TEST0042")
    yield firmware_board
    firmware_board.close()


@pytest.fixture
def line(board: FirmwareBoard) -> Iterator[serial.Serial]:
    """The board's port opened raw (no driver), to see its exact replies."""
    port = serial.Serial(board.port_path, baudrate=4_000_000, timeout=DEADLINE_S)
    yield port
    port.close()


def exchange(port: serial.Serial, command: str) -> str:
    """Send one command line; the reply line without its newline."""
    port.write(command.encode("latin-1") + b"\n")
    reply = port.read_until(b"\n")
    assert reply.endswith(b"\n"), f"no reply to {command!r} within {DEADLINE_S:g} s"
    return reply[:-1].decode("ascii")


def stream(driver: SerialDaqDriver, n_samples: int) -> tuple[np.ndarray, ...]:
    """Start, stop once ``n_samples`` arrived; counters, volts and saturation flags of every sample sent."""
    driver.start()
    blocks = []
    while sum(len(block.counters) for block in blocks) < n_samples:
        block = driver.get_block(timeout_s=DEADLINE_S)
        assert block is not None, f"no data from the firmware harness within {DEADLINE_S:g} s"
        blocks.append(block)
    driver.stop()
    while (block := driver.get_block(timeout_s=0)) is not None:  # sent before the stop marker
        blocks.append(block)
    return (
        np.concatenate([block.counters for block in blocks]),
        np.vstack([block.volts for block in blocks]),
        np.concatenate([block.saturated for block in blocks]),
    )


def assert_is_the_synthetic_source(
    counters: np.ndarray, volts: np.ndarray, saturated: np.ndarray
) -> None:
    """Every decoded value equals what the harness's source gives for that counter."""
    counts, hall = synthetic_source(counters)
    np.testing.assert_array_equal(volts[:, :8], counts * VOLTS_PER_COUNT)
    np.testing.assert_array_equal(volts[:, 8], np.where(hall, 3.3, 0.0))
    at_limit = np.any((counts == -32768) | (counts == 32767), axis=1)
    np.testing.assert_array_equal(saturated, at_limit)


def test_crc_is_ccitt_false_with_the_documented_check_value(harness: Path) -> None:
    assert run_harness(harness, "crc", "123456789") == "29b1\n"
    text = "ORNI-DAQ9 frame bytes"
    assert int(run_harness(harness, "crc", text), 16) == crc16_ccitt_false(text.encode())


def test_encoder_reproduces_the_documented_example_frames_byte_for_byte(harness: Path) -> None:
    documented = re.findall(r"a5 5a(?: [0-9a-f]{2}){23}", PROTOCOL_DOC.read_text())
    assert len(documented) == 3
    fields = [
        "1 1 0 1 -1 32767 -32768 256 2 3",  # status 0x01 as given (bit 1 clear for illustration)
        "0x12345678 0 3200 -3200 0 0 0 0 6080 4339",
        "2 2 0 0 32767 0 0 0 0 0",
    ]
    assert run_harness(harness, "encode", records="\n".join(fields)).splitlines() == documented
    # with the status the board computes itself (Hall level given): the over-range bit is set
    # whenever a channel reads a limit, so the first example goes out with status 0x03
    board_frames = run_harness(
        harness,
        "sample",
        records="1 1 0 1 -1 32767 -32768 256 2 3\n"
        "0x12345678 0 3200 -3200 0 0 0 0 6080 4339\n2 0 0 0 32767 0 0 0 0 0\n",
    ).splitlines()
    assert board_frames[1:] == documented[1:]
    first = bytes.fromhex(board_frames[0])
    assert first[22] == 0x03 and first[:22] == bytes.fromhex(documented[0])[:22]
    decoded = DaqFrameParser().feed(first, final=True)
    assert decoded.status.tolist() == [0x03]


def test_encoder_agrees_with_the_python_encoder_on_random_frames(harness: Path) -> None:
    rng = np.random.default_rng(17)
    counters = rng.integers(0, 2**32, 200, dtype=np.uint64)
    counts = rng.integers(-32768, 32768, (200, 8)).astype(np.int16)
    status = rng.integers(0, 4, 200).astype(np.uint8)
    records = "\n".join(
        " ".join(map(str, [int(c), int(s), *row.tolist()]))
        for c, s, row in zip(counters, status, counts, strict=True)
    )
    frames = bytes.fromhex(run_harness(harness, "encode", records=records).replace("\n", " "))
    assert frames == encode_frames(counters, counts, status)


def test_command_replies_are_the_documented_lines(line: serial.Serial) -> None:
    identity = DaqIdentity(
        model="ORNI-DAQ9",
        serial_number="TEST0042",
        firmware="1.0.0",
        channels=CHANNEL_NAMES,
        volts_per_count=(VOLTS_PER_COUNT,) * 8,
        range_v=10.24,
        hall_high_v=3.3,
        baud=4_000_000,
        max_rate_hz=16_000.0,
    )
    line.write(b"\n")  # an empty line gets no reply: the next reply is the one to ID?
    assert exchange(line, "ID?") == format_identity(identity)
    assert exchange(line, "RATE?") == "RATE 10000"  # power-up rate
    assert exchange(line, "RATE 20000") == "ERR rate 20000 outside 100..16000 Hz"
    assert exchange(line, "RATE 99.5") == "ERR rate 99.5 outside 100..16000 Hz"
    assert exchange(line, "RATE fast") == "ERR rate 'fast' is not a number"
    assert exchange(line, "RATE?") == "RATE 10000"  # refused rates leave it unchanged
    assert exchange(line, "RATE 16000") == "OK"
    assert exchange(line, "RATE?") == "RATE 16000"
    assert exchange(line, "RATE 100") == "OK"
    assert exchange(line, "RATE?") == "RATE 100"
    # the RP2040's timer makes 128 MHz / whole counts: 3000 Hz is 42667 counts, 2999.98 Hz
    assert exchange(line, "rate 3000") == "OK"
    assert exchange(line, "RATE?") == "RATE 2999.98"
    assert exchange(line, "HELLO") == "ERR unknown command 'HELLO'"
    assert exchange(line, "RATE") == "ERR unknown command 'RATE'"
    assert exchange(line, "  ID? please ") == "ERR unknown command 'ID? please'"
    assert exchange(line, "X" * 70) == f"ERR unknown command '{'X' * 64}...'"
    assert exchange(line, "STOP") == "OK STOPPED"  # also when not streaming


def test_while_streaming_only_stop_is_heard(line: serial.Serial) -> None:
    assert exchange(line, "START") == "OK"
    line.write(b"RATE 500\nID?\nBOGUS\n")
    line.write(b"STOP\n")
    stream = line.read_until(STOP_MARKER)
    assert stream.endswith(STOP_MARKER), f"no stop marker within {DEADLINE_S:g} s"
    parser = DaqFrameParser()
    decoded = parser.feed(stream[: -len(STOP_MARKER)], final=True)
    # nothing but whole frames before the marker: no reply line slipped into the stream
    assert parser.statistics.garbage_bytes == 0 and parser.statistics.truncated_frames == 0
    np.testing.assert_array_equal(decoded.counters, np.arange(len(decoded)))
    assert exchange(line, "RATE?") == "RATE 10000"


def test_driver_streams_the_firmware_frames_value_for_value(board: FirmwareBoard) -> None:
    with SerialDaqDriver(board.port_path, name="firmware harness") as driver:
        assert driver.identity.serial_number == "TEST0042"
        assert driver.identity.max_rate_hz == 16_000.0
        driver.set_sample_rate(10_000)
        assert driver.sample_rate_hz == 10_000
        counters, volts, saturated = stream(driver, 2000)
        np.testing.assert_array_equal(counters, np.arange(len(counters)))
        assert_is_the_synthetic_source(counters, volts, saturated)
        assert np.count_nonzero(saturated) >= 1 and 0 < np.count_nonzero(volts[:, 8]) < len(volts)

        # a second run continues the counter from the last sample sent
        again, volts, saturated = stream(driver, 500)
        assert again[0] == counters[-1] + 1
        np.testing.assert_array_equal(np.diff(again.astype(np.int64)), 1)
        assert_is_the_synthetic_source(again, volts, saturated)
        statistics = driver.statistics
        assert statistics.frames_ok == len(again)
        assert (
            statistics.crc_failures,
            statistics.truncated_frames,
            statistics.garbage_bytes,
            statistics.counter_gaps,
            statistics.counter_resets,
        ) == (0, 0, 0, 0, 0)


def test_the_counter_wraps_at_2_to_the_32(harness: Path) -> None:
    first = 2**32 - 300
    wrapping = FirmwareBoard(harness, "--first-counter", str(first))
    try:
        with SerialDaqDriver(wrapping.port_path, name="firmware harness") as driver:
            driver.set_sample_rate(16_000)  # the link ceiling
            counters, volts, saturated = stream(driver, 1000)
            statistics = driver.statistics
    finally:
        wrapping.close()
    expected = (first + np.arange(len(counters), dtype=np.int64)) % 2**32
    np.testing.assert_array_equal(counters, expected)
    assert_is_the_synthetic_source(counters, volts, saturated)
    assert (statistics.counter_gaps, statistics.counter_resets, statistics.crc_failures) == (
        0,
        0,
        0,
    )
