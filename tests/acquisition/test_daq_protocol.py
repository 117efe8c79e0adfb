"""Byte-level tests of the ORNI-DAQ9 frame format and the vectorised parser (no transport)."""

import numpy as np
import pytest

from ornitail.acquisition.crc16 import crc16_ccitt_false, crc16_ccitt_false_rows
from ornitail.acquisition.daq_protocol import (
    FRAME_LENGTH_BYTES,
    DaqFrameParser,
    DaqIdentity,
    encode_frames,
    format_identity,
    link_ceiling_frames_per_s,
    parse_identity,
)


def bitwise_crc16_ccitt_false(data: bytes) -> int:
    """Reference CRC computed bit by bit (independent of the table-driven implementation)."""
    register = 0xFFFF
    for byte in data:
        register ^= byte << 8
        for _ in range(8):
            register = ((register << 1) ^ 0x1021) if register & 0x8000 else register << 1
            register &= 0xFFFF
    return register


@pytest.mark.parametrize(
    ("data", "expected"),
    [(b"123456789", 0x29B1), (b"", 0xFFFF), (bytes(range(256)), None), (b"\xa5\x5a" * 7, None)],
)
def test_crc_matches_check_value_and_bitwise_reference(data, expected):
    reference = bitwise_crc16_ccitt_false(data)
    if expected is not None:
        assert reference == expected
    assert crc16_ccitt_false(data) == reference
    rows = np.frombuffer(data, dtype=np.uint8)[None, :].repeat(3, axis=0)
    assert crc16_ccitt_false_rows(rows).tolist() == [reference] * 3


def test_frame_bytes_are_exactly_as_documented():
    counts = np.array([[0, 1, -1, 32767, -32768, 256, 2, 3]], dtype=np.int16)
    frame = encode_frames(np.array([1]), counts, np.array([0x01]))
    body = bytes.fromhex("0100000000000100ffffff7f008000010200030001")
    crc = bitwise_crc16_ccitt_false(body)
    assert frame == b"\xa5\x5a" + body + bytes([crc & 0xFF, crc >> 8])
    assert len(frame) == FRAME_LENGTH_BYTES == 25


def test_link_ceiling_fits_ten_kilohertz():
    # 25 bytes * 10 bits (8N1) = 250 bits per frame; 4 Mbaud / 250 = 16000 frames/s
    assert link_ceiling_frames_per_s(4_000_000) == pytest.approx(16_000.0)
    assert link_ceiling_frames_per_s(2_000_000) == pytest.approx(8_000.0)  # too slow for 10 kHz


def make_stream(n_frames: int, first_counter: int = 0, seed: int = 1) -> tuple[bytes, np.ndarray]:
    rng = np.random.default_rng(seed)
    counts = rng.integers(-32768, 32768, size=(n_frames, 8)).astype(np.int16)
    counters = first_counter + np.arange(n_frames)
    return encode_frames(counters, counts, (counters % 2).astype(np.uint8)), counts


def feed_in_chunks(parser: DaqFrameParser, data: bytes, chunk: int):
    parts = [parser.feed(data[i : i + chunk]) for i in range(0, len(data), chunk)]
    parts.append(parser.feed(b"", final=True))
    return np.concatenate([p.counters for p in parts]), np.concatenate([p.counts for p in parts])


@pytest.mark.parametrize("chunk", [1, 7, 25, 26, 333, 100_000])
def test_clean_stream_decodes_exactly_whatever_the_chunking(chunk):
    data, counts = make_stream(200)
    parser = DaqFrameParser()
    counters, decoded_counts = feed_in_chunks(parser, data, chunk)
    assert counters.tolist() == list(range(200))
    np.testing.assert_array_equal(decoded_counts, counts)
    stats = parser.statistics
    assert (stats.frames_ok, stats.garbage_bytes, stats.crc_failures, stats.lost_samples) == (
        200,
        0,
        0,
        0,
    )


@pytest.mark.parametrize("chunk", [5, 25, 64, 100_000])
@pytest.mark.parametrize("garbage", [b"\x00\x01\x02", b"\xa5\x5a\xa5\x5a junk \xa5", b"\xa5" * 30])
def test_garbage_is_skipped_and_counted_and_next_frame_recovered(chunk, garbage):
    data, _ = make_stream(40)
    split = 10 * FRAME_LENGTH_BYTES
    parser = DaqFrameParser()
    counters, _ = feed_in_chunks(parser, data[:split] + garbage + data[split:], chunk)
    # every frame survives: the frame right after the garbage is found again (resync in one frame)
    assert counters.tolist() == list(range(40))
    assert parser.statistics.garbage_bytes == len(garbage)
    assert parser.statistics.lost_samples == 0


@pytest.mark.parametrize("kept_bytes", [1, 2, 9, 24])
def test_truncated_frame_loses_only_itself(kept_bytes):
    data, _ = make_stream(30)
    start = 12 * FRAME_LENGTH_BYTES
    damaged = data[: start + kept_bytes] + data[start + FRAME_LENGTH_BYTES :]
    parser = DaqFrameParser()
    counters, _ = feed_in_chunks(parser, damaged, 50)
    assert counters.tolist() == [c for c in range(30) if c != 12]
    stats = parser.statistics
    assert (stats.counter_gaps, stats.lost_samples, stats.garbage_bytes) == (1, 1, kept_bytes)
    # a frame cut before its sync word was complete leaves no sync word to count as truncated
    assert stats.truncated_frames == (1 if kept_bytes >= 2 else 0)


def test_corrupted_crc_is_counted_and_frame_rejected():
    data = bytearray(make_stream(30)[0])
    for frame in (3, 17):
        data[frame * FRAME_LENGTH_BYTES + 8] ^= 0x40  # flip a payload bit
    parser = DaqFrameParser()
    counters, _ = feed_in_chunks(parser, bytes(data), 60)
    assert counters.tolist() == [c for c in range(30) if c not in (3, 17)]
    assert parser.statistics.crc_failures == 2
    assert parser.statistics.lost_samples == 2


@pytest.mark.parametrize("dropped", [1, 5, 1000])
def test_counter_gap_counts_the_dropped_samples(dropped):
    first, _ = make_stream(10)
    second, _ = make_stream(10, first_counter=10 + dropped)
    parser = DaqFrameParser()
    feed_in_chunks(parser, first + second, 40)
    assert parser.statistics.counter_gaps == 1
    assert parser.statistics.lost_samples == dropped


def test_counter_wraps_at_two_to_the_32_without_a_gap():
    data, _ = make_stream(6, first_counter=2**32 - 3)
    parser = DaqFrameParser()
    counters, _ = feed_in_chunks(parser, data, 25)
    assert counters.tolist() == [2**32 - 3, 2**32 - 2, 2**32 - 1, 0, 1, 2]
    assert parser.statistics.counter_gaps == 0 and parser.statistics.counter_resets == 0


def test_identity_line_round_trips():
    identity = DaqIdentity(
        "ORNI-DAQ9",
        "SN42",
        "1.0.0",
        tuple(f"c{i}" for i in range(9)),
        (3.125e-4,) * 8,
        10.24,
        3.3,
        4_000_000,
        16_000.0,
    )
    line = format_identity(identity)
    assert line.startswith("ID model=ORNI-DAQ9 serial=SN42 firmware=1.0.0 channels=c0,c1,")
    assert parse_identity(line) == identity
    with pytest.raises(ValueError):
        parse_identity("ID model=X serial=1")
