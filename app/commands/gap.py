"""``ornitail gap``: diagnose the sim-to-real gap, make example data, run the benchmark."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from ornitail.app.cli_output import emit, json_option
from ornitail.app.progress import Progress
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import prepare_output_directory, prepare_output_file
from ornitail.core.output import to_jsonable

# The diagnosis, example data and benchmark (numpy, scipy, casadi, matplotlib) are imported inside the
# commands: `ornitail gap --help` stays fast.

MAX_SEED = 2**32 - 1
"""Largest seed accepted (seeds are 0..2**32 - 1)."""

gap_group = click.Group("gap", help="Sim-to-real gap: where it lies, which effect, how far.")


@gap_group.command("diagnose")
@click.option(
    "--model",
    "model_path",
    type=click.Path(path_type=Path),
    required=True,
    help="Baseline model file (TOML, docs/gap-diagnosis.md).",
)
@click.option(
    "--data",
    "data_paths",
    type=click.Path(path_type=Path),
    multiple=True,
    required=True,
    help=(
        "Flight log (CSV/Parquet/.mat), tunnel cycle-averages.csv (repeat either), or one "
        "steady-state table (representative_models.csv or tail, x_h_mm, theta_ss_deg, v_ss_m_s)."
    ),
)
@click.option(
    "--seed",
    type=click.IntRange(0, MAX_SEED),
    default=2018,
    show_default=True,
    help="Split and bootstrap seed.",
)
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("gap-diagnosis"),
    show_default=True,
    help="Folder for the report (JSON, text) and pictures.",
)
@click.option("--no-pictures", is_flag=True, help="Write the report only.")
@json_option
def diagnose_command(
    model_path: Path,
    data_paths: tuple[Path, ...],
    seed: int,
    out: Path,
    no_pictures: bool,
    as_json: bool,
) -> None:
    """Diagnose measured data against a baseline model and write the report."""
    prepare_output_directory(out)
    from ornitail.gap.report_files import diagnose_files
    from ornitail.gap.report_text import render_report

    with Progress("gap diagnose", 1, "steps", bar_delay_s=1.0) as bar:
        report = diagnose_files(
            model_path,
            list(data_paths),
            seed,
            out,
            pictures=not no_pictures,
            on_step=lambda done, total, what: bar.update(done, item=what, total=total),
        )
    emit(report, as_json, render_report)


def _parse_effect(text: str) -> tuple[str, float | None]:
    name, _, value = text.partition("=")
    if not value:
        return name, None
    try:
        magnitude = float(value)
    except ValueError:
        raise UserInputError(f"--effect {text}", f"magnitude {value!r} is not a number") from None
    if not math.isfinite(magnitude):
        raise UserInputError(f"--effect {text}", f"magnitude {value!r} is not finite")
    return name, magnitude


@gap_group.command("example")
@click.option(
    "--kind",
    type=click.Choice(["flight", "tunnel", "steady"]),
    default="flight",
    show_default=True,
    help="Free-flight log, tunnel sweep table or steady-state table.",
)
@click.option(
    "--effect",
    "effects",
    multiple=True,
    help="Withheld effect NAME or NAME=MAGNITUDE (repeat; none: data match the model).",
)
@click.option("--tail", default="S3", show_default=True, help="Study tail.")
@click.option("--x-h-mm", type=float, default=98.0, show_default=True, help="Tail position, mm.")
@click.option(
    "--manoeuvres",
    type=click.IntRange(6, 200),  # gap.flight_data.MINIMUM_MANOEUVRES (tests/gap/test_gap_cli.py)
    default=20,
    show_default=True,
    help="Doublet manoeuvres in the flight.",
)
@click.option(
    "--seed",
    type=click.IntRange(0, MAX_SEED),
    default=1,
    show_default=True,
    help="Simulation seed.",
)
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Folder for the data file and the baseline model file.",
)
@json_option
def example_command(
    kind: str,
    effects: tuple[str, ...],
    tail: str,
    x_h_mm: float,
    manoeuvres: int,
    seed: int,
    out: Path,
    as_json: bool,
) -> None:
    """Write example data with withheld effects and the baseline model file that lacks them."""
    from ornitail.gap.example_data import write_example

    parsed = dict(_parse_effect(text) for text in effects)
    result = write_example(kind, parsed, tail, x_h_mm, manoeuvres, seed, out)
    emit(
        result,
        as_json,
        lambda r: (
            f"wrote {r['data']} and {r['model']}\nnext: ornitail gap diagnose --model "
            f"{r['model']} --data {r['data']} --out {Path(r['data']).parent / 'report'}"
        ),
    )


@gap_group.command("benchmark")
@click.option(
    "--cases", type=click.IntRange(1, 10000), default=60, show_default=True, help="Number of cases."
)
@click.option(
    "--seed",
    type=click.IntRange(0, MAX_SEED),
    default=2018,
    show_default=True,
    help="Benchmark seed.",
)
@click.option(
    "--manoeuvres",
    type=click.IntRange(6, 200),  # gap.flight_data.MINIMUM_MANOEUVRES (tests/gap/test_gap_cli.py)
    default=20,
    show_default=True,
    help="Doublet manoeuvres per case.",
)
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Also write the full result (every case) as JSON here.",
)
@json_option
def benchmark_command(
    cases: int, seed: int, manoeuvres: int, out: Path | None, as_json: bool
) -> None:
    """Diagnose simulated flights with known withheld effects, blind, and score the diagnosis."""
    from ornitail.gap.benchmark import run_benchmark

    if out is not None:
        prepare_output_file(out)
    with Progress("gap benchmark", cases, "cases") as bar:
        result = run_benchmark(
            cases, seed, manoeuvres, progress=lambda step: bar.update(bar.done + step)
        )
    if out is not None:
        out.write_text(json.dumps(to_jsonable(result), indent=1))
        result["written"] = str(out)
    emit(result, as_json, render_benchmark)


def render_benchmark(result: dict) -> str:
    scores = result["scores"]
    matrix = scores["confusion_matrix"]
    columns = matrix["columns_reported"]
    width = max(len(c) for c in columns + matrix["rows_true"]) + 1

    def percent(value: float | None) -> str:
        return "-" if value is None else f"{100 * value:.1f} %"

    def number(value: float | None) -> str:
        return "-" if value is None else f"{value:.3f}"

    lines = [
        f"gap benchmark: {scores['cases']} cases ({scores['effect_cases']} with withheld effects, "
        f"{scores['no_effect_cases']} without), seed {result['seed']}",
        f"top-1 accuracy {percent(scores['top1_accuracy'])}, top-3 accuracy "
        f"{percent(scores['top3_accuracy'])}, false alarms {percent(scores['false_alarm_rate'])}, "
        f"mean reported set size {scores['mean_reported_set_size']:.2f}",
        f"magnitude error: median {number(scores['magnitude_error_median'])}, 90th percentile "
        f"{number(scores['magnitude_error_90th_percentile'])} (relative)",
        f"closure of the reported effect: test runs {number(scores['closure_reported_median'])}, "
        f"validation runs {number(scores['closure_reported_validation_median'])}; true effect on "
        f"validation runs {number(scores['closure_true_effect_median'])} (medians)",
        f"named effects on a fresh flight of the same case: closure within the reported interval "
        f"{percent(scores['fresh_flight_within_interval'])} (test runs) and "
        f"{percent(scores['fresh_flight_within_prediction_interval'])} (90 % prediction for new "
        f"data), below the reported closure "
        f"{percent(scores['fresh_flight_below_reported'])}, reported minus fresh "
        f"{number(scores['closure_reported_minus_fresh_median'])} (median)",
        "confusion matrix (rows: true effect; columns: reported):",
        " " * width + " ".join(f"{c[:8]:>8s}" for c in columns),
    ]
    for truth in matrix["rows_true"]:
        counts = matrix["counts"][truth]
        lines.append(f"{truth:<{width}s}" + " ".join(f"{counts[c]:>8d}" for c in columns))
    if result.get("written"):
        lines.append(f"written: {result['written']}")
    return "\n".join(lines)
