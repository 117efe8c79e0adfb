"""Paths of the calibration files shipped with ornitail (in ``calibration/data/``)."""

from __future__ import annotations

from pathlib import Path

CALIBRATION_DATA_DIRECTORY = Path(__file__).resolve().parent / "data"
DEFAULT_BALANCE_CALIBRATION_PATH = CALIBRATION_DATA_DIRECTORY / "FT8884.cal"
"""Real ATI Nano17 calibration (FT8884, SI-50-0.5): the simulated rig's balance calibration."""
EXAMPLE_HOTWIRE_POINTS_PATH = CALIBRATION_DATA_DIRECTORY / "example_hotwire_points.csv"
EXAMPLE_TUNNEL_TABLE_PATH = CALIBRATION_DATA_DIRECTORY / "example_tunnel_table.csv"
