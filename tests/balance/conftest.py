"""Sweeps processed straight from the simulator's signals (no real-time rig), and the simulator's own truth: the
:class:`SimulatedSweep` of ``benchmarks/tunnel_coverage.py`` (one home for both)."""

import importlib.util
import sys
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "tunnel_coverage.py"
_SPEC = importlib.util.spec_from_file_location("ornitail_tunnel_coverage", _PATH)
tunnel_coverage = importlib.util.module_from_spec(_SPEC)
sys.modules[_SPEC.name] = tunnel_coverage
_SPEC.loader.exec_module(tunnel_coverage)
simulated_sweep = tunnel_coverage.simulated_sweep


@pytest.fixture
def make_simulated_sweep():
    """The :func:`simulated_sweep` factory."""
    return simulated_sweep
