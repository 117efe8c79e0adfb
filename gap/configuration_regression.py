"""Where a per-row residual concentrates: share per channel and regression on configuration variables.

Rows are tunnel set points or flown configurations, each with one residual per channel. Shared by
the tunnel and steady-state diagnoses; the JSON shapes are those of docs/gap-diagnosis.md
(``by_channel``; ``by_configuration`` with ``per_load`` {channel: slope, correlation, p-value}).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy.stats import linregress

from ornitail.vehicle.geometry import study_tails


def geometry_variables(tail_ids: Sequence[str], x_h_m: np.ndarray) -> pd.DataFrame:
    """Columns S (m^2), AR, b (m), x_h (m) of every row's study tail and position."""
    tails = study_tails()
    geometry = {name: tails[name].geometry for name in set(tail_ids)}
    return pd.DataFrame(
        {
            "S": [geometry[t].area_m2 for t in tail_ids],
            "AR": [geometry[t].aspect_ratio for t in tail_ids],
            "b": [geometry[t].span_m for t in tail_ids],
            "x_h": np.asarray(x_h_m, float),
        }
    )


def channel_shares(
    residual: np.ndarray, scales: np.ndarray, channels: Sequence[str], units: Sequence[str]
) -> dict[str, dict[str, object]]:
    """RMS (SI), normalised RMS and share of the normalised residual energy per channel."""
    normalised = residual / scales
    energy = np.sum(normalised**2, axis=0)
    return {
        channel: {
            "rms": float(np.sqrt(np.mean(residual[:, i] ** 2))),
            "unit": units[i],
            "rms_normalised": float(np.sqrt(np.mean(normalised[:, i] ** 2))),
            "energy_share": float(energy[i] / energy.sum()),
        }
        for i, channel in enumerate(channels)
    }


def configuration_regressions(
    variables: pd.DataFrame, normalised: np.ndarray, channels: Sequence[str]
) -> dict[str, dict[str, object]]:
    """Per variable: whether it varies and, if so, a regression of each channel's residual on it."""
    result: dict[str, dict[str, object]] = {}
    for name in variables.columns:
        values = variables[name].to_numpy(float)
        if not np.all(np.isfinite(values)) or np.ptp(values) <= 1e-12 or len(values) < 3:
            result[name] = {"varies": False}
            continue
        per_channel = {}
        for i, channel in enumerate(channels):
            fit = linregress(values, normalised[:, i])
            per_channel[channel] = {
                "slope_per_unit": float(fit.slope),
                "correlation": float(fit.rvalue),
                "p_value": float(fit.pvalue),
            }
        result[name] = {"varies": True, "per_load": per_channel}
    return result


def localisation_sentences(
    by_channel: dict[str, dict[str, object]],
    by_configuration: dict[str, dict[str, object]],
) -> list[str]:
    """The summary sentences: the channel with most energy, the closest configuration variable."""
    channel = max(by_channel, key=lambda name: by_channel[name]["energy_share"])
    item = by_channel[channel]
    sentences = [
        f"channel: {channel} carries {100 * item['energy_share']:.0f} % of the normalised "
        f"residual energy (RMS {item['rms']:.3g} {item['unit']})"
    ]
    strongest = max(
        (
            (abs(fit["correlation"]), name, target)
            for name, entry in by_configuration.items()
            if entry["varies"]
            for target, fit in entry["per_load"].items()
        ),
        default=None,
    )
    if strongest is not None:
        _, name, target = strongest
        fit = by_configuration[name]["per_load"][target]
        sentences.append(
            f"configuration: the {target} residual follows {name} most closely "
            f"(correlation {fit['correlation']:+.2f}, p = {fit['p_value']:.2g})"
        )
    return sentences
