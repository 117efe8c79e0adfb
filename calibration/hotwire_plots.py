"""Picture of a hot-wire fit (PNG and PDF): the law through the calibration points, and the residuals.

Left: velocity (m/s) against the temperature-corrected bridge voltage E_corr (V), the points and the
fitted law drawn over their voltage range. Right: residual (fitted - measured velocity, m/s) at each
point against its measured velocity (m/s), with the RMS residual as a band.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ornitail.calibration.hotwire_fit import HotwireFit  # noqa: E402
from ornitail.calibration.hotwire_points import HotwireCalibrationPoints  # noqa: E402
from ornitail.calibration.thermocouple_amplifier import CELSIUS_TO_KELVIN_OFFSET  # noqa: E402

CURVE_SAMPLES = 200


def hotwire_fit_figure(fit: HotwireFit, points: HotwireCalibrationPoints) -> plt.Figure:
    """The fitted law through the points (m/s against V) and the residuals in m/s."""
    law = fit.law
    report = fit.report
    corrected = law.corrected_voltage(points.voltage_v, points.temperature_k)
    grid = np.linspace(float(np.min(corrected)), float(np.max(corrected)), CURVE_SAMPLES)
    reference = np.full_like(grid, law.reference_temperature_k)
    curve = law.velocity_from_voltage(grid, reference)
    figure, (law_axis, residual_axis) = plt.subplots(1, 2, figsize=(10, 4))
    law_axis.plot(corrected, report.velocity_m_s, "o", color="0.3", label="calibration points")
    law_axis.plot(grid, curve, color="tab:red", label=f"fitted {law.law_name} law")
    law_axis.set_xlabel(
        f"bridge voltage corrected to {law.reference_temperature_k - CELSIUS_TO_KELVIN_OFFSET:.1f} degC, E_corr (V)"
    )
    law_axis.set_ylabel("flow velocity U (m/s)")
    law_axis.set_title("law through the points", fontsize=9)
    law_axis.grid(True, alpha=0.3)
    law_axis.legend(fontsize=8)
    rms = report.rms_residual_m_s
    residual_axis.axhspan(-rms, rms, color="tab:orange", alpha=0.2, label=f"+-RMS {rms:.4f} m/s")
    residual_axis.axhline(0.0, color="black", linewidth=0.6)
    residual_axis.plot(report.velocity_m_s, report.residual_m_s, "o", color="tab:blue")
    residual_axis.set_xlabel("measured velocity U (m/s)")
    residual_axis.set_ylabel("residual, fitted - measured (m/s)")
    residual_axis.set_title(
        f"residuals: max |residual| {report.max_abs_residual_m_s:.4f} m/s", fontsize=9
    )
    residual_axis.grid(True, alpha=0.3)
    residual_axis.legend(fontsize=8)
    figure.suptitle(
        f"hot-wire calibration: {law.law_name} law, {len(report.velocity_m_s)} points", fontsize=10
    )
    figure.tight_layout()
    return figure


def hotwire_picture_paths(law_path: Path) -> list[Path]:
    """Where the picture of a law written to ``law_path`` goes: ``<stem>_fit.png`` and ``.pdf``
    beside it."""
    base = law_path.with_name(f"{law_path.stem}_fit")
    return [base.with_suffix(".png"), base.with_suffix(".pdf")]


def write_hotwire_fit_picture(
    fit: HotwireFit, points: HotwireCalibrationPoints, law_path: Path
) -> list[Path]:
    """Write :func:`hotwire_fit_figure` beside the law file (:func:`hotwire_picture_paths`)."""
    figure = hotwire_fit_figure(fit, points)
    paths = hotwire_picture_paths(law_path)
    for path in paths:
        figure.savefig(path, dpi=120)
    plt.close(figure)
    return paths
