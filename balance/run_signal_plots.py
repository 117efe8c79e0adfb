"""Picture of one recorded run's signals over time (PNG and PDF), in physical units.

Panels, sharing the run's time axis (s, from the first sample counter; lost samples show as jumps):

- forces X, Y, Z (N) and moments L, M, N (N m) in the body frame about the rig's reference point, from the
  run's balance calibration; relative to the run's first wind-off tare when it has one (else the sensor's raw
  zero, said in the panel title). Each trace is the mean per display bin with its min-max band, so the flapping
  amplitude stays visible however long the run;
- flow velocity (m/s): the set tunnel speed of each set point, the speed measured during it (when recorded),
  and the hot-wire velocity when a hot-wire law is given (else the hot-wire bridge voltage, V, in a panel of
  its own);
- flow temperature (degC) from the thermocouple amplifier;
- flapping frequency (Hz): each Hall-line cycle, and the set frequency of each set point;
- pitch (deg): set and measured per set point.

Wind-off tares are shaded grey.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ornitail.acquisition.calibration_copies import CalibrationSources  # noqa: E402
from ornitail.acquisition.recording_layout import SET_POINT_KIND_TARE  # noqa: E402
from ornitail.acquisition.recording_reader import Recording  # noqa: E402
from ornitail.balance.hall_cycles import HallEdgeSettings, rising_edge_times  # noqa: E402
from ornitail.balance.sweep_table import balance_calibration_of  # noqa: E402
from ornitail.calibration.hotwire_laws import HotwireLaw  # noqa: E402
from ornitail.calibration.signal_channels import GAUGE_CHANNELS  # noqa: E402
from ornitail.calibration.thermocouple_amplifier import (  # noqa: E402
    CELSIUS_TO_KELVIN_OFFSET,
    temperature_k_from_amplifier_voltage,
)
from ornitail.core.errors import UserInputError  # noqa: E402

DISPLAY_BINS = 3000
"""Bins per trace: each holds the mean, min and max of its samples."""
FORCE_NAMES = ("X", "Y", "Z")
MOMENT_NAMES = ("L", "M", "N")
HOTWIRE_CHANNEL, THERMOCOUPLE_CHANNEL, HALL_CHANNEL = "hotwire_bridge_v", "thermocouple_v", "hall_v"


@dataclass(frozen=True)
class BinnedTrace:
    """A signal reduced to display bins: time (s) and the mean, min and max per bin (signal units)."""

    time_s: np.ndarray
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray


@dataclass(frozen=True)
class SetPointSpan:
    """One set point on the time axis (s) with its set and measured values (deg, m/s, Hz)."""

    start_s: float
    end_s: float
    is_tare: bool
    pitch_deg: float
    pitch_measured_deg: float
    velocity_m_s: float
    velocity_measured_m_s: float
    frequency_hz: float


@dataclass(frozen=True)
class RunSignals:
    """What the picture draws, in physical units (see the module docstring)."""

    run_id: str
    loads: dict[str, BinnedTrace]
    tare_corrected: bool
    hotwire: BinnedTrace
    hotwire_in_m_s: bool
    temperature_c: BinnedTrace
    cycle_time_s: np.ndarray
    cycle_frequency_hz: np.ndarray
    set_points: list[SetPointSpan]


def binned(time_s: np.ndarray, values: np.ndarray, bins: int = DISPLAY_BINS) -> BinnedTrace:
    """Mean, min and max of ``values`` over ``bins`` consecutive runs of samples (fewer if short)."""
    count = len(values)
    size = max(1, math.ceil(count / bins))
    usable = count // size * size
    shape = (-1, size)
    parts = [values[:usable].reshape(shape)] if usable else []
    times = [time_s[:usable].reshape(shape).mean(axis=1)] if usable else []
    if usable < count:
        parts.append(values[usable:][None, :])
        times.append(np.array([time_s[usable:].mean()]))
    if not parts:
        empty = np.zeros(0)
        return BinnedTrace(empty, empty, empty, empty)
    return BinnedTrace(
        np.concatenate(times),
        np.concatenate([part.mean(axis=1) for part in parts]),
        np.concatenate([part.min(axis=1) for part in parts]),
        np.concatenate([part.max(axis=1) for part in parts]),
    )


def _optional(value: object) -> float:
    return math.nan if value is None else float(value)


def _set_point_spans(recording: Recording, time_s: np.ndarray) -> list[SetPointSpan]:
    spans = []
    for record in recording.set_points:
        extra = record.extra
        spans.append(
            SetPointSpan(
                start_s=float(time_s[record.first_sample_index]),
                end_s=float(time_s[min(record.last_sample_index, len(time_s) - 1)]),
                is_tare=record.kind == SET_POINT_KIND_TARE,
                pitch_deg=math.degrees(record.pitch_rad),
                pitch_measured_deg=math.degrees(_optional(extra.get("pitch_mean_rad"))),
                velocity_m_s=float(record.tunnel_velocity_m_s),
                velocity_measured_m_s=_optional(extra.get("tunnel_velocity_mean_m_s")),
                frequency_hz=float(record.flapping_frequency_hz),
            )
        )
    return spans


def _cycle_frequency(
    hall_v: np.ndarray, time_s: np.ndarray, sample_rate_hz: float
) -> tuple[np.ndarray, np.ndarray]:
    """Time (s) and frequency (Hz) of each cycle between consecutive Hall edges; a cycle spanning a
    stretch of lost samples, or slower than 1 Hz (motor off), is left out."""
    edges = rising_edge_times(hall_v, sample_rate_hz, HallEdgeSettings())
    if len(edges) < 2:
        return np.zeros(0), np.zeros(0)
    edge_rows = np.clip(np.round(edges * sample_rate_hz).astype(int), 0, len(time_s) - 1)
    edge_times = time_s[edge_rows] + (edges - edge_rows / sample_rate_hz)
    period = np.diff(edge_times)
    row_span = np.diff(edges) * sample_rate_hz
    keep = (period < 1.0) & np.isclose(period * sample_rate_hz, row_span, atol=2.0)
    return (edge_times[:-1] + period / 2)[keep], 1.0 / period[keep]


def run_signals(
    recording: Recording,
    calibration_sources: CalibrationSources | None = None,
    hotwire_law: HotwireLaw | None = None,
) -> RunSignals:
    """The run's signals in physical units, binned for display (see the module docstring).

    Raises
    ------
    UserInputError
        If the run holds no samples, lacks a channel the picture needs, or its balance calibration file
        cannot be found (the message names the run and the channel or key).
    """
    frame = (
        recording.samples_frame()
    )  # a missing or unreadable samples file is refused here, naming it
    if frame.empty:
        raise UserInputError(str(recording.run_directory), "the run holds no samples to draw")
    needed = (*GAUGE_CHANNELS, HOTWIRE_CHANNEL, THERMOCOUPLE_CHANNEL, HALL_CHANNEL)
    missing = [name for name in needed if name not in frame.columns]
    if missing:
        raise UserInputError(
            str(recording.run_directory), f"the run has no channel {', '.join(missing)}"
        )
    calibration, _ = balance_calibration_of(recording, calibration_sources)
    time_s = frame["time_s"].to_numpy()
    gauges = frame[list(GAUGE_CHANNELS)].to_numpy(dtype=float)
    tares = [record for record in recording.set_points if record.kind == SET_POINT_KIND_TARE]
    bias = np.zeros(6)
    if tares:
        first = tares[0]
        bias = gauges[first.first_sample_index : first.last_sample_index + 1].mean(axis=0)
    loads = calibration.forces_from_voltages(gauges, bias)
    temperature_k = np.asarray(
        temperature_k_from_amplifier_voltage(frame[THERMOCOUPLE_CHANNEL].to_numpy(dtype=float))
    )
    bridge_v = frame[HOTWIRE_CHANNEL].to_numpy(dtype=float)
    hotwire = (
        bridge_v
        if hotwire_law is None
        else np.asarray(hotwire_law.velocity_from_voltage(bridge_v, temperature_k))
    )
    cycle_time, cycle_frequency = _cycle_frequency(
        frame[HALL_CHANNEL].to_numpy(dtype=float), time_s, recording.sample_rate_hz
    )
    return RunSignals(
        run_id=recording.run_id,
        loads={
            name: binned(time_s, loads[:, index])
            for index, name in enumerate((*FORCE_NAMES, *MOMENT_NAMES))
        },
        tare_corrected=bool(tares),
        hotwire=binned(time_s, hotwire),
        hotwire_in_m_s=hotwire_law is not None,
        temperature_c=binned(time_s, temperature_k - CELSIUS_TO_KELVIN_OFFSET),
        cycle_time_s=cycle_time,
        cycle_frequency_hz=cycle_frequency,
        set_points=_set_point_spans(recording, time_s),
    )


def _with_gaps_broken(trace: BinnedTrace) -> BinnedTrace:
    """The trace with a NaN bin inserted wherever time jumps by more than five typical bin widths (lost or
    unrecorded samples), so no line is drawn across the gap."""
    if len(trace.time_s) < 3:
        return trace
    steps = np.diff(trace.time_s)
    jumps = np.flatnonzero(steps > 5.0 * np.median(steps)) + 1
    if not len(jumps):
        return trace
    time_s = np.insert(trace.time_s, jumps, trace.time_s[jumps - 1] + steps[jumps - 1] / 2)
    return BinnedTrace(
        time_s,
        *(np.insert(values, jumps, np.nan) for values in (trace.mean, trace.low, trace.high)),
    )


def _trace(axis: plt.Axes, trace: BinnedTrace, label: str, colour: str | None = None) -> None:
    trace = _with_gaps_broken(trace)
    (line,) = axis.plot(trace.time_s, trace.mean, linewidth=0.9, label=label, color=colour)
    axis.fill_between(trace.time_s, trace.low, trace.high, color=line.get_color(), alpha=0.25)


def _steps(
    axis: plt.Axes, spans: list[SetPointSpan], field: str, label: str, style: str = "-"
) -> None:
    first = True
    for span in spans:
        value = getattr(span, field)
        if not math.isfinite(value):
            continue
        axis.plot(
            [span.start_s, span.end_s],
            [value, value],
            style,
            color="black",
            linewidth=1.6,
            label=label if first else None,
        )
        first = False


def run_signals_figure(signals: RunSignals) -> plt.Figure:
    """The run's signals, one panel per quantity with its unit (see the module docstring)."""
    hotwire_panel = 0 if signals.hotwire_in_m_s else 1
    count = 6 + hotwire_panel
    figure, axes = plt.subplots(count, 1, figsize=(12, 2.0 * count + 0.8), sharex=True)
    force_axis, moment_axis, velocity_axis = axes[0], axes[1], axes[2]
    for name in FORCE_NAMES:
        _trace(force_axis, signals.loads[name], name)
    for name in MOMENT_NAMES:
        _trace(moment_axis, signals.loads[name], name)
    force_axis.set_ylabel("force (N)")
    moment_axis.set_ylabel("moment (N m)")
    zero = "relative to the run's first wind-off tare" if signals.tare_corrected else "raw zero"
    force_axis.set_title(
        f"body-frame loads ({zero}); band: min-max per bin", fontsize=8, loc="left"
    )
    _steps(velocity_axis, signals.set_points, "velocity_m_s", "set tunnel speed")
    _steps(velocity_axis, signals.set_points, "velocity_measured_m_s", "measured speed", "--")
    if signals.hotwire_in_m_s:
        _trace(velocity_axis, signals.hotwire, "hot-wire velocity", "tab:green")
    else:
        bridge_axis = axes[3]
        _trace(bridge_axis, signals.hotwire, "hot-wire bridge", "tab:green")
        bridge_axis.set_ylabel("hot-wire bridge (V)")
        bridge_axis.set_title(
            "hot-wire bridge voltage (no hot-wire law given)", fontsize=8, loc="left"
        )
    velocity_axis.set_ylabel("flow velocity (m/s)")
    temperature_axis, frequency_axis, pitch_axis = axes[3 + hotwire_panel :]
    _trace(temperature_axis, signals.temperature_c, "thermocouple", "tab:red")
    temperature_axis.set_ylabel("flow temperature (degC)")
    frequency_axis.plot(
        signals.cycle_time_s,
        signals.cycle_frequency_hz,
        ".",
        markersize=2,
        color="tab:purple",
        label="Hall line, per cycle",
    )
    _steps(frequency_axis, signals.set_points, "frequency_hz", "set frequency")
    frequency_axis.set_ylabel("flapping frequency (Hz)")
    _steps(pitch_axis, signals.set_points, "pitch_deg", "set pitch")
    _steps(pitch_axis, signals.set_points, "pitch_measured_deg", "measured pitch", "--")
    pitch_axis.set_ylabel("pitch theta (deg)")
    pitch_axis.set_xlabel("time from the run's first sample (s)")
    for axis in axes:
        for span in signals.set_points:
            if span.is_tare:
                axis.axvspan(span.start_s, span.end_s, color="0.85", zorder=0)
        axis.grid(True, alpha=0.3)
        if axis.get_legend_handles_labels()[0]:
            axis.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.005, 1.0), frameon=False)
    figure.suptitle(
        f"run {signals.run_id}: recorded signals ({len(signals.set_points)} set points; "
        "grey: wind-off tares)",
        fontsize=10,
    )
    figure.tight_layout()
    return figure


def write_run_signals_picture(signals: RunSignals, directory: Path) -> list[Path]:
    """Write ``signals_<run id>.png`` and ``.pdf`` into ``directory``; return their paths."""
    figure = run_signals_figure(signals)
    paths = [directory / f"signals_{signals.run_id}.{suffix}" for suffix in ("png", "pdf")]
    for path in paths:
        figure.savefig(path, dpi=110)
    plt.close(figure)
    return paths
