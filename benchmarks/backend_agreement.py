"""Benchmark: one study plan on each balance backend, processed, and the processed tables compared.

The three packaged simulated rigs measure the same simulated vehicle (same seed, same shared tunnel signals) through
three balance backends, each with its real driver on a real transport:

- ``serial_daq``: the ORNI-DAQ9 alone (``simulated_rig.toml``, a pty);
- ``can_aux``: the ATI NETCANOEM polled on python-can's virtual bus, with the ORNI-DAQ9 beside it as auxiliary board
  (``simulated_rig_can_aux.toml``);
- ``netft_aux``: the ATI Net F/T streaming RDT over UDP on the loopback, with the auxiliary board
  (``simulated_rig_netft_aux.toml``).

Each sweep is processed as ``ornitail process`` does (:func:`ornitail.balance.process_runs.process_runs`). The
script prints the processed tail contribution (tailed minus tailless at each point measured both ways) and the
stability derivatives of each backend with their sigmas, and the pairwise z = (a - b) / sqrt(sigma_a^2 + sigma_b^2)
of every quantity. ``tests/acquisition/test_backend_agreement.py`` runs a short plan through the same functions.

A backend whose sweep does not complete, or whose recordings cannot be processed, is named with the reason and left
out of the comparison. Usage: ``benchmarks/README.md``. Exit code 0 when every backend was compared and every
|z| <= ``--max-z``, 1 otherwise, 2 for a bad option.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import shutil
import sys
import time
from pathlib import Path
from typing import Any

from ornitail.acquisition import set_point_recording
from ornitail.acquisition.instrument_errors import InstrumentError
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.acquisition.sweep import run_sweep, run_sweep_to_completion
from ornitail.acquisition.sweep_plan import SweepPlan, load_plan
from ornitail.balance.point_loads import BODY_LOAD_NAMES
from ornitail.balance.process_runs import process_runs
from ornitail.core.errors import UserInputError

DATA = DEFAULT_RIG_FILE.parent
STUDY_PLAN = DATA / "study_tunnel_plan.toml"
BACKEND_RIG_FILES = {
    "serial_daq": DEFAULT_RIG_FILE,
    "can_aux": DATA / "simulated_rig_can_aux.toml",
    "netft_aux": DATA / "simulated_rig_netft_aux.toml",
}
"""Backend label -> its packaged simulated rig file."""

LIGHT_RATES = {
    "serial_daq": {},
    "can_aux": {"sample_rate_hz = 500.0": "sample_rate_hz = 250.0", "10000.0": "5000.0"},
    "netft_aux": {"rdt_rate_hz = 1000.0": "rdt_rate_hz = 500.0", "10000.0": "5000.0"},
}
"""Rig file replacements of ``--light``: the balances beside the auxiliary board at half their packaged rates and
the board at 5 kHz (the rows stay at the plan's rate); what a busy host keeps whole."""

Quantities = dict[str, tuple[float, float]]
"""Quantity name -> (value, sigma), SI units."""


def rig_copy(source: Path, folder: Path, replacements: dict[str, str] | None = None) -> Path:
    """``source`` written into ``folder`` with the data files it names, after exact text replacements (each must
    occur in the file)."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copytree(DATA / "calibration", folder / "calibration", dirs_exist_ok=True)
    shutil.copy(DATA / "tunnel_table.csv", folder / "tunnel_table.csv")
    text = source.read_text()
    for old, new in (replacements or {}).items():
        if old not in text:
            raise ValueError(f"{source.name}: {old!r} not found")
        text = text.replace(old, new)
    path = folder / source.name
    path.write_text(text)
    return path


def record_and_process(
    rig_path: Path, plan: SweepPlan, folder: Path, time_scale: float, *, reuse: bool = False
) -> dict[str, Any]:
    """Run ``plan`` on the rig of ``rig_path`` at ``time_scale`` and process the recordings into
    ``folder/processed``; the summary :func:`process_runs` returns. With ``reuse`` and a sweep of the plan already
    in ``folder/data``, that sweep is resumed (only the set points it did not record are recorded).

    Raises
    ------
    RuntimeError
        The sweep did not complete (its message).
    """
    data = folder / "data"
    if reuse and data.exists():
        with Rig.from_file(
            rig_path, time_scale=time_scale
        ) as rig:  # what a sweep left to record, if anything
            result = run_sweep(plan, rig, data, resume=True)
    else:
        with Rig.from_file(rig_path, time_scale=time_scale) as rig:
            # resumed where a busy host lost samples through a record's retakes
            result = run_sweep_to_completion(plan, rig, data)
    if result.status != "completed":
        raise RuntimeError(f"{rig_path.name}: sweep {result.status}: {result.message}")
    return process_runs(result.run_directories, folder / "processed")


def processed_quantities(summary: dict[str, Any]) -> Quantities:
    """The tail contribution (each load at each point measured tailed and tailless, N and N m) and the stability
    derivatives of every configuration of a :func:`process_runs` summary, with their sigmas."""
    quantities: Quantities = {}
    for configuration in summary["configurations"]:
        for row in configuration.get("tail_contribution", []):
            where = f"theta {row['theta_deg']:g} V {row['v_m_s']:g} f {row['f_set_hz']:g}"
            for load in BODY_LOAD_NAMES:
                quantities[f"tail {load} @ {where}"] = (
                    float(row[load]),
                    float(row[f"{load}_sigma"]),
                )
        derivatives = configuration.get("derivatives", {}).get("derivatives", {})
        for name, entry in derivatives.items():
            quantities[f"derivative {name} [{entry['unit']}]"] = (
                float(entry["value"]),
                float(entry["sigma"]),
            )
    return quantities


def pairwise_z(by_backend: dict[str, Quantities]) -> list[dict[str, Any]]:
    """For every quantity all backends have and every pair of backends: z = (a - b) / sqrt(sa^2 + sb^2) (None
    when both sigmas are 0)."""
    names = set.intersection(*(set(values) for values in by_backend.values()))
    rows = []
    for name in sorted(names):
        for first, second in itertools.combinations(sorted(by_backend), 2):
            (a, sigma_a), (b, sigma_b) = by_backend[first][name], by_backend[second][name]
            combined = math.hypot(sigma_a, sigma_b)
            z = (a - b) / combined if combined > 0 else None
            rows.append({"quantity": name, "pair": f"{first}-{second}", "z": z})
    return rows


def render(by_backend: dict[str, Quantities], rows: list[dict[str, Any]]) -> str:
    """The quantities side by side (value +- sigma) with the pairwise z."""
    backends = sorted(by_backend)
    pairs = sorted({row["pair"] for row in rows})
    z_of = {(row["quantity"], row["pair"]): row["z"] for row in rows}
    lines = [
        "quantity | "
        + " | ".join(f"{b} (value +- sigma)" for b in backends)
        + " | "
        + " | ".join(f"z {p}" for p in pairs)
    ]
    for name in sorted({row["quantity"] for row in rows}):
        values = " | ".join(
            f"{by_backend[b][name][0]:+.4g} +- {by_backend[b][name][1]:.2g}" for b in backends
        )
        zs = " | ".join(
            "n/a" if z_of[(name, p)] is None else f"{z_of[(name, p)]:+.2f}" for p in pairs
        )
        lines.append(f"{name} | {values} | {zs}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plan", type=Path, default=STUDY_PLAN, help="sweep plan (TOML)")
    parser.add_argument("--time-scale", type=float, default=2.0, help="simulated s per wall s")
    parser.add_argument("--out", type=Path, required=True, help="folder for rigs, data, tables")
    parser.add_argument("--max-z", type=float, default=3.0, help="largest |z| accepted")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead")
    parser.add_argument(
        "--light",
        action="store_true",
        help="CAN polled 250/s, Net F/T at 500 records/s, auxiliary boards at 5 kHz (a busy host)",
    )
    parser.add_argument(
        "--max-retakes", type=int, default=None, help="retakes of a lossy record (default 3)"
    )
    parser.add_argument(
        "--reuse", action="store_true", help="resume a sweep already recorded in --out"
    )
    options = parser.parse_args(argv)
    if not options.time_scale > 0:
        parser.error("--time-scale must be > 0")
    if options.max_retakes is not None:
        if options.max_retakes < 0:
            parser.error("--max-retakes must be >= 0")
        set_point_recording.MAX_RETAKES = options.max_retakes
    plan = load_plan(options.plan)
    by_backend: dict[str, Quantities] = {}
    wall_s: dict[str, float] = {}
    failed: dict[str, str] = {}
    for label, source in BACKEND_RIG_FILES.items():
        folder = options.out / label
        started = time.monotonic()
        rig_path = rig_copy(source, folder, LIGHT_RATES[label] if options.light else None)
        try:
            summary = record_and_process(
                rig_path, plan, folder, options.time_scale, reuse=options.reuse
            )
        except (RuntimeError, UserInputError, InstrumentError) as error:  # the others still run
            failed[label] = str(error)
            print(f"{label}: {error}", file=sys.stderr)
            continue
        wall_s[label] = time.monotonic() - started
        by_backend[label] = processed_quantities(summary)
        print(f"{label}: recorded and processed in {wall_s[label]:.0f} s", file=sys.stderr)
    rows = pairwise_z(by_backend) if len(by_backend) >= 2 else []
    worst = max((abs(row["z"]) for row in rows if row["z"] is not None), default=0.0)
    if options.json:
        print(
            json.dumps(
                {"quantities": by_backend, "pairwise_z": rows, "wall_s": wall_s, "failed": failed}
            )
        )
    else:
        print(render(by_backend, rows))
        print(f"largest |z| {worst:.2f} over {len(rows)} comparisons (accepted: {options.max_z:g})")
        for label, problem in failed.items():
            print(f"{label}: not compared: {problem}")
    return 0 if worst <= options.max_z and not failed else 1


if __name__ == "__main__":
    sys.exit(main())
