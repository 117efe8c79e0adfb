"""Benchmark: ``ornitail process`` on a short sweep, its figures saved at their own size against a tight bounding box.

Processing saves three figures, each as PNG and PDF (``balance/processing_plots.save_figure``). Every figure lays
itself out (``tight_layout`` with room for its legend), so it is saved at its own size; the baseline, measured in
the same process on the same recording, saves them as processing did before, with ``bbox_inches="tight"``, which
draws each file twice to find its box. A short sweep (steady state tailed and tailless, one pitch, one velocity,
one frequency point; 2 kHz) is recorded once on the simulated rig; both variants process it ``--repeats`` times,
alternating, and the medians are compared. Printed: both medians and their ratio (one JSON object with ``--json``).

Usage::

    .venv/bin/python benchmarks/processing_figures.py
    .venv/bin/python benchmarks/processing_figures.py --repeats 5 --json

Exit code 0 when saving at the figures' own size is faster than the baseline, 1 otherwise, 2 for a bad option.
"""

from __future__ import annotations

import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import matplotlib.pyplot as plt
from benchmark_timing import alternating_medians_s, repeats_and_json_options
from matplotlib.figure import Figure

from ornitail.acquisition.rig import Rig
from ornitail.acquisition.sweep import run_sweep_to_completion
from ornitail.acquisition.sweep_plan import plan_from_document
from ornitail.app.cli_output import emit
from ornitail.balance import process_runs as process_module

PLAN = {
    "plan": {"name": "processing-figures"},
    "configuration": {"tail_id": "S3", "x_h_mm": 98},
    "steady_state": {"theta_deg": 25.0, "v_m_s": 0.8, "f_hz": 13.5},
    "sweeps": {"theta_deg": [3.0], "v_m_s": [0.2], "f_hz": [1.0]},
    "protocol": {
        "steady_state_repeats": 1,
        "record_s": 0.6,
        "tailless_points": "steady_state",
        "sample_rate_hz": 2000.0,
    },
    "settle": {"stable_for_s": 0.3, "timeout_s": 60},
}
TIME_SCALE = 10.0
"""Rig seconds per wall second while recording (2 kHz x 10: 20 k frames/s on the pty)."""


def save_with_tight_box(figure: Figure, path_without_suffix: Path) -> list[Path]:
    """The baseline: PNG (150 dpi) and PDF with ``bbox_inches="tight"``, as processing saved them before."""
    paths = [path_without_suffix.with_suffix(".png"), path_without_suffix.with_suffix(".pdf")]
    for path in paths:
        figure.savefig(path, dpi=150, bbox_inches="tight")
    plt.close(figure)
    return paths


@contextmanager
def tight_box_saving() -> Iterator[None]:
    """Processing as it saved its figures before (the baseline)."""
    saved = process_module.save_figure
    process_module.save_figure = save_with_tight_box
    try:
        yield
    finally:
        process_module.save_figure = saved


def main(argv: list[str] | None = None) -> int:
    arguments = repeats_and_json_options("processing_figures", __doc__.splitlines()[0], argv)
    if arguments is None:
        return 2
    with tempfile.TemporaryDirectory(prefix="processing-figures-data-") as data:
        with Rig.from_file(time_scale=TIME_SCALE) as rig:
            result = run_sweep_to_completion(plan_from_document(PLAN, "plan.toml"), rig, Path(data))
        if result.status != "completed":
            print(f"processing_figures: the sweep ended {result.status}", file=sys.stderr)
            return 1
        runs = list(result.run_directories)

        def process() -> None:
            with tempfile.TemporaryDirectory(prefix="processing-figures-") as out:
                process_module.process_runs(runs, Path(out))

        process()  # imports and font caches warm
        own_size_s, tight_box_s = alternating_medians_s(
            process, tight_box_saving, arguments.repeats
        )
    record = {
        "repeats": arguments.repeats,
        "processing_own_size_s": own_size_s,
        "processing_tight_box_s": tight_box_s,
        "tight_box_over_own_size": tight_box_s / own_size_s,
    }
    emit(
        record,
        arguments.json,
        lambda r: (
            f"processing a short sweep: {r['processing_own_size_s']:.2f} s with figures at their own size, "
            f"{r['processing_tight_box_s']:.2f} s with a tight bounding box (baseline): "
            f"{r['tight_box_over_own_size']:.2f}x"
        ),
    )
    return 0 if own_size_s < tight_box_s else 1


if __name__ == "__main__":
    sys.exit(main())
