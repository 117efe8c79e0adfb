"""Semi-real gap cases: NASA's real Twin Otter record with a known effect injected.

The record ``twin_otter_020213f1_019`` (tests/data/twin-otter, copied unchanged from
shared/realdata/twin-otter; a NASA SIDPAC example flight: 376 samples at 0.02 s, one longitudinal
manoeuvre) is real flight data: its own turbulence, sensor noise and whatever the short-period
model leaves out. The baseline is ``twin_otter_short_period`` identified by ornitail's output-error
estimator on the *untouched* record (its start values replaced by the estimates), so the untouched
record is what the baseline was made from, and anything the diagnosis finds in an injected copy
is the injection or the record's own leftovers (the untouched case measures those).

Injected effects (logged columns changed, the motion untouched):

- ``elevator_delay``: the logged elevator leads the surface by d: ``elevator_deg(t) -> elevator_deg(t
  + d)`` (the candidate ``input_delay`` = +d);
- ``elevator_filter``: the logged elevator is the surface through a first-order low-pass of time
  constant tau (exact at the record's 0.02 s for a deflection linear between samples; candidate
  ``input_filter`` = tau);
- ``alpha_bias``: the alpha vane reads b too high: ``alpha_deg -> alpha_deg + b`` (candidate
  ``alpha_bias``, in the model's unit rad).

The record has no manoeuvre command columns, so the diagnosis cuts it into segments of
:data:`SEGMENT_S` seconds (``[baseline].segment_s``); each starts from its measured state.

``python benchmarks/semi_real.py`` runs every case once and prints the verdicts.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.identify import identify
from ornitail.flight.model_file import load_model
from ornitail.gap.model_spec import BaselineSpec, write_baseline_spec
from ornitail.gap.withheld_effects import first_order_lowpass

RECORD = Path(__file__).parents[1] / "tests" / "data" / "twin-otter" / "twin_otter_020213f1_019.csv"
MODEL = "twin_otter_short_period"
SEGMENT_S = 0.5  # 15 segments of 25 samples: about a quarter of the short period (2 s)


@dataclass(frozen=True)
class InjectedCase:
    """One semi-real case: ``effect`` (None = untouched) of ``magnitude`` (s, or deg for the
    alpha bias) and the candidate name and magnitude (model units) the diagnosis should report."""

    effect: str | None
    magnitude: float = 0.0

    @property
    def expected(self) -> tuple[str | None, float]:
        if self.effect is None:
            return None, 0.0
        if self.effect == "alpha_bias":
            return "alpha_bias", math.radians(self.magnitude)
        return {"elevator_delay": "input_delay", "elevator_filter": "input_filter"}[
            self.effect
        ], self.magnitude


CASES = (
    InjectedCase(None),
    InjectedCase("elevator_delay", 0.08),
    InjectedCase("elevator_filter", 0.1),
    InjectedCase("alpha_bias", 0.5),
)


def injected_log(log: pd.DataFrame, case: InjectedCase) -> pd.DataFrame:
    """A copy of the record ``log`` with ``case``'s effect in its logged columns."""
    log = log.copy()
    time_s = log["time_sec"].to_numpy(float)
    elevator = log["elevator_deg"].to_numpy(float)
    if case.effect == "elevator_delay":
        log["elevator_deg"] = np.interp(time_s + case.magnitude, time_s, elevator)
    elif case.effect == "elevator_filter":
        step_s = float(np.median(np.diff(time_s)))
        log["elevator_deg"] = first_order_lowpass(elevator, step_s, case.magnitude)
    elif case.effect == "alpha_bias":
        log["alpha_deg"] = log["alpha_deg"] + case.magnitude
    elif case.effect is not None:
        raise ValueError(f"unknown injected effect {case.effect!r}")
    return log


def identified_model_file(folder: Path, record: Path = RECORD) -> Path:
    """The Twin Otter model file with its start values set to the output-error estimates on the
    untouched ``record`` (written into ``folder``)."""
    model = load_model(MODEL)
    values = identify(model, read_flight_log(record)).parameter_values()
    text = Path(model.source).read_text()
    for name, value in values.items():
        text, count = re.subn(
            rf"^{name} = \{{ start = [^,]+,", f"{name} = {{ start = {value!r},", text, flags=re.M
        )
        if count != 1:
            raise ValueError(f"{model.source}: parameter {name} not found once")
    path = folder / "twin_otter_identified.toml"
    path.write_text(text)
    return path


def write_case(
    case: InjectedCase, folder: Path, model_file: Path, derivative_refit: bool = False
) -> tuple[Path, Path]:
    """The injected log and the baseline file (segments of :data:`SEGMENT_S`, with the derivative
    re-fit when asked) in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    log_path = folder / "twin_otter.csv"
    injected_log(read_flight_log(RECORD), case).to_csv(log_path, index=False)
    spec = BaselineSpec(
        "linear_model",
        model=str(model_file),
        segment_s=SEGMENT_S,
        derivative_refit=derivative_refit,
    )
    return log_path, write_baseline_spec(spec, folder / "baseline.toml")
