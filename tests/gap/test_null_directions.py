"""The detection rule's random directions of A and B, and their library-orthogonal variant (the top-set-orthogonal
one: tests/gap/test_flight_model.py)."""

from pathlib import Path

import numpy as np
import pytest

from ornitail.core.errors import UserInputError
from ornitail.gap.detection import random_matrix_directions, stripped_basis
from ornitail.gap.model_spec import (
    FLIGHT_NULL_DIRECTIONS,
    NULL_DIRECTIONS,
    BaselineSpec,
    read_baseline_spec,
    require_flight_only_keys,
    write_baseline_spec,
)
from ornitail.gap.steady_diagnosis import diagnose_steady
from ornitail.gap.tunnel_diagnosis import diagnose_tunnel

# a longitudinal A (q, u, w, theta) and B (elevator) with the kinematic row theta' = q
A = np.array(
    [
        [-2.0, 0.3, -1.1, 0.0],
        [0.1, -0.4, 0.2, -9.81],
        [1.5, -0.6, -3.0, 0.4],
        [1.0, 0.0, 0.0, 0.0],
    ]
)
B = np.array([[-20.0], [0.5], [-3.0], [0.0]])


def relative(step: np.ndarray) -> np.ndarray:
    """A change [dA dB] as a fraction of each dynamic-row entry (the space the directions live in)."""
    joined = np.hstack([A, B])[:3]
    return step[:3][joined != 0] / np.abs(joined[joined != 0])


def test_directions_keep_their_draws_and_lose_their_part_along_the_named_changes():
    inertia = np.zeros((4, 5))
    inertia[0] = -0.01 * np.hstack([A, B])[0]  # a pitch-inertia change scales the q row
    single = np.zeros((4, 5))
    single[2, 2] = 0.03  # one derivative: Z_w
    plain = random_matrix_directions(A, B, 6, seed=7, dynamic_rows=(0, 1, 2))
    stripped = random_matrix_directions(
        A, B, 6, seed=7, dynamic_rows=(0, 1, 2), named_steps=[inertia, single]
    )
    named = np.array([relative(inertia), relative(single)])
    for (a_plain, b_plain), (a_step, b_step) in zip(plain, stripped, strict=True):
        step = np.hstack([a_step, b_step])
        assert not step[3].any()  # the kinematic row stays
        along = named @ relative(step)
        assert along == pytest.approx([0.0, 0.0], abs=1e-12)  # nothing left along either change
        assert np.sqrt(np.mean(relative(step) ** 2)) == pytest.approx(
            1.0
        )  # unit RMS relative change
        # the same draw less its part along the named changes: the plain direction lies in their span with it
        together = np.vstack([named, relative(step), relative(np.hstack([a_plain, b_plain]))])
        assert np.linalg.matrix_rank(together, tol=1e-9) == 3


def test_the_basis_leaves_at_least_one_free_entry():
    size = np.abs(np.hstack([A, B]))
    size[3] = 0.0
    active = int(np.count_nonzero(size))
    every_entry = []
    for index in zip(*np.nonzero(size), strict=True):
        step = np.zeros_like(size)
        step[index] = size[index]
        every_entry.append(step)
    basis = stripped_basis(every_entry, size)
    assert basis.shape == (active, active - 1)
    assert stripped_basis([], size) is None


def test_the_baseline_file_takes_null_directions_and_refuses_other_values(tmp_path):
    spec = BaselineSpec(
        kind="simulator", tail="S3", x_h_mm=98.0, null_directions="library-orthogonal"
    )
    assert read_baseline_spec(write_baseline_spec(spec, tmp_path / "b.toml")).null_directions == (
        "library-orthogonal"
    )
    # without the key the flight diagnosis' default applies, and the file written back leaves it out
    plain = read_baseline_spec(
        write_baseline_spec(BaselineSpec("simulator", "S3", 98.0), tmp_path / "p.toml")
    )
    assert plain.null_directions is None
    assert "null_directions" not in (tmp_path / "p.toml").read_text()
    assert FLIGHT_NULL_DIRECTIONS in NULL_DIRECTIONS
    require_flight_only_keys(plain, "tunnel tables")  # the default is no refusal for tables
    bad = tmp_path / "bad.toml"
    bad.write_text(
        '[baseline]\nkind = "simulator"\ntail = "S3"\nx_h_mm = 98\nnull_directions = "orthogonal"\n'
    )
    with pytest.raises(UserInputError, match=r"bad.toml: \[baseline\].null_directions") as raised:
        read_baseline_spec(bad)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("data", ["tunnel", "steady"])
def test_tables_refuse_the_flight_only_null_directions_in_one_line(tmp_path, data):
    spec = BaselineSpec(
        kind="simulator",
        tail="S3",
        x_h_mm=98.0,
        null_directions="library-orthogonal",
        source=str(tmp_path / "baseline.toml"),
    )
    with pytest.raises(
        UserInputError, match=r"baseline.toml: \[baseline\].null_directions"
    ) as raised:
        if data == "tunnel":
            diagnose_tunnel(spec, [Path("points.csv")], seed=1)
        else:
            diagnose_steady(spec, Path("steady.csv"), seed=1)
    assert "only for flight logs" in str(raised.value) and "\n" not in str(raised.value)
