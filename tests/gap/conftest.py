"""Shared by the gap tests: example data written by ``ornitail gap example``, as a user would make it."""

import dataclasses
import json

import numpy as np
import pytest
from click.testing import CliRunner

from ornitail.app.cli import main
from ornitail.gap.flight_data import FlightRun
from ornitail.gap.flight_model import simulate_runs


@pytest.fixture(scope="session")
def write_gap_example(tmp_path_factory):
    """``write(kind, effect)`` runs ``ornitail gap example --kind KIND --effect EFFECT --out DIR --json`` in a new
    folder and returns its JSON record (paths of the data and the baseline model)."""

    def write(kind: str, effect: str, *options: str) -> dict:
        folder = tmp_path_factory.mktemp(kind)
        arguments = [
            "gap",
            "example",
            "--kind",
            kind,
            "--effect",
            effect,
            "--out",
            str(folder),
            "--json",
            *options,
        ]
        result = CliRunner().invoke(main, arguments)
        assert result.exit_code == 0, result.output
        return json.loads(result.output)

    return write


@pytest.fixture(scope="session")
def fly_linear_manoeuvres():
    """``fly(truth, count, seed)``: ``count`` 6 s doublet manoeuvres (0.5 s run-in) flown by the
    linear model ``truth`` (states and outputs q, u, w, theta) with white noise of 3 % of each
    channel's response, as measured runs."""
    return _manoeuvres


def _manoeuvres(truth, count: int, seed: int) -> list[FlightRun]:
    """6 s doublet manoeuvres (0.5 s run-in) flown by ``truth`` with white noise of 3 % of each
    channel's response."""
    time_s = np.arange(384) / 64.0
    elevator = 0.1 * (
        ((time_s >= 0.5) & (time_s < 0.83)) * 1.0 - ((time_s >= 0.83) & (time_s < 1.16))
    )
    zeros = np.zeros((384, 4))
    plain = FlightRun("t", time_s, zeros, elevator[:, None], zeros, zeros[0], 0.5)
    (response,) = simulate_runs(truth, [plain])
    noise = 0.03 * response.std(axis=0)
    generator = np.random.default_rng(seed)
    runs = []
    for index in range(count):
        measured = response + noise * generator.standard_normal((384, 4))
        runs.append(
            dataclasses.replace(
                plain, label=f"t#{index}", outputs=measured, states=measured, initial_state=zeros[0]
            )
        )
    return runs
