"""Net F/T RDT: requests and records byte for byte as ATI's manual (9620-05-NET FT, section 10) lays them out."""

import numpy as np
import pytest

from ornitail.acquisition import netft_protocol as protocol


def test_requests_are_header_command_and_sample_count_big_endian():
    # Section 10: {uint16 command_header = 0x1234; uint16 command; uint32 sample_count}, high byte first;
    # Table 10.1: 0x0000 stop streaming, 0x0002 start high-speed real-time streaming, 0x0042 set software bias.
    assert protocol.encode_request(protocol.COMMAND_START_REALTIME_STREAMING) == bytes(
        [0x12, 0x34, 0x00, 0x02, 0x00, 0x00, 0x00, 0x00]
    )
    assert protocol.encode_request(protocol.COMMAND_STOP_STREAMING) == bytes(
        [0x12, 0x34, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]
    )
    assert protocol.encode_request(protocol.COMMAND_SET_SOFTWARE_BIAS) == bytes(
        [0x12, 0x34, 0x00, 0x42, 0x00, 0x00, 0x00, 0x00]
    )
    # one record, as the driver asks on open: sample_count = 1 in the last four bytes
    assert protocol.encode_request(protocol.COMMAND_START_REALTIME_STREAMING, 1) == bytes.fromhex(
        "1234000200000001"
    )
    assert protocol.RDT_PORT == 49152


def test_request_layout_matches_the_manuals_own_example_bytes():
    # Section 10 (extended RDT requests, just before 10.3) prints a request for command 0x8002 (0x0002 with
    # the high bit set), infinite samples, to multicast 224.0.5.128 port 28250:
    # { 0x12, 0x34, 0x80, 0x02, 0x00, 0x00, 0x00, 0x00, 224, 0, 5, 128, 0x6e, 0x5a }; its first eight bytes
    # are the standard request layout.
    assert protocol.encode_request(0x8002, 0) == bytes(
        [0x12, 0x34, 0x80, 0x02, 0x00, 0x00, 0x00, 0x00]
    )


def test_requests_decode_and_bad_ones_are_refused():
    assert protocol.decode_request(bytes.fromhex("1234004200000000")) == (0x0042, 0)
    assert protocol.decode_request(bytes.fromhex("12340002000003e8")) == (0x0002, 1000)
    with pytest.raises(ValueError, match="header 0x4321"):
        protocol.decode_request(bytes.fromhex("4321000200000000"))
    with pytest.raises(ValueError, match="8 bytes"):
        protocol.decode_request(bytes.fromhex("12340002"))
    with pytest.raises(ValueError):
        protocol.encode_request(0x10000)


# Section 10 record: uint32 rdt_sequence, uint32 ft_sequence, uint32 status, int32 Fx Fy Fz Tx Ty Tz.
MANUAL_LAYOUT_RECORD = bytes.fromhex(
    "00000001"  # rdt_sequence = 1 (a request's first record)
    "00abcdef"  # ft_sequence = 11259375
    "80000000"  # status: top bit set
    "000f4240"  # Fx = 1 000 000
    "ffd9da60"  # Fy = -2 500 000
    "00000000"  # Fz = 0
    "0000007b"  # Tx = 123
    "ffffffff"  # Ty = -1
    "7fffffff"  # Tz = 2**31 - 1
)


def test_record_from_the_manuals_layout_decodes_to_counts_and_si():
    assert len(MANUAL_LAYOUT_RECORD) == protocol.RECORD_LENGTH == 36
    records = protocol.decode_records(MANUAL_LAYOUT_RECORD)
    assert records.rdt_sequence.tolist() == [1]
    assert records.ft_sequence.tolist() == [11259375]
    assert records.status.tolist() == [0x80000000]
    assert records.counts.tolist() == [[1_000_000, -2_500_000, 0, 123, -1, 2**31 - 1]]

    newton_and_metre = protocol.CountsPerUnit(1_000_000, 1_000_000, "N", "Nm")
    np.testing.assert_allclose(
        newton_and_metre.to_si(records.counts)[0],
        [1.0, -2.5, 0.0, 123e-6, -1e-6, (2**31 - 1) * 1e-6],
        rtol=1e-15,
    )
    # The same counts from a sensor set up in lbf and lbf-in, 1000 counts per unit each.
    imperial = protocol.CountsPerUnit(1000, 1000, "lbf", "lbf-in")
    np.testing.assert_allclose(
        imperial.to_si(records.counts)[0, :4],
        [1000 * 4.4482216152605, -2500 * 4.4482216152605, 0.0, 0.123 * 0.112984829027617],
        rtol=1e-15,
    )


def test_records_encode_to_the_manuals_layout_and_back_to_back_in_one_datagram():
    record = protocol.decode_records(MANUAL_LAYOUT_RECORD)
    assert protocol.encode_records(record) == MANUAL_LAYOUT_RECORD
    two = protocol.decode_records(
        MANUAL_LAYOUT_RECORD * 2
    )  # buffered mode packs several per datagram
    assert two.counts.shape == (2, 6)
    with pytest.raises(ValueError, match="whole number of 36-byte"):
        protocol.decode_records(MANUAL_LAYOUT_RECORD[:-1])


@pytest.mark.parametrize(
    ("previous", "sequence", "lost"),
    [
        (0, [1, 2, 3], 0),  # a request's records start at 1
        (0, [3, 4], 2),
        (10, [11, 14, 15, 20], 2 + 4),
        (2**32 - 2, [2**32 - 1, 0, 1], 0),  # rolls over to zero after 4294967295
        (2**32 - 1, [2], 2),  # 0 and 1 lost across the roll-over
        (10, [9, 10, 11], 0),  # a reordered or repeated datagram loses nothing
        # 60 overtaken by 61 across two blocks: its hole was counted when 61 came (previous is the newest, 61), not
        # again on the step from 60 to 62 (it was, until stop 36: two lost for one late record)
        (61, [60, 62], 0),
        (
            10,
            [12, 11, 13],
            1,
        ),  # the hole 12 skipped, counted once (the driver sorts a block before counting)
    ],
)
def test_lost_records_from_sequence_gaps(previous, sequence, lost):
    assert protocol.lost_records(np.array(sequence, dtype=np.uint32), previous) == lost


@pytest.mark.parametrize(
    ("previous", "sequence", "newest"),
    [
        (0, [1, 2, 3], 3),
        (61, [60, 62], 62),
        (61, [59, 60], 61),  # late records leave the newest where it was
        (2**32 - 2, [2**32 - 1, 0, 1], 1),  # across the roll-over
    ],
)
def test_the_newest_sequence_number_is_kept_across_late_records(previous, sequence, newest):
    assert protocol.newest_sequence(np.array(sequence, dtype=np.uint32), previous) == newest


@pytest.mark.parametrize(
    ("arrived", "arrival_order"),
    [
        ([59, 61, 60, 62], [0, 2, 1, 3]),  # 60 overtaken by 61 on the way
        ([2**32 - 1, 1, 0], [0, 2, 1]),  # across the roll-over: 0 follows 4294967295
        ([5, 5, 6], [0, 1, 2]),  # a repeat stays (lost_records counts it as nothing lost)
    ],
)
def test_records_reordered_within_a_block_are_put_back_in_the_devices_order(arrived, arrival_order):
    count = len(arrived)
    sequence = np.array(arrived, dtype=np.uint32)
    records = protocol.RdtRecords(
        rdt_sequence=sequence,
        ft_sequence=sequence * np.uint32(7),
        status=np.arange(count, dtype=np.uint32),
        counts=np.tile(
            np.arange(count, dtype=np.int32)[:, None], (1, 6)
        ),  # each record tagged by arrival
    )
    ordered = protocol.in_sequence_order(records)
    assert ordered.rdt_sequence.tolist() == sequence[arrival_order].tolist()
    # every field moves with its record
    assert ordered.ft_sequence.tolist() == (sequence[arrival_order] * np.uint32(7)).tolist()
    assert ordered.status.tolist() == arrival_order
    assert ordered.counts[:, 5].tolist() == arrival_order
    previous = (int(ordered.rdt_sequence[0]) - 1) % 2**32
    assert protocol.lost_records(ordered.rdt_sequence, previous) == 0


# Trimmed from the element names of the manual's section 9.1 (netftapi2.xml); root <netft> as devices serve it.
DEVICE_XML = """<?xml version="1.0"?><netft>
<runstat>0x00000000</runstat><runrate>7000</runrate>
<scfgfu>N</scfgfu><scfgtu>Nm</scfgtu>
<cfgcpf>1000000</cfgcpf><cfgcpt>1000000</cfgcpt>
<comrdte>Enabled</comrdte><comrdtrate>7000</comrdtrate>
</netft>"""


def test_netftapi2_xml_gives_counts_per_unit_and_units():
    scaling = protocol.parse_netftapi2(DEVICE_XML)
    assert scaling == protocol.CountsPerUnit(1_000_000, 1_000_000, "N", "Nm")
    np.testing.assert_array_equal(scaling.si_per_count(), [1e-6] * 6)
    millimetre = protocol.parse_netftapi2(
        DEVICE_XML.replace(">Nm<", ">N-mm<").replace("<cfgcpt>1000000", "<cfgcpt>1000")
    )
    np.testing.assert_allclose(millimetre.si_per_count()[3:], [1e-6] * 3, rtol=1e-15)


@pytest.mark.parametrize(
    ("xml", "message"),
    [
        (DEVICE_XML.replace("<cfgcpt>1000000</cfgcpt>", ""), "no <cfgcpt> value"),
        (DEVICE_XML.replace("<cfgcpf>1000000", "<cfgcpf>lots"), "not numbers"),
        (DEVICE_XML.replace("<scfgfu>N<", "<scfgfu>stone<"), "unknown force unit 'stone'"),
        (DEVICE_XML.replace("<cfgcpf>1000000", "<cfgcpf>0"), "positive"),
        ("<netft><cfgcpf>1", "not well-formed"),
    ],
)
def test_malformed_netftapi2_xml_is_refused_naming_the_problem(xml, message):
    with pytest.raises(ValueError, match=message):
        protocol.parse_netftapi2(xml)


def test_formatted_page_parses_back_and_writes_whole_counts_as_devices_do():
    scaling = protocol.CountsPerUnit(1_000_000, 1000, "lbf", "lbf-ft")
    page = protocol.format_netftapi2(scaling)
    assert "<cfgcpf>1000000</cfgcpf>" in page and "<cfgcpt>1000</cfgcpt>" in page
    assert protocol.parse_netftapi2(page) == scaling


def test_si_to_counts_rounds_to_the_nearest_count_and_clips():
    scaling = protocol.CountsPerUnit(1000, 1000, "N", "Nm")
    counts = scaling.to_counts(np.array([[0.0014, 0.0016, -0.0016, 1e9, -1e9, 0.0]]))
    assert counts.tolist() == [[1, 2, -2, 2**31 - 1, -(2**31), 0]]
