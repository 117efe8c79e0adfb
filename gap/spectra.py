"""Residual spectra and coherence with the input, averaged over runs of equal sample rate.

Each run's residual (mean removed) and input are zero-padded to a common FFT length; power and
cross spectra are summed over runs (Welch's averaging with one segment per run). Coherence is
|sum S_ru|^2 / (sum S_rr sum S_uu): 0 for a residual unrelated to the
input, 1 for one the input explains linearly; coherence is computed per bin (sums over runs)
and averaged over a band weighted by the residual power in each bin.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

FREQUENCY_BANDS_HZ = ((0.0, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, 5.0), (5.0, np.inf))


def _spectra(signals: Sequence[np.ndarray], length: int) -> np.ndarray:
    return np.array(
        [np.fft.rfft(signal - signal.mean(axis=0), n=length, axis=0) for signal in signals]
    )


def fft_length(signals: Sequence[np.ndarray]) -> int:
    return int(2 ** np.ceil(np.log2(max(len(signal) for signal in signals))))


def residual_power(
    residuals: Sequence[np.ndarray], time_step_s: float, length: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and summed residual power per channel, shape (F, channels)."""
    length = length or fft_length(residuals)
    spectra = _spectra(residuals, length)
    return np.fft.rfftfreq(length, time_step_s), np.sum(np.abs(spectra) ** 2, axis=0)


def band_shares_and_coherence(
    residuals: Sequence[np.ndarray], inputs: Sequence[np.ndarray], time_step_s: float
) -> list[dict[str, object]]:
    """Per band: share of each channel's residual power and its coherence with the input."""
    length = fft_length(residuals)
    frequencies = np.fft.rfftfreq(length, time_step_s)
    residual_spectra = _spectra(residuals, length)  # (runs, F, channels)
    input_spectra = _spectra([u.reshape(-1, 1) for u in inputs], length)[:, :, 0]
    power = np.sum(np.abs(residual_spectra) ** 2, axis=0)
    input_power = np.sum(np.abs(input_spectra) ** 2, axis=0)
    cross = np.sum(residual_spectra * np.conj(input_spectra)[:, :, None], axis=0)
    total = power.sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        coherence = np.nan_to_num(np.abs(cross) ** 2 / (power * input_power[:, None]))
    bands = []
    for low, high in FREQUENCY_BANDS_HZ:
        inside = (frequencies >= low) & (frequencies < high)
        if not inside.any():
            continue
        band_power = power[inside].sum(axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            band_coherence = np.sum(coherence[inside] * power[inside], axis=0) / band_power
        bands.append(
            {
                "band_hz": [low, high if np.isfinite(high) else float(frequencies[-1])],
                "power_share": (band_power / total).tolist(),
                "coherence_with_input": np.nan_to_num(band_coherence).tolist(),
            }
        )
    return bands
