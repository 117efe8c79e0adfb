"""The ORNI-DAQ9 board as auxiliary acquisition beside the CAN or Net F/T balance: the clock model, the rig file and
the aligned stream against the simulators' true sample times (a short sweep on every backend, processed:
test_backend_agreement.py)."""

import math
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from ornitail.acquisition.aligned_balance import AlignedBalance
from ornitail.acquisition.aux_clock_model import CounterClockModel
from ornitail.acquisition.live_balance import LiveBalance
from ornitail.acquisition.netcanoem_balance import volts_per_gauge_count
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE, read_rig_file
from ornitail.core.errors import UserInputError

DATA = DEFAULT_RIG_FILE.parent
CAN_AUX_RIG = DATA / "simulated_rig_can_aux.toml"
NETFT_AUX_RIG = DATA / "simulated_rig_netft_aux.toml"
DEADLINE_S = 60.0


def rig_copy(tmp_path: Path, source: Path, replacements: dict[str, str]) -> Path:
    """``source`` with its data files beside it, after text replacements."""
    shutil.copytree(DATA / "calibration", tmp_path / "calibration", dirs_exist_ok=True)
    shutil.copy(DATA / "tunnel_table.csv", tmp_path / "tunnel_table.csv")
    text = source.read_text()
    for old, new in replacements.items():
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / f"rig-{len(list(tmp_path.glob('rig-*.toml')))}.toml"
    path.write_text(text)
    return path


# -- the clock model ------------------------------------------------------------------------------
def test_clock_model_finds_offset_and_rate_under_one_sided_latency():
    rng = np.random.default_rng(3)
    nominal_hz, true_hz, offset_s = 10_000.0, 10_000.0 * (1 + 80e-6), 12.5
    counters = np.cumsum(rng.integers(40, 60, size=3000)) + 1_000_000  # ~50 samples a block: 15 s
    sampled_s = offset_s + (counters - counters[0]) / true_hz
    latency_s = 0.0002 + rng.exponential(0.003, size=counters.size)  # never negative, 0.2 ms floor
    model = CounterClockModel(nominal_hz)
    for counter, arrival in zip(counters, sampled_s + latency_s, strict=True):
        model.add(int(counter), float(arrival))
    fit = model.fit()
    # The rate comes from per-bin minima over 15 s: 60 bins whose minima scatter by ~0.01 ms (exponential latency,
    # ~12 blocks a bin), so the slope is known to a few ppm; 20 ppm is generous.
    assert fit.rate_error_ppm == pytest.approx(80.0, abs=20.0)
    newest = counters[-200:]
    error_s = fit.time_of(newest) - (offset_s + (newest - counters[0]) / true_hz)
    # What timestamps cannot see is the 0.2 ms floor; the line sits on it within the envelope (~0.15 ms, the 5 %
    # quantile of a 3 ms exponential) plus the rate error over the 5 s offset window (20 ppm x 5 s = 0.1 ms).
    assert np.all(error_s >= 0.0002 - 0.0002)
    assert np.all(error_s <= 0.0002 + fit.envelope_s + 0.0002)
    assert fit.jitter_rms_s == pytest.approx(
        0.003 * math.sqrt(2), rel=0.2
    )  # rms of an exponential: sqrt(2) x mean


def test_clock_model_uses_the_nominal_rate_until_the_span_is_long_enough():
    model = CounterClockModel(1000.0)
    counters = (
        np.arange(20) * 100 + 99
    )  # 2 s of 100-sample blocks: too short for a slope better than the crystal's
    arrivals = 5.0 + counters / 1000.0 * (1 - 300e-6) + 0.001 * (np.arange(20) % 3)
    for counter, arrival in zip(counters, arrivals, strict=True):
        model.add(int(counter), float(arrival))
    fit = model.fit()
    assert fit.rate_error_ppm == 0.0
    above = arrivals - fit.time_of(counters)
    assert above.min() == pytest.approx(0.0, abs=1e-12)  # under every arrival, touching the lowest
    assert np.all(above >= -1e-12)


def test_a_rate_beyond_a_crystals_tolerance_is_clipped_to_it_not_reset_to_nominal():
    """Deliveries that lag more and more (a starved reader) tilt the arrivals' floor far beyond any crystal. The fit
    used to fall back to the nominal rate past 1000 ppm, so a tilt near that limit made the line jump by the slope
    over the offset window (6.7 ms) each time the fit crossed it; clipped, both tilts give the same line."""
    from ornitail.acquisition.aux_clock_model import CRYSTAL_TOLERANCE_PPM

    rates = []
    for tilt_ppm in (600.0, 1500.0):
        model = CounterClockModel(1000.0)
        counters = np.arange(1, 301) * 50 - 1  # 15 s of 50-sample blocks: 60 bins
        arrivals = 2.0 + counters / 1000.0 * (1 + tilt_ppm * 1e-6) + 0.0005 * (np.arange(300) % 4)
        for counter, arrival in zip(counters, arrivals, strict=True):
            model.add(int(counter), float(arrival))
        rates.append(model.fit().rate_error_ppm)
    # clipped at the tolerance (a period 200 ppm long reads as -199.96 ppm fast)
    assert rates == pytest.approx([-CRYSTAL_TOLERANCE_PPM] * 2, rel=1e-3)


def test_a_held_line_stays_put_until_released():
    """While a record is taken the line is held: a faster delivery (the line should move 5 ms back) changes
    nothing until the hold is released."""
    model = CounterClockModel(1000.0)
    model.hold()  # before the first arrival there is nothing to hold
    counters = np.arange(1, 21) * 100 - 1
    for counter in counters:
        model.add(int(counter), 3.0 + counter / 1000.0 + 0.006)
    assert model.fit() is not None
    model.hold()
    held = model.fit()
    model.add(2099, 3.0 + 2.099 + 0.001)  # delivered 5 ms faster than any before
    assert model.fit() is held
    assert held.time_of(2099) == pytest.approx(3.0 + 2.099 + 0.006)
    assert model.release() == pytest.approx(-0.005)  # how far it moved while held
    assert model.fit().time_of(2099) == pytest.approx(3.0 + 2.099 + 0.001)
    assert model.release() == 0.0  # nothing held


def test_board_calibration_must_be_the_cal_files():
    cal = np.array([[2.0, 0.5], [0.25, 4.0]])
    assert volts_per_gauge_count(cal * 3.125e-4, cal) == pytest.approx(3.125e-4)
    other = cal * 3.125e-4
    other[1, 1] *= 1.01  # another sensor's matrix: one element 1 % off
    assert volts_per_gauge_count(other, cal) is None


# -- the rig file ---------------------------------------------------------------------------------
def test_packaged_can_aux_rig_file_reads(tmp_path):
    description = read_rig_file(CAN_AUX_RIG)
    assert description.balance_route == "can" and description.aux_daq is not None
    assert description.carries_flap_channels
    assert description.balance_sample_rate_hz() == description.aux_daq.sample_rate_hz


def test_aux_board_beside_the_serial_daq_balance_is_refused(tmp_path):
    path = rig_copy(
        tmp_path, DEFAULT_RIG_FILE, {"[balance.can]": "[balance.aux_daq]\n\n[balance.can]"}
    )
    with pytest.raises(
        UserInputError, match=r"\[balance.aux_daq\]: only beside a CAN or Net F/T balance"
    ):
        read_rig_file(path)


def test_net_ft_route_needs_its_table(tmp_path):
    path = rig_copy(tmp_path, DEFAULT_RIG_FILE, {'route = "serial_daq"': 'route = "netft"'})
    with pytest.raises(
        UserInputError, match=r": \[balance.netft\]: required with route = \"netft\"$"
    ):
        read_rig_file(path)


def test_can_balance_alone_cannot_stream_the_flap_channels(tmp_path):
    path = rig_copy(tmp_path, DEFAULT_RIG_FILE, {'route = "serial_daq"': 'route = "can"'})
    with Rig.from_file(path, time_scale=5.0) as rig:
        assert not rig.description.carries_flap_channels
        with pytest.raises(
            UserInputError, match=r"add the serial board beside the CAN or Net F/T balance"
        ):
            LiveBalance(rig)


# -- the aligned stream on the simulators ---------------------------------------------------------
@pytest.mark.parametrize("source", [CAN_AUX_RIG, NETFT_AUX_RIG], ids=["can", "netft"])
def test_aligned_stream_matches_the_simulated_boards_true_sample_times(tmp_path, source):
    path = rig_copy(tmp_path, source, {})
    with Rig.from_file(path, time_scale=1.0) as rig:
        balance = rig.balance
        assert isinstance(balance, AlignedBalance)
        rig.set_flapping_frequency(12.0)
        rig.start_balance()
        rate_hz = rig.description.balance_sample_rate_hz()
        blocks = []
        deadline = time.monotonic() + DEADLINE_S
        while sum(len(block.counters) for block in blocks) < 3 * rate_hz:  # 3 s of rows
            assert time.monotonic() < deadline, "rows did not arrive"
            block = balance.read_block(timeout_s=0.5)
            if block is not None:
                blocks.append(block)
        values = balance.alignment_values()
        aux_board = rig.simulators.aux_daq_board
        counters = balance._aux_counters
        modelled_s = balance.time_of_aux_counter(counters)
        true_s = aux_board.sample_time_s(counters)
        netft_error_s = None
        if (
            rig.simulators.netft is not None
        ):  # the Net F/T's records are placed by a counter line too
            stride = round(7000 / rig.description.netft.rdt_rate_hz)  # internal samples per record
            newest = balance.balance._last_counter[0] - stride * np.arange(2000)  # 2 s of records
            netft_error_s = balance.balance._model.fit().time_of(
                newest
            ) - rig.simulators.netft.sample_time_s(newest)
        rig.stop_balance()
    rows = np.concatenate([block.counters for block in blocks]).astype(np.int64)
    volts = np.vstack([block.volts for block in blocks])
    assert np.all(np.diff(rows) >= 1) and volts.shape[1] == 9
    assert set(np.unique(volts[:, 8])) <= {0.0, 3.3}  # the Hall line stays a logic level
    assert np.ptp(volts[:, 8]) > 0  # and it toggles: the motor flaps
    error_s = modelled_s - true_s
    # The model's time of a counter is never before the sample was taken (arrivals come after sampling; one
    # auxiliary sample, 0.1 ms, for the simulated board's clock read), and only the transport's floor after it:
    # under 1 ms on a quiet host, several ms when two busy cores starve the reader thread; 20 ms (a quarter flap) is
    # generous, and tiny next to what the model removes (the counter starts 123 s "early", the crystal is 80 ppm fast).
    assert error_s.min() >= -1.0 / 10_000.0
    assert error_s.max() <= 0.020
    if netft_error_s is not None:
        # The same holds for the Net F/T's ft_sequence line (crystal 40 ppm slow): never before the sample (within
        # one 7 kHz internal sample, as the simulator sends a record once its sample time has passed), at most the
        # floor of UDP delivery and the receiver's 10 ms block period after it.
        assert netft_error_s.min() >= -1.0 / 7000.0
        assert netft_error_s.max() <= 0.020
    assert values["aux_clock_points"] > 10 and values["alignment_error_estimate_s"] > 0


def test_both_counter_lines_are_held_while_a_record_is_taken(tmp_path):
    """A record's rows are placed with one line per device: while the alignment is held (as the sweep holds it
    for each record), the Net F/T's and the auxiliary board's lines stay the ones fitted at the hold however many
    blocks arrive; once released they follow the arrivals again (refitted after each block)."""
    path = rig_copy(tmp_path, NETFT_AUX_RIG, {})
    with Rig.from_file(path, time_scale=1.0) as rig:
        balance = rig.balance
        rig.set_flapping_frequency(12.0)
        rig.start_balance()
        live = LiveBalance(rig)
        deadline = time.monotonic() + DEADLINE_S
        while balance.read_block(timeout_s=0.5) is None:  # both devices streaming
            assert time.monotonic() < deadline, "rows did not arrive"
        models = (balance._model, balance.balance._model)
        with live.alignment_held():
            held = [model.fit() for model in models]
            points = [model.points for model in models]
            rows = 0
            while rows < 0.5 * rig.description.balance_sample_rate_hz():  # 0.5 s of rows
                assert time.monotonic() < deadline, "rows did not arrive"
                block = balance.read_block(timeout_s=0.5)
                rows += 0 if block is None else len(block.counters)
            assert all(model.points > count for model, count in zip(models, points, strict=True))
            assert all(model.fit() is line for model, line in zip(models, held, strict=True))
        while balance.read_block(timeout_s=0.5) is None:
            assert time.monotonic() < deadline, "rows did not arrive"
        assert all(model.fit() is not line for model, line in zip(models, held, strict=True))
        # what the hold kept out (the balance's line against the board's) is journalled and widens the estimate
        values = balance.alignment_values()
        moved_s = values["alignment_moved_while_held_s"]
        assert math.isfinite(moved_s)
        assert values["alignment_error_estimate_s"] >= abs(moved_s)
        rig.stop_balance()


def test_a_reader_that_fell_behind_catches_up_in_a_few_calls(tmp_path):
    """A busy host once left the live balance's reader seconds behind the Net F/T, and it never caught up: each call
    took one balance block and re-copied a pile of auxiliary rows that grew with the lag (a livelock). After a 2 s
    backlog (about 200 balance blocks of 10 ms, 1000 records/s), reading must reach the present within a handful of
    calls: every waiting block of both devices is merged per call (up to MAX_BLOCKS_PER_READ). One block per call
    would need about 200 calls; 4 * ceil(200 / 64) + 4 = 20 allows each call to cover less than half of what it can
    while the devices keep streaming."""
    from ornitail.acquisition.aligned_balance import MAX_BLOCKS_PER_READ

    path = rig_copy(tmp_path, NETFT_AUX_RIG, {})
    with Rig.from_file(path, time_scale=1.0) as rig:
        balance = rig.balance
        rig.set_flapping_frequency(12.0)
        rig.start_balance()
        rate_hz = rig.description.balance_sample_rate_hz()
        deadline = time.monotonic() + DEADLINE_S
        while balance.read_block(timeout_s=0.5) is None:  # both devices streaming
            assert time.monotonic() < deadline, "rows did not arrive"
        behind_s = 2.0
        rig.wait_simulated_s(behind_s)  # the reader is starved
        calls_allowed = 4 * math.ceil(behind_s / 0.01 / MAX_BLOCKS_PER_READ) + 4
        lag_s = []
        for _ in range(calls_allowed):
            block = balance.read_block(timeout_s=0.5)
            if block is not None:
                lag_s.append(balance._clock() - (balance._t0 + float(block.counters[-1]) / rate_hz))
                if lag_s[-1] < 0.5:
                    break
        rig.stop_balance()
    # Rows reach the device's data within half a second: the UDP and serial transports' floor plus a block period.
    assert lag_s and lag_s[-1] < 0.5, (
        f"still {lag_s[-1] if lag_s else 'inf'} s behind after {calls_allowed} calls"
    )


@pytest.mark.parametrize(
    ("source", "key"), [(CAN_AUX_RIG, "[balance.can]"), (NETFT_AUX_RIG, "[balance.netft]")]
)
def test_rig_check_shows_the_balance_and_the_aux_board_in_rows_of_their_own(source, key):
    from ornitail.acquisition.rig_check import check_rig

    result = check_rig(source)
    rows = {check.rig_file_key: check for check in result.instruments}
    assert rows[key].status == "ok", rows[key]
    assert rows["[balance.aux_daq].port"].status == "ok"
    assert "ORNI-DAQ9" in rows["[balance.aux_daq].port"].identity


def test_one_board_records_no_alignment():
    """The ORNI-DAQ9 alone (and the CAN balance alone) add nothing to the journal or run.json: one sample clock."""
    from ornitail.acquisition.serial_daq_driver import SerialDaqDriver

    board = SerialDaqDriver("/dev/ttyACM0")
    assert board.alignment_values() == {} and board.recording_description() == {}
    assert board.carries_flap_channels
