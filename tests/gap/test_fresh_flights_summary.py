"""The several-fresh-flights benchmark's scoring (benchmarks/fresh_flights.py ``summarise``) on hand-made
case results, and its refusals: every count is exact, so the bookkeeping is checked without a flight."""

import pytest
from fresh_flights import main, summarise
from gap_realities import wilson_interval


def named(closures, low=0.2, high=0.4):
    below = sum(value < low for value in closures)
    above = sum(value > high for value in closures)
    return {
        "expected": "input_delay",
        "verdict": "effect",
        "closure_fresh_data_interval": [low, high],
        "closure_fresh_flights": closures,
        "below": below,
        "above": above,
    }


def test_fresh_flights_are_counted_inside_below_and_above_and_whole_misses_by_case():
    results = [
        named([0.25, 0.3, 0.35, 0.39]),
        named([0.41, 0.45, 0.5, 0.42]),  # the diagnosed flight stood apart: every new flight above
        named([0.1, 0.3, 0.3, 0.3]),
        {"expected": None, "verdict": "none"},
    ]
    summary = summarise(results)
    assert summary["cases"] == 4 and summary["cases_named"] == 3
    assert summary["fresh_flights"] == 12
    assert (summary["inside"], summary["below"], summary["above"]) == (7, 1, 4)
    assert summary["inside_rate"] == pytest.approx(7 / 12)
    assert summary["inside_rate_interval_95"] == wilson_interval(7, 12)
    assert summary["cases_missing_every_fresh_flight"] == 1


def test_no_named_case_gives_no_rate():
    summary = summarise([{"expected": None, "verdict": "unexplained"}])
    assert summary["fresh_flights"] == 0
    assert summary["inside_rate"] is None and summary["inside_rate_interval_95"] is None


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--out", "no-such-folder/result.json"], "the folder no-such-folder does not exist"),
        (["--fresh", "0"], "--cases 10 --fresh 0: both must be at least 1"),
    ],
)
def test_bad_options_are_refused_in_one_line_before_a_flight(arguments, message, capsys):
    with pytest.raises(SystemExit) as ended:
        main(["--part", "sim", *arguments])
    assert ended.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert message in error
