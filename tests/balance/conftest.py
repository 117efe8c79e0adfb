"""Sweeps processed straight from the simulator's signals (no real-time rig), and the simulator's own truth: the
:class:`SimulatedSweep` of ``benchmarks/tunnel_coverage.py`` (one home for both)."""

import pytest
import tunnel_coverage

simulated_sweep = tunnel_coverage.simulated_sweep


@pytest.fixture
def make_simulated_sweep():
    """The :func:`simulated_sweep` factory."""
    return simulated_sweep


@pytest.fixture
def sweep_z_scores():
    """``sweep_z_scores(sweep, seed, settle_s)`` of the benchmark: {quantity: (value - truth) / sigma}."""
    return tunnel_coverage.sweep_z_scores
