"""A headless sweep from a Python script: the same API `ornitail sweep` uses.

Run it on the simulated rig (the default) with

    python examples/headless_sweep.py --data-root /tmp/ornitail-example

or point ``--rig`` at your own rig file and ``--plan`` at your plan. It prints progress (from the sweep's run
documents), the runs it wrote and the cycle-averaged X, Z and M of every measured point.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.acquisition.run_documents import Document, DocumentDispatcher, SetPointDocument
from ornitail.acquisition.sweep import run_sweep
from ornitail.acquisition.sweep_plan import SweepPlan, load_plan
from ornitail.balance.sweep_table import cycle_averaged_table
from ornitail.core.errors import UserInputError

STUDY_PLAN = Path(__file__).resolve().parents[1] / "acquisition" / "data" / "study_tunnel_plan.toml"


class ProgressPrinter:
    """A subscriber of the sweep's run documents: one line per recorded set point of ``plan``, with the count of
    set points done."""

    def __init__(self, plan: SweepPlan) -> None:
        self.plan = plan

    def __call__(self, name: str, document: Document) -> None:
        """Print the line of a set point document."""
        if isinstance(document, SetPointDocument) and document.progress is not None:
            point = self.plan.set_points[document.plan_point_index]
            print(
                f"[{document.progress.done}/{document.progress.total}] {point.sweep:12s} "
                f"theta={math.degrees(point.pitch_rad):5.1f} deg V={point.tunnel_velocity_m_s:.3f} m/s "
                f"f={point.flapping_frequency_hz:.2f} Hz"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plan", type=Path, default=STUDY_PLAN)
    parser.add_argument("--rig", type=Path, default=DEFAULT_RIG_FILE)
    parser.add_argument("--data-root", type=Path, required=True)
    parser.add_argument("--time-scale", type=float, default=4.0, help="simulated rigs only")
    arguments = parser.parse_args()

    try:
        plan = load_plan(arguments.plan)
        documents = DocumentDispatcher()
        documents.subscribe(ProgressPrinter(plan))
        with Rig.from_file(arguments.rig, time_scale=arguments.time_scale) as rig:
            result = run_sweep(plan, rig, arguments.data_root, documents=documents)
    except UserInputError as error:  # a mistake in the plan, the rig file or the options
        print(f"headless_sweep: error: {error}", file=sys.stderr)
        sys.exit(2)
    except (
        InstrumentError
    ) as error:  # absent or silent instrument; the rig was made safe on the way out
        print(f"headless_sweep: error: {error}", file=sys.stderr)
        sys.exit(3)
    print(f"sweep {result.status}: {result.message}")
    for directory in result.run_directories:
        print(f"  run {directory}")
    if result.status == "completed":
        table = cycle_averaged_table(result.run_directories)
        print(
            table[
                ["sweep", "tailed", "theta_deg", "v_m_s", "f_set_hz", "x_n", "z_n", "m_n_m"]
            ].to_string()
        )


if __name__ == "__main__":
    main()
