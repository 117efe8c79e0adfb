"""Shared by the gap tests: example data written by ``ornitail gap example``, as a user would make it."""

import json

import pytest
from click.testing import CliRunner

from ornitail.app.cli import main


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
