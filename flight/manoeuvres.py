"""Cutting free-flight manoeuvres out of a flight log, with the study's pre-processing.

Pipeline (docs/background.md section 4), applied to a whole log before cutting so that the filter has no
edge transients inside a manoeuvre:

1. elevator glitch removal: samples of ``elevator_rad`` that differ by 25 deg or more from the
   steady deflection (the median over the manoeuvre's run-in: the study's |delta_e| >= 25 deg,
   delta_e being the deviation from the steady state; rule ``steady_deviation``, default) or,
   as an option, from the last good sample (rule ``sample_jump``) are dropped and linearly
   interpolated over time;
2. a 4th-order 5 Hz low-pass Butterworth filter run forwards and backwards (zero phase,
   ``scipy.signal.sosfiltfilt``) on the states and the elevator deflection: it keeps the
   time-averaged motion and removes the flapping content (it also rounds the elevator input);
3. manoeuvres: a doublet starts where ``elevator_cmd`` leaves zero; a manoeuvre starts 0.5 s
   before that and ends at the next rudder input (``rudder_cmd`` leaves zero), or at the log's end.

The time column must be a uniform grid up to rounding and jitter (:mod:`sampling`); the
prepared log's ``time_s`` is that grid. Each manoeuvre carries its steady state (means of the
filtered run-in before the input) and its signals as deviations from that steady state, in the
log's column names (SI units, body frame of docs/frames.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.signal import butter, sosfiltfilt

from ornitail.core.errors import UserInputError
from ornitail.flight.sample_interval import refuse_huge_times, refuse_long_sample_interval
from ornitail.flight.sampling import uniform_grid

STATE_COLUMNS = ("q_rad_s", "u_m_s", "w_m_s", "theta_rad")
ELEVATOR_COLUMN = "elevator_rad"
REQUIRED_LOG_COLUMNS = ("time_s", *STATE_COLUMNS, "elevator_cmd", ELEVATOR_COLUMN, "rudder_cmd")
FREQUENCY_COLUMN = "flapping_frequency_hz"  # optional: steady-state flapping frequency

GLITCH_THRESHOLD_RAD = math.radians(25.0)
GLITCH_RULES = ("steady_deviation", "sample_jump")
DEFAULT_GLITCH_RULE = "steady_deviation"
FILTER_CUTOFF_HZ = 5.0
FILTER_ORDER = 4
RUN_IN_S = 0.5
MINIMUM_RESPONSE_S = 2.0  # from input start to manoeuvre end: doublet (0.66 s) plus >= 1 period
_COMMAND_ZERO_TOLERANCE = 1e-6


@dataclass(frozen=True)
class SteadyState:
    """Means over a manoeuvre's run-in: pitch (rad), body velocities and airspeed (m/s), f (Hz)."""

    theta_rad: float
    u_m_s: float
    w_m_s: float
    airspeed_m_s: float
    flapping_frequency_hz: float  # NaN when the log has no flapping-frequency column


@dataclass(frozen=True)
class Manoeuvre:
    """One manoeuvre cut from a log.

    ``deviations`` holds ``time_s`` (from the manoeuvre start, s), the four states and
    ``elevator_rad`` as deviations from ``steady_state`` (SI units), after glitch removal and
    filtering. ``input_start_s`` is the input's time from the manoeuvre start (the run-in, 0.5 s).
    ``glitches_removed`` counts the elevator samples inside the manoeuvre that were interpolated.
    """

    log_name: str
    number: int
    log_start_s: float
    log_end_s: float
    input_start_s: float
    steady_state: SteadyState
    deviations: pd.DataFrame
    glitches_removed: int = 0

    @property
    def label(self) -> str:
        return f"{self.log_name}#{self.number}"

    @property
    def duration_s(self) -> float:
        return float(self.deviations["time_s"].iloc[-1])


Window = tuple[float, float, float]  # (start, input, end) of a manoeuvre, s on the log clock


@dataclass(frozen=True)
class PreparedLog:
    """A flight log after glitch removal and filtering, with its sample rate (Hz) and its
    manoeuvre windows (:func:`find_manoeuvre_windows`). ``time_s`` of ``raw`` and ``filtered``
    is the log's uniform grid (s).
    """

    name: str
    raw: pd.DataFrame
    filtered: pd.DataFrame
    sample_rate_hz: float
    glitch_mask: np.ndarray  # True where the elevator sample was a glitch (interpolated)
    windows: tuple[Window, ...]


def require_log_columns(log: pd.DataFrame, log_name: str) -> None:
    """Refuse a log that lacks a column the campaign needs or holds non-finite values in one."""
    missing = [column for column in REQUIRED_LOG_COLUMNS if column not in log.columns]
    if missing:
        raise UserInputError(
            log_name,
            f"flight log lacks column(s) {', '.join(missing)} "
            f"(needs {', '.join(REQUIRED_LOG_COLUMNS)}; see docs/flight-campaign.md)",
        )
    for column in REQUIRED_LOG_COLUMNS:
        values = pd.to_numeric(log[column], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise UserInputError(
                f"{log_name}: column {column}",
                f"value at row {bad[0] + 1} is not a finite number",
            )


def steady_elevator_rad(
    elevator_rad: np.ndarray, start_indices: np.ndarray, input_indices: np.ndarray
) -> np.ndarray:
    """The steady elevator deflection (rad) each sample is compared with by the study's rule.

    A manoeuvre's steady deflection is the median raw deflection over its run-in (samples from
    ``start_indices[k]`` to before ``input_indices[k]``: those whose filtered mean is the
    manoeuvre's steady state; the median, so that a glitch in the run-in does not move it). It
    holds from the manoeuvre's start to the next manoeuvre's start; samples before the first
    manoeuvre use the first one's. A log without manoeuvres uses its overall median.
    """
    elevator_rad = np.asarray(elevator_rad, dtype=float)
    if len(input_indices) == 0:
        return np.full(elevator_rad.size, float(np.median(elevator_rad)))
    levels = np.array(
        [
            np.median(elevator_rad[start : max(index, start + 1)])
            for start, index in zip(start_indices, input_indices, strict=True)
        ]
    )
    segment = np.searchsorted(start_indices, np.arange(elevator_rad.size), side="right") - 1
    return levels[np.maximum(segment, 0)]


def sample_jump_glitch_mask(
    elevator_rad: np.ndarray, threshold_rad: float = GLITCH_THRESHOLD_RAD
) -> np.ndarray:
    """Rule ``sample_jump``: True for elevator samples (rad) that jump by ``threshold_rad`` or
    more from the last good sample (so a spike of several samples is marked as a whole and the
    sample after it is kept). It also marks a true step of the threshold or more within one
    sample, and every sample after it until the deflection returns.
    """
    elevator_rad = np.asarray(elevator_rad, dtype=float)
    glitch = np.zeros(elevator_rad.size, dtype=bool)
    last_good = elevator_rad[0]
    for index in range(1, elevator_rad.size):
        if abs(elevator_rad[index] - last_good) >= threshold_rad:
            glitch[index] = True
        else:
            last_good = elevator_rad[index]
    return glitch


def steady_deviation_glitch_mask(
    elevator_rad: np.ndarray,
    steady_rad: np.ndarray,
    threshold_rad: float = GLITCH_THRESHOLD_RAD,
) -> np.ndarray:
    """Rule ``steady_deviation`` (the study's): True for elevator samples (rad) that differ by
    ``threshold_rad`` or more from the steady deflection (rad, per sample:
    :func:`steady_elevator_rad`).
    """
    deviation = np.asarray(elevator_rad, dtype=float) - np.asarray(steady_rad, dtype=float)
    return np.abs(deviation) >= threshold_rad


def interpolate_glitches(
    time_s: np.ndarray, elevator_rad: np.ndarray, glitch: np.ndarray, where: str
) -> np.ndarray:
    """The elevator deflection (rad) with the ``glitch`` samples replaced by linear
    interpolation in time (s) between the good ones.
    """
    elevator_rad = np.asarray(elevator_rad, dtype=float)
    if not glitch.any():
        return elevator_rad.copy()
    if glitch.all():
        raise UserInputError(f"{where}: column {ELEVATOR_COLUMN}", "every sample is a glitch")
    time_s = np.asarray(time_s, dtype=float)
    return np.interp(time_s, time_s[~glitch], elevator_rad[~glitch])


def elevator_glitch_mask(
    raw: pd.DataFrame, sample_rate_hz: float, windows: tuple[Window, ...], rule: str
) -> np.ndarray:
    """The glitch mask of a log's ``elevator_rad`` under ``rule`` (one of :data:`GLITCH_RULES`);
    ``windows`` give the manoeuvres whose run-ins define the steady deflection.
    """
    elevator = raw[ELEVATOR_COLUMN].to_numpy(dtype=float)
    if rule == "sample_jump":
        return sample_jump_glitch_mask(elevator)
    if rule != "steady_deviation":
        raise UserInputError("glitch rule", f"{rule!r} is not one of {', '.join(GLITCH_RULES)}")
    time_s = raw["time_s"].to_numpy(dtype=float)
    # half a sample below each time, so that rounding cannot move a boundary by one sample
    half_step_s = 0.5 / sample_rate_hz
    starts = np.searchsorted(time_s, [start - half_step_s for start, _, _ in windows])
    inputs = np.searchsorted(time_s, [input_s - half_step_s for _, input_s, _ in windows])
    return steady_deviation_glitch_mask(elevator, steady_elevator_rad(elevator, starts, inputs))


def lowpass_zero_phase(
    signal: np.ndarray,
    sample_rate_hz: float,
    cutoff_hz: float = FILTER_CUTOFF_HZ,
    order: int = FILTER_ORDER,
) -> np.ndarray:
    """Butterworth low-pass of ``order`` at ``cutoff_hz`` run forwards and backwards (zero phase).

    Works along the first axis; ``signal`` in any unit, sample rate and cutoff in Hz.
    """
    if not 0 < cutoff_hz < sample_rate_hz / 2:
        raise UserInputError(
            "filter cutoff", f"{cutoff_hz:g} Hz must lie below half the sample rate"
        )
    sections = butter(order, cutoff_hz, btype="lowpass", fs=sample_rate_hz, output="sos")
    signal = np.asarray(signal, dtype=float)
    edge_samples = 3 * (2 * len(sections) + 1)  # sosfiltfilt's default padding
    if signal.shape[0] <= edge_samples:
        raise UserInputError(
            "flight log",
            f"{signal.shape[0]} samples are too few to filter (need {edge_samples + 1})",
        )
    return sosfiltfilt(sections, signal, axis=0)


def prepare_log(
    log: pd.DataFrame,
    log_name: str,
    glitch_rule: str = DEFAULT_GLITCH_RULE,
    run_in_s: float = RUN_IN_S,
    first_row: int = 1,
) -> PreparedLog:
    """Check a flight log, put it on its uniform time grid, find its manoeuvre windows, remove
    elevator glitches by ``glitch_rule`` and low-pass the states and the elevator.

    ``first_row`` is the row number of the log's first sample in the user's file (for messages).
    """
    require_log_columns(log, log_name)
    raw = log.reset_index(drop=True).copy()
    refuse_huge_times(raw["time_s"].to_numpy(dtype=float), f"{log_name}: column time_s")
    with np.errstate(over="ignore", invalid="ignore"):  # huge times: refused below, not warned
        grid = uniform_grid(
            raw["time_s"].to_numpy(dtype=float), f"{log_name}: column time_s", first_row
        )
    refuse_long_sample_interval(
        grid.step_s, f"{log_name}: column time_s", "the column time_s must be in seconds"
    )
    time_s = grid.times_s()
    raw["time_s"] = time_s
    rate = grid.rate_hz
    windows = find_manoeuvre_windows(raw, rate, run_in_s)
    glitches = elevator_glitch_mask(raw, rate, windows, glitch_rule)
    elevator = interpolate_glitches(
        time_s, raw[ELEVATOR_COLUMN].to_numpy(float), glitches, log_name
    )
    filtered = raw.copy()
    smoothed_columns = [*STATE_COLUMNS, ELEVATOR_COLUMN]
    if FREQUENCY_COLUMN in raw.columns:
        frequency = raw[FREQUENCY_COLUMN].to_numpy(dtype=float)
        if not np.all(np.isfinite(frequency)):
            raise UserInputError(
                f"{log_name}: column {FREQUENCY_COLUMN}", "holds non-finite values"
            )
        smoothed_columns.append(FREQUENCY_COLUMN)
    stacked = np.column_stack([raw[column].to_numpy(float) for column in smoothed_columns])
    stacked[:, smoothed_columns.index(ELEVATOR_COLUMN)] = elevator
    smoothed = lowpass_zero_phase(stacked, rate)
    for position, column in enumerate(smoothed_columns):
        filtered[column] = smoothed[:, position]
    return PreparedLog(log_name, raw, filtered, rate, glitches, windows)


def _onsets(signal: np.ndarray) -> np.ndarray:
    """Indices where ``signal`` leaves zero (non-zero after a zero sample, or non-zero at start)."""
    active = np.abs(signal) > _COMMAND_ZERO_TOLERANCE
    previous = np.concatenate([[False], active[:-1]])
    return np.flatnonzero(active & ~previous)


def find_manoeuvre_windows(
    log: pd.DataFrame, sample_rate_hz: float, run_in_s: float = RUN_IN_S
) -> tuple[Window, ...]:
    """(start, input, end) times (s, log clock) of every manoeuvre in a uniformly sampled log.

    Each elevator-command onset opens a manoeuvre; onsets before the previous manoeuvre's end
    belong to it (e.g. a doublet whose command passes through zero). A manoeuvre ends at the next
    rudder onset after its input (exclusive), or one sample after the log's last sample.
    """
    time_s = log["time_s"].to_numpy(float)
    elevator_onsets = _onsets(log["elevator_cmd"].to_numpy(float))
    rudder_onsets = _onsets(log["rudder_cmd"].to_numpy(float))
    windows: list[Window] = []
    for onset in elevator_onsets:
        input_s = float(time_s[onset])
        if windows and input_s < windows[-1][2]:
            continue
        later_turns = rudder_onsets[rudder_onsets > onset]
        end_s = (
            float(time_s[later_turns[0]])
            if later_turns.size
            else float(time_s[-1]) + 1.0 / sample_rate_hz
        )
        windows.append((input_s - run_in_s, input_s, end_s))
    return tuple(windows)


def cut_manoeuvre(
    prepared: PreparedLog,
    start_s: float,
    end_s: float,
    number: int = 1,
    run_in_s: float = RUN_IN_S,
    minimum_response_s: float = MINIMUM_RESPONSE_S,
) -> Manoeuvre:
    """Cut the manoeuvre between ``start_s`` and ``end_s`` (log clock, s) and check it.

    The window is ``start_s <= t < end_s``, each bound taken to the nearest sample. Its input is
    the first elevator-command onset inside it; the window must start at steady flight (command
    zero), hold ``run_in_s`` before the input and ``minimum_response_s`` after it. A window that
    breaks this is refused with a :class:`UserInputError` naming the log and the time.
    """
    name = prepared.name
    time_s = prepared.raw["time_s"].to_numpy(float)
    where = f"{name}: manoeuvre at t = {start_s:.2f}-{end_s:.2f} s"
    if not (math.isfinite(start_s) and math.isfinite(end_s)) or end_s <= start_s:
        raise UserInputError(where, "the manoeuvre must end after it starts")
    if start_s < time_s[0] - 0.5 / prepared.sample_rate_hz:
        raise UserInputError(where, f"starts before the log does (log starts at {time_s[0]:.2f} s)")
    if end_s > time_s[-1] + 1.5 / prepared.sample_rate_hz:
        raise UserInputError(where, f"ends after the log does (log ends at {time_s[-1]:.2f} s)")
    half_step_s = 0.5 / prepared.sample_rate_hz  # bounds to the nearest sample of the grid
    inside = (time_s >= start_s - half_step_s) & (time_s < end_s - half_step_s)
    command = prepared.raw["elevator_cmd"].to_numpy(float)
    onsets = [index for index in _onsets(command) if inside[index]]
    if abs(command[inside][0]) > _COMMAND_ZERO_TOLERANCE:
        raise UserInputError(where, "the elevator input is already under way at the start")
    if not onsets:
        raise UserInputError(where, "no elevator input (elevator_cmd never leaves zero) inside")
    input_s = float(time_s[onsets[0]])
    if input_s - start_s < run_in_s - 1e-9:
        raise UserInputError(
            where,
            f"input at t = {input_s:.2f} s leaves {input_s - start_s:.2f} s of run-in "
            f"(need {run_in_s:.2f} s of steady flight before the input)",
        )
    if end_s - input_s < minimum_response_s - 1e-9:
        raise UserInputError(
            where,
            f"input at t = {input_s:.2f} s is too close to the end: {end_s - input_s:.2f} s of "
            f"response (need {minimum_response_s:.2f} s); drop it with time_range_s",
        )
    rows = prepared.filtered.loc[inside].reset_index(drop=True)
    run_in = rows[rows["time_s"] < input_s]
    theta0 = float(run_in["theta_rad"].mean())
    u0 = float(run_in["u_m_s"].mean())
    w0 = float(run_in["w_m_s"].mean())
    frequency = (
        float(run_in[FREQUENCY_COLUMN].mean()) if FREQUENCY_COLUMN in rows.columns else math.nan
    )
    steady = SteadyState(theta0, u0, w0, math.hypot(u0, w0), frequency)
    deviations = pd.DataFrame({"time_s": rows["time_s"].to_numpy(float) - float(start_s)})
    for column in (*STATE_COLUMNS, ELEVATOR_COLUMN):
        deviations[column] = rows[column].to_numpy(float) - float(run_in[column].mean())
    return Manoeuvre(
        log_name=name,
        number=number,
        log_start_s=float(start_s),
        log_end_s=float(end_s),
        input_start_s=float(input_s - start_s),
        steady_state=steady,
        deviations=deviations,
        glitches_removed=int(np.count_nonzero(prepared.glitch_mask[inside])),
    )


def cut_manoeuvres(
    log: pd.DataFrame,
    log_name: str,
    time_range_s: tuple[float, float] | None = None,
    run_in_s: float = RUN_IN_S,
    minimum_response_s: float = MINIMUM_RESPONSE_S,
    glitch_rule: str = DEFAULT_GLITCH_RULE,
) -> list[Manoeuvre]:
    """Prepare a flight log and cut all its manoeuvres (optionally only inside ``time_range_s``).

    Every manoeuvre found must pass :func:`cut_manoeuvre`'s checks; otherwise the log is refused
    with the time of the offending input, so nothing is dropped silently.
    """
    first_row = 1
    if time_range_s is not None:
        require_log_columns(log, log_name)
        first, last = time_range_s
        if not (math.isfinite(first) and math.isfinite(last) and last > first):
            raise UserInputError(f"{log_name}: time_range_s", f"{time_range_s!r} is not a range")
        kept = ((log["time_s"] >= first) & (log["time_s"] <= last)).to_numpy()
        if np.count_nonzero(kept) < 3:
            raise UserInputError(f"{log_name}: time_range_s", "holds fewer than 3 samples")
        first_row = int(np.argmax(kept)) + 1
        log = log[kept]
    prepared = prepare_log(log, log_name, glitch_rule, run_in_s, first_row)
    if not prepared.windows:
        raise UserInputError(log_name, "no elevator input found (elevator_cmd is zero throughout)")
    return [
        cut_manoeuvre(prepared, start, end, number, run_in_s, minimum_response_s)
        for number, (start, _, end) in enumerate(prepared.windows, start=1)
    ]
