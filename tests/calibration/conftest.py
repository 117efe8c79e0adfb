"""Shared fixtures of the calibration tests: data paths and a runner on the real root command."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

CALIBRATION_TEST_DATA = Path(__file__).resolve().parents[1] / "data" / "calibration"


@pytest.fixture
def cal_file_path():
    """Return a function giving the path of one of the real ATI files by serial."""
    return lambda serial: CALIBRATION_TEST_DATA / f"{serial}.cal"


@pytest.fixture
def run_ornitail():
    """Run ``ornitail <args>`` in-process through the real root group (errors -> exit 2)."""
    from ornitail.app.cli import main

    def run(*arguments: str):
        return CliRunner().invoke(main, [str(argument) for argument in arguments])

    return run
