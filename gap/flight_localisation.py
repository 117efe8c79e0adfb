"""Where the flight gap lies: channel, frequency band, time segment, steady state, configuration.

Works on the baseline's residuals (measured minus simulated outputs) of every run, normalised per
channel by ``scales`` (the measured standard deviation). Channels are the model's outputs.
Segments: the run-in before the input (steady flight), the input (the exciting input above 10 %
of its peak deviation), and the free response after it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.stats import linregress

from ornitail.flight.residual_statistics import residual_tests
from ornitail.gap.flight_data import FlightRun, output_units
from ornitail.gap.flight_model import LinearFlightModel
from ornitail.gap.sparse_regression import sparse_terms
from ornitail.gap.spectra import band_shares_and_coherence

INPUT_FRACTION = 0.10
SEGMENTS = ("steady_run_in", "input", "free_response")


def _segment_masks(run: FlightRun) -> dict[str, np.ndarray]:
    deviation = np.abs(run.excitation - run.excitation[0])
    active = deviation >= INPUT_FRACTION * np.max(deviation)
    after_start = run.time_s >= run.input_start_s
    end = run.time_s[active & after_start].max() if np.any(active & after_start) else np.inf
    return {
        "steady_run_in": ~after_start,
        "input": after_start & (run.time_s <= end),
        "free_response": run.time_s > end,
    }


def _by_segment(runs: Sequence[FlightRun], normalised: Sequence[np.ndarray]) -> dict[str, object]:
    energy = dict.fromkeys(SEGMENTS, 0.0)
    samples = dict.fromkeys(SEGMENTS, 0)
    for run, residual in zip(runs, normalised, strict=True):
        for name, mask in _segment_masks(run).items():
            energy[name] += float(np.sum(residual[mask] ** 2))
            samples[name] += int(mask.sum())
    total = sum(energy.values())
    mean_rate = total / max(sum(samples.values()), 1)
    return {
        name: {
            "energy_share": energy[name] / total if total > 0 else 0.0,
            "relative_intensity": (energy[name] / samples[name]) / mean_rate
            if samples[name] and mean_rate > 0
            else 0.0,
            "samples": samples[name],
        }
        for name in SEGMENTS
    }


def _by_configuration(
    runs: Sequence[FlightRun], normalised: Sequence[np.ndarray]
) -> dict[str, object]:
    gap = np.array([np.sqrt(np.mean(residual**2)) for residual in normalised])
    variables = {
        "theta_deg": np.array([math.degrees(run.theta0_rad) for run in runs]),
        "v_m_s": np.array([run.airspeed_m_s for run in runs]),
    }
    result: dict[str, object] = {}
    for name, values in variables.items():
        if len(runs) < 3 or np.ptp(values) <= 1e-12:
            result[name] = {"varies": False}
            continue
        fit = linregress(values, gap)
        result[name] = {
            "varies": True,
            "slope_per_unit": float(fit.slope),
            "correlation": float(fit.rvalue),
            "p_value": float(fit.pvalue),
        }
    for name in ("S", "AR", "b", "x_h"):
        result[name] = {"varies": False}
    return result


def localise_flight(
    runs: Sequence[FlightRun],
    residuals: Sequence[np.ndarray],
    scales: np.ndarray,
    baseline: LinearFlightModel,
) -> dict[str, object]:
    """The ``where`` section of the report (see the module docstring)."""
    channels = baseline.output_names
    units = output_units(channels)
    input_name = baseline.input_names[runs[0].excitation_index]
    normalised = [residual / scales for residual in residuals]
    stacked = np.concatenate(normalised)
    energy = np.sum(stacked**2, axis=0)
    raw = np.concatenate(residuals)
    by_channel = {
        channel: {
            "rms": float(np.sqrt(np.mean(raw[:, index] ** 2))),
            "unit": units[index],
            "rms_normalised": float(np.sqrt(np.mean(stacked[:, index] ** 2))),
            "energy_share": float(energy[index] / energy.sum()),
        }
        for index, channel in enumerate(channels)
    }
    bands = band_shares_and_coherence(
        normalised, [run.excitation for run in runs], runs[0].time_step_s
    )
    for band in bands:
        shares = np.array(band["power_share"])
        band["pooled_share"] = float(np.sum(shares * energy) / energy.sum())
        band["power_share"] = dict(zip(channels, band["power_share"], strict=True))
        band["coherence_with_input"] = dict(
            zip(channels, band["coherence_with_input"], strict=True)
        )
    tests = residual_tests(
        stacked,
        np.concatenate([run.excitation for run in runs])[:, None],
        channels,
        (input_name,),
    )
    where = {
        "by_channel": by_channel,
        "by_band": bands,
        "by_segment": _by_segment(runs, normalised),
        "input_locked_fraction": input_locked_fraction(runs, normalised),
        "by_configuration": _by_configuration(runs, normalised),
        "steady_state": _steady_state(runs, baseline),
        "residual_tests": {
            "bound": tests.bound,
            "max_autocorrelation": tests.max_autocorrelation,
            "white": tests.white,
            "max_input_correlation": {c: tests.max_input_correlation[c] for c in channels},
            "independent_of_input": tests.independent_of_inputs,
        },
    }
    where["summary"] = flight_summary(where, input_name)
    return where


def _steady_state(runs: Sequence[FlightRun], baseline: LinearFlightModel) -> dict | None:
    """The runs' run-in steady state against the model's trim; None when the runs have none
    (segments of a record)."""
    if not all(math.isfinite(run.theta0_rad) for run in runs):
        return None
    data_theta = float(np.mean([run.theta0_rad for run in runs]))
    data_speed = float(np.mean([run.airspeed_m_s for run in runs]))
    return {
        "data_theta_deg": math.degrees(data_theta),
        "model_theta_deg": math.degrees(baseline.theta0_rad),
        "theta_difference_deg": math.degrees(data_theta - baseline.theta0_rad),
        "data_v_m_s": data_speed,
        "model_v_m_s": baseline.airspeed_m_s,
        "v_difference_m_s": data_speed - baseline.airspeed_m_s,
    }


def aligned_on_input(runs: Sequence[FlightRun], arrays: Sequence[np.ndarray]) -> np.ndarray:
    """``arrays`` (one (N_i, channels) array per run) aligned at each run's input start on their
    common span: shape (runs, samples, channels).
    """
    offsets = [int(np.searchsorted(run.time_s, run.input_start_s)) for run in runs]
    before = min(offsets)
    after = min(len(a) - o for a, o in zip(arrays, offsets, strict=True))
    return np.array([a[o - before : o + after] for a, o in zip(arrays, offsets, strict=True)])


def input_locked_fraction(runs: Sequence[FlightRun], normalised: Sequence[np.ndarray]) -> float:
    """Share of the residual energy that repeats from manoeuvre to manoeuvre (aligned on the
    input): (R - 1/M) / (1 - 1/M) with R = |mean residual|^2 / mean |residual|^2 over M runs.

    Noise and disturbances give about 0 (R ~ 1/M); an error the input drives the same way every
    time gives 1. Runs are aligned at their input start on their common span.
    """
    aligned = aligned_on_input(runs, normalised)
    count = len(aligned)
    ratio = np.sum(aligned.mean(axis=0) ** 2) / np.mean(np.sum(aligned**2, axis=(1, 2)))
    return float((ratio - 1.0 / count) / (1.0 - 1.0 / count))


def unlocked_residual_sd(runs: Sequence[FlightRun], residuals: Sequence[np.ndarray]) -> np.ndarray:
    """Per-channel standard deviation (SI units of the channel) of the part of the residual that
    does not repeat from manoeuvre to manoeuvre: gusts, sensor noise, and whatever differs between
    runs. Runs aligned on their input (as :func:`input_locked_fraction`); the spread about the mean
    over M runs is scaled by M / (M - 1). NaN for a channel when fewer than two runs are given.
    """
    if len(runs) < 2:
        return np.full(residuals[0].shape[1], np.nan)
    aligned = aligned_on_input(runs, residuals)
    count = len(aligned)
    spread = aligned - aligned.mean(axis=0)
    return np.sqrt(np.mean(spread**2, axis=(0, 1)) * count / (count - 1))


def flight_summary(where: dict[str, object], input_name: str = "elevator") -> list[str]:
    """Sentences stating, with numbers, where the gap concentrates (``input_name``: the input
    that excites the runs)."""
    channels = where["by_channel"]
    channel = max(channels, key=lambda name: channels[name]["energy_share"])
    bands = where["by_band"]
    band = max(bands, key=lambda item: item["pooled_share"])
    segments = where["by_segment"]
    segment = max(segments, key=lambda name: segments[name]["relative_intensity"])
    steady = where["steady_state"]
    correlations = where["residual_tests"]["max_input_correlation"]
    lines = [
        f"channel: {channel} carries {100 * channels[channel]['energy_share']:.0f} % of the "
        f"normalised residual energy (RMS {channels[channel]['rms']:.3g} "
        f"{channels[channel]['unit']})",
        f"frequency: {band['band_hz'][0]:g}-{band['band_hz'][1]:.3g} Hz holds "
        f"{100 * band['pooled_share']:.0f} % of it; coherence with the {input_name} there "
        f"{np.mean(list(band['coherence_with_input'].values())):.2f} (channel mean)",
        f"time: the {segment.replace('_', ' ')} segment is "
        f"{segments[segment]['relative_intensity']:.1f}x the mean residual intensity "
        f"({100 * segments[segment]['energy_share']:.0f} % of the energy)",
        "steady state: none (the runs are segments of a record)"
        if steady is None
        else f"steady state: data - model theta {steady['theta_difference_deg']:+.2f} deg, "
        f"V {steady['v_difference_m_s']:+.3f} m/s",
        "residual-input correlation (max over lags): "
        + ", ".join(f"{c} {correlations[c].get(input_name, 0.0):.2f}" for c in correlations)
        + f" (99 % bound {where['residual_tests']['bound']:.3f})",
    ]
    return lines


def sparse_pointer(runs: Sequence[FlightRun], baseline: LinearFlightModel) -> dict[str, object]:
    """Sparse regression of each state's equation residual dx/dt - (A x + B u) on features: the
    measured states, the exciting input and its rate, time, q|q| (when a state is named q) and 1."""
    states = baseline.state_names
    input_name = baseline.input_names[runs[0].excitation_index]
    names = [*states, input_name, f"{input_name}_rate", "time"]
    names += ["q_abs_q"] if "q" in states else []
    names.append("one")
    targets, features = [], []
    for run in runs:
        step = run.time_step_s
        rates = np.gradient(run.states, step, axis=0)
        targets.append(rates - run.states @ baseline.a_matrix.T - run.inputs @ baseline.b_matrix.T)
        columns = [run.states, run.excitation, np.gradient(run.excitation, step), run.time_s]
        if "q" in states:
            q = run.states[:, states.index("q")]
            columns.append(q * np.abs(q))
        columns.append(np.ones(len(run.time_s)))
        features.append(np.column_stack(columns))
    target, feature = np.concatenate(targets), np.concatenate(features)
    return {
        f"d{state}_dt": sparse_terms(feature, target[:, index], tuple(names))
        for index, state in enumerate(states)
    }
