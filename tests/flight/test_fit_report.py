"""``ornitail flight identify --out``: the fit report on the real Twin Otter record, its
correlation sequences against a direct computation, warnings of a poor fit, and ``--input-hold``.
"""

import json
import math
from pathlib import Path
from statistics import NormalDist

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from ornitail.app.commands.flight import flight_group
from ornitail.core.errors import UserInputError
from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.identify import identify
from ornitail.flight.model_data import model_data
from ornitail.flight.model_file import PRESET_DIRECTORY, load_model

CSV_PATH = str(Path(__file__).parents[1] / "data" / "twin-otter" / "twin_otter_020213f1_019.csv")
MODEL = "twin_otter_short_period"
PICTURES = ("compare", "residuals", "residual_autocorrelation", "residual_input_correlation")
TABLES = ("parameters.csv", "residual_autocorrelation.csv", "residual_input_correlation.csv")


def _identify(model: str, *options: str) -> str:
    result = CliRunner().invoke(
        flight_group, ["identify", "--model", model, "--data", CSV_PATH, *options]
    )
    assert result.exit_code == 0, result.output
    return result.output


def _correlation(first: np.ndarray, second: np.ndarray, lag: int) -> float:
    """sum_k a[k] b[k + lag] / sqrt(sum a^2 sum b^2) of the mean-removed signals, by slicing."""
    a, b = first - first.mean(), second - second.mean()
    count = len(a)
    product = np.dot(a[: count - lag], b[lag:]) if lag >= 0 else np.dot(a[-lag:], b[: count + lag])
    return float(product / np.sqrt(np.sum(a**2) * np.sum(b**2)))


def _direct_correlations(model_name: str) -> dict[str, object]:
    """The residual correlation sequences of an in-process identification, computed directly."""
    model = load_model(model_name)
    log = read_flight_log(CSV_PATH)
    result = identify(model, log)
    signals = model_data(model, log)
    residuals = signals.outputs - result.simulated_outputs
    count = len(residuals)
    lags = min(25, count // 4)
    auto, cross = {}, {}
    for index, output in enumerate(model.outputs):
        residual = residuals[:, index]
        auto[output] = [_correlation(residual, residual, lag) for lag in range(lags + 1)]
        for input_index, name in enumerate(model.inputs):
            signal = signals.inputs[:, input_index]
            if np.ptp(signal) > 0:
                cross[(output, name)] = [
                    _correlation(signal, residual, lag) for lag in range(-lags, lags + 1)
                ]
    return {
        "auto": auto,
        "cross": cross,
        "bound": NormalDist().inv_cdf(0.995) / math.sqrt(count),
        "lags": lags,
    }


def _expected_warnings(fit: dict[str, float], direct: dict[str, object]) -> list[tuple[str, str]]:
    """(output, figure) for every output with 1 - NRMSE < 0.5, then (output, input) for every
    input whose correlation with an output's residual fails the 99 % test (more than 1 % of the
    tested lags of that output beyond the bound).
    """
    expected = [(output, "compare.png") for output, value in fit.items() if value < 0.5]
    bound = direct["bound"]
    for output in fit:
        pairs = {name: values for (out, name), values in direct["cross"].items() if out == output}
        exceedances = sum(int(np.sum(np.abs(values) > bound)) for values in pairs.values())
        tested = sum(len(values) for values in pairs.values())
        if exceedances > int(0.01 * tested):
            expected += [
                (output, name) for name, values in pairs.items() if np.max(np.abs(values)) > bound
            ]
    return expected


def _assert_warnings_match(warnings: list[str], expected: list[tuple[str, str]]) -> None:
    assert len(warnings) == len(expected), warnings
    for sentence, (output, named) in zip(warnings, expected, strict=True):
        assert sentence.startswith(f"output {output}:")
        if named == "compare.png":
            assert "below 0.5" in sentence and sentence.endswith("see compare.png")
        else:
            assert f"input {named}" in sentence and "99 % bound" in sentence
            assert sentence.endswith("see residual_input_correlation.png")


@pytest.fixture(scope="module")
def good_fit(tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "new" / "folder"
    summary = json.loads(_identify(MODEL, "--out", str(out), "--json"))
    return out, summary, _direct_correlations(MODEL)


def test_every_picture_and_table_is_written_and_listed(good_fit):
    out, summary, _ = good_fit
    expected = [out / f"{stem}{suffix}" for stem in PICTURES for suffix in (".png", ".pdf")]
    expected += [out / name for name in (*TABLES, "identification.json")]
    for path in expected:
        assert path.is_file() and path.stat().st_size > 0, path
    assert sorted(summary["written"]) == sorted(str(path) for path in expected)
    document = json.loads((out / "identification.json").read_text())
    assert document["parameters"] == summary["parameters"]
    assert document["warnings"] == summary["warnings"]
    assert document["model"] == MODEL and document["method"] == "output_error"


def test_parameter_table_carries_the_models_units(good_fit):
    out, summary, _ = good_fit
    table = pd.read_csv(out / "parameters.csv", keep_default_na=False)
    assert list(table.columns) == ["parameter", "value", "sigma_crb", "sigma_colored", "unit"]
    units = {parameter.name: parameter.unit for parameter in load_model(MODEL).parameters}
    assert all(units.values())
    assert dict(zip(table["parameter"], table["unit"], strict=True)) == units
    assert {name: item["unit"] for name, item in summary["parameters"].items()} == units
    for row in table.itertuples():
        estimate = summary["parameters"][row.parameter]
        assert row.value == pytest.approx(estimate["value"], rel=1e-12)
        assert row.sigma_crb == pytest.approx(estimate["sigma"], rel=1e-12)
        assert row.sigma_colored == pytest.approx(estimate["sigma_colored"], rel=1e-12)


def test_correlation_sequences_agree_with_a_direct_computation(good_fit):
    out, _, direct = good_fit
    lags = direct["lags"]
    auto = pd.read_csv(out / "residual_autocorrelation.csv")
    assert auto["lag_samples"].tolist() == list(range(lags + 1))
    assert auto["lag_s"].to_numpy() == pytest.approx(0.02 * auto["lag_samples"], abs=1e-9)
    for output, values in direct["auto"].items():
        assert auto[output].to_numpy() == pytest.approx(values, abs=1e-10)
    cross = pd.read_csv(out / "residual_input_correlation.csv")
    assert cross["lag_samples"].tolist() == list(range(-lags, lags + 1))
    assert set(cross.columns) == {"lag_samples", "lag_s"} | {
        f"{output}_vs_{name}" for output, name in direct["cross"]
    }
    tests = json.loads((out / "identification.json").read_text())["residual_tests"]
    assert tests["bound"] == pytest.approx(direct["bound"])
    for (output, name), values in direct["cross"].items():
        assert cross[f"{output}_vs_{name}"].to_numpy() == pytest.approx(values, abs=1e-10)
        largest = tests["max_input_correlation"][output][name]
        assert largest == pytest.approx(np.max(np.abs(values)), abs=1e-10)


def test_good_fit_warnings_follow_from_its_numbers(good_fit):
    _, summary, direct = good_fit
    expected = _expected_warnings(summary["fit"], direct)
    _assert_warnings_match(summary["warnings"], expected)


def test_a_wrong_elevator_column_gives_warnings_in_text_and_json(tmp_path):
    text = (PRESET_DIRECTORY / f"{MODEL}.toml").read_text()
    assert text.count('column = "elevator_deg"') == 1
    variant = tmp_path / "wrong_elevator.toml"
    variant.write_text(text.replace('column = "elevator_deg"', 'column = "rudder_deg"'))
    summary = json.loads(_identify(str(variant), "--json"))
    expected = _expected_warnings(summary["fit"], _direct_correlations(str(variant)))
    assert {figure for _, figure in expected} == {"compare.png", "elevator"}
    _assert_warnings_match(summary["warnings"], expected)

    lines = _identify(str(variant)).splitlines()
    assert f"converged, with {len(expected)} warnings" in lines[0]
    printed = [line.removeprefix("warning: ") for line in lines if line.startswith("warning: ")]
    assert printed == summary["warnings"]


def test_input_hold_option_changes_the_estimates_and_is_reported(good_fit):
    _, summary, _ = good_fit
    assert summary["input_hold"] == load_model(MODEL).input_hold
    other = "zero_order" if summary["input_hold"] == "first_order" else "first_order"
    changed = json.loads(_identify(MODEL, "--input-hold", other, "--json"))
    assert changed["input_hold"] == other
    shifts = [
        abs(changed["parameters"][name]["value"] - estimate["value"]) / estimate["sigma"]
        for name, estimate in summary["parameters"].items()
    ]
    assert max(shifts) > 3.0


def test_an_out_folder_that_cannot_be_made_is_one_line_naming_it(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    out = blocker / "report"
    result = CliRunner().invoke(
        flight_group, ["identify", "--model", MODEL, "--data", CSV_PATH, "--out", str(out)]
    )
    assert isinstance(result.exception, UserInputError)
    message = str(result.exception)
    assert str(out) in message and len(message.splitlines()) == 1
