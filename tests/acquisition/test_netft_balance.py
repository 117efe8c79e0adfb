"""The Net F/T as a rig balance: the rig file's ``[balance.netft]``, gauge volts from the device's loads, sample
counters and link health, and the RDT rate checked against the records. Against the simulated device over real UDP
and HTTP on the loopback; waits are on conditions with generous deadlines, never on sleeps."""

import time

import numpy as np
import pytest

from ornitail.acquisition.instrument_errors import InstrumentReplyError
from ornitail.acquisition.netft_balance import NetFtBalance
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, read_rig_file
from ornitail.calibration.ati_calibration import AtiCalibration
from ornitail.core.errors import UserInputError
from ornitail.simulated_instruments.netft import SimulatedNetFt, constant_load

DATA = DEFAULT_RIG_FILE.parent
NETFT_AUX_RIG = DATA / "simulated_rig_netft_aux.toml"
MATRIX_SI = AtiCalibration.from_file(DATA / "calibration" / "FT8884.cal").matrix_si
DEADLINE_S = 30.0
LOAD = np.array([0.3, -0.2, 1.5, 0.004, -0.006, 0.002])  # N and N m


def balance_for(device: SimulatedNetFt, rdt_rate_hz: float) -> NetFtBalance:
    return NetFtBalance(
        device.host,
        rdt_port=device.rdt_port,
        http_port=device.http_port,
        calibration_matrix_si=MATRIX_SI,
        rdt_rate_hz=rdt_rate_hz,
        name="test Net F/T",
    )


def blocks_until(read, enough, deadline_s: float = DEADLINE_S) -> list:
    blocks: list = []
    deadline = time.monotonic() + deadline_s
    while not (blocks and enough(blocks)):
        assert time.monotonic() < deadline, "condition not reached before the deadline"
        block = read(0.5)
        if block is not None:
            blocks.append(block)
    return blocks


def rig_text(**replacements: str) -> str:
    text = NETFT_AUX_RIG.read_text()
    for old, new in replacements.items():
        assert old in text, old
        text = text.replace(old, new)
    return text


def test_packaged_netft_rig_file_reads():
    description = read_rig_file(NETFT_AUX_RIG)
    assert description.balance_route == "netft" and description.carries_flap_channels
    assert (description.netft.rdt_port, description.netft.rdt_rate_hz) == (49152, 1000.0)
    assert description.netft.counts_per_unit is None  # read from the device's netftapi2.xml at open
    assert description.balance_sample_rate_hz() == description.aux_daq.sample_rate_hz


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "rdt_rate_hz = 1000.0",
            "rdt_rate_hz = 900.0",
            r"\[balance.netft\].rdt_rate_hz: 900 records/s is not an RDT output rate",
        ),
        ('route = "netft"', 'route = "can"', r"\[balance.netft\]: only with route = \"netft\""),
        ("rdt_port = 49152", "rdt_port = 0", r"\[balance.netft\].rdt_port: 0 must be >= 1"),
    ],
)
def test_netft_table_mistakes_are_one_line_naming_file_and_key(tmp_path, old, new, message):
    path = tmp_path / "rig.toml"
    path.write_text(rig_text(**{old: new}))
    (tmp_path / "calibration").symlink_to(DATA / "calibration")
    (tmp_path / "tunnel_table.csv").symlink_to(DATA / "tunnel_table.csv")
    with pytest.raises(UserInputError, match=rf"rig.toml: {message}") as raised:
        read_rig_file(path)
    assert "\n" not in str(raised.value)


def test_net_ft_alone_streams_gauge_volts_counted_by_rdt_sequence():
    with SimulatedNetFt(constant_load(LOAD), rate_hz=1000.0, drop_rdt_sequences={40, 41}) as device:
        balance = balance_for(device, 1000.0)
        try:
            assert "counts_per_force=1000000 N" in balance.open()
            assert balance.start_stream(1000.0) == 1000.0
            blocks = blocks_until(balance.read_block, lambda b: int(b[-1].counters[-1]) >= 100)
            balance.stop_stream()
            counts = balance.link_counts()
        finally:
            balance.close()
    counters = np.concatenate([block.counters for block in blocks]).astype(np.int64)
    volts = np.vstack([block.volts for block in blocks])
    assert counters[0] == 1 and 40 not in counters and 41 not in counters
    assert counts.lost_samples == 2  # the two rdt_sequence gaps
    # the gauge volts, through the rig file's .cal matrix, give back the loads: the device digitises them at 1e6
    # counts per N and per N m, so within a micro-unit (plus the matrix inverse's rounding)
    np.testing.assert_allclose(volts @ MATRIX_SI.T, np.tile(LOAD, (len(volts), 1)), atol=2e-6)
    assert not np.concatenate([block.saturated for block in blocks]).any()


def test_records_at_another_rate_than_the_rig_file_says_are_refused_in_one_line():
    with SimulatedNetFt(constant_load(LOAD), rate_hz=500.0) as device:
        balance = balance_for(device, 1000.0)
        try:
            balance.open()
            balance.start_stream(1000.0)
            with pytest.raises(InstrumentReplyError) as raised:
                blocks_until(balance.read_timed_gauges, lambda b: False)
        finally:
            balance.close()
    message = str(raised.value)
    assert message.startswith("test Net F/T: records from 127.0.0.1:") and "\n" not in message
    assert "14 internal samples apart (500 records/s), not 7 (1000 records/s" in message
    assert "[balance.netft].rdt_rate_hz" in message


def timed_sample_steps(samples: int, **faults) -> tuple[np.ndarray, object]:
    """The steps (s) between the first ``samples`` sample times of a 500 records/s stream from a device with
    ``faults``, and the link counts."""
    with SimulatedNetFt(constant_load(LOAD), rate_hz=500.0, **faults) as device:
        balance = balance_for(device, 500.0)
        try:
            balance.open()
            balance.start_stream(500.0)
            blocks = blocks_until(
                balance.read_timed_gauges, lambda b: sum(len(x.sample_time_s) for x in b) >= samples
            )
            balance.stop_stream()
            counts = balance.link_counts()
        finally:
            balance.close()
    return np.diff(np.concatenate([block.sample_time_s for block in blocks])), counts


def test_a_burst_of_lost_records_is_counted_as_lost_not_refused_as_a_wrong_rate():
    """Every other record from 40 to 200 lost: for 0.3 s each record arrives 28 internal samples after the one
    before it, as a 250 records/s stream's would; the rdt_sequence steps of 2 show them lost, not the rate wrong."""
    dropped = set(range(40, 201, 2))
    steps_s, counts = timed_sample_steps(300, drop_rdt_sequences=dropped)
    assert np.median(steps_s) == pytest.approx(0.002, rel=0.1)  # the device's own 2 ms spacing
    assert counts.lost_samples == len(dropped)


def test_a_datagram_overtaken_by_the_next_is_left_out_of_the_timed_stream():
    """Records 120, 180 and 240 arrive after the record that follows them. The driver puts a pair that falls in one
    block back in order; a late record whose successor came in an earlier block is left out of the timed stream.
    Before, its ft_sequence step back read as the counter wrapping round, and the line re-placed under it misplaced
    the records around it by 2-8 ms (steps of 0.05 ms and 10.3 ms between records 2 ms apart). The sample times
    step by the device's 2 ms, or 4 ms across a left-out record; 1 ms of slack is for the counter line's own
    refinement as lower arrival times come in (about 0.1-0.3 ms here after the first 100 records)."""
    steps_s, counts = timed_sample_steps(350, late_rdt_sequences={120, 180, 240})
    # a late record is lost to the stream only when its successor came a block before it, and then counted once
    assert counts.lost_samples <= 3
    steps_s = steps_s[100:]
    off_period_s = np.minimum(np.abs(steps_s - 0.002), np.abs(steps_s - 0.004))
    assert np.all(off_period_s < 0.001), np.round(steps_s[off_period_s >= 0.001] * 1e3, 3)


def test_a_rate_other_than_the_devices_is_refused_before_streaming():
    balance = NetFtBalance(
        "127.0.0.1", calibration_matrix_si=MATRIX_SI, rdt_rate_hz=1000.0, name="test Net F/T"
    )
    with pytest.raises(UserInputError, match=r"3500 records/s: the device streams at its RDT"):
        balance.check_sample_rate(3500.0)
    with pytest.raises(UserInputError, match=r"3000 records/s is not an RDT output rate"):
        balance.check_sample_rate(3000.0)
    balance.check_sample_rate(1000.0)
