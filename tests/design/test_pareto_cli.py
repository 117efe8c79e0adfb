"""`ornitail design pareto`: the area-damping front on the study's tables is monotonic and its points are optimal."""

import json

import numpy as np
from click.testing import CliRunner

from ornitail.app.cli import main


def test_area_damping_front_rises_and_each_point_meets_its_damping_floor(tmp_path):
    result = CliRunner().invoke(
        main,
        [
            "design",
            "pareto",
            "--kind",
            "area-damping",
            "--points",
            "4",
            "--x-h-mm",
            "98",
            "--out",
            str(tmp_path),
            "--json",
        ],
    )
    assert result.exit_code == 0, result.output
    front = json.loads(result.output.strip().splitlines()[-1])
    areas = np.array([point["s_cm2"] for point in front["points"]])
    damping = np.array([point["damping_ratio"] for point in front["points"]])
    epsilons = np.array([point["epsilon"] for point in front["points"]])
    # Each point is the smallest tail whose damping is at least epsilon: the floor holds (solver tolerance) ...
    assert np.all(damping >= epsilons - 1e-6)
    # ... and a higher floor costs area: strictly increasing along the front.
    assert np.all(np.diff(epsilons) > 0) and np.all(np.diff(areas) > 0)
    assert (tmp_path / "pareto.csv").stat().st_size > 0 and (
        tmp_path / "pareto.png"
    ).stat().st_size > 0
