"""The several-fresh-flights benchmark's scoring (benchmarks/fresh_flights.py ``summarise``) on hand-made
case results, and its refusals: every count is exact, so the bookkeeping is checked without a flight."""

import json

import numpy as np
import pytest
from fresh_flights import fresh_flights_figure, intraclass_correlation, main, replay, summarise
from gap_realities import wilson_interval


def named(closures, low=0.2, high=0.4, index=1, closure_test=0.3):
    below = sum(value < low for value in closures)
    above = sum(value > high for value in closures)
    return {
        "index": index,
        "closure_test": closure_test,
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
        (["--figure", "no-such-folder/cases.png"], "the folder no-such-folder does not exist"),
    ],
)
def test_bad_options_are_refused_in_one_line_before_a_flight(arguments, message, capsys):
    with pytest.raises(SystemExit) as ended:
        main(["--part", "sim", *arguments])
    assert ended.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert message in error


def test_draw_needs_a_picture_and_a_run_needs_a_part(capsys):
    for arguments, message in (
        (["--draw", "a.json"], "--draw needs --figure PNG"),
        ([], "--part is required unless --draw is given"),
    ):
        with pytest.raises(SystemExit) as ended:
            main(arguments)
        assert ended.value.code == 2
        assert message in capsys.readouterr().err.strip().splitlines()[-1]


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "not a fresh_flights result file ("),
        ("[1, 2]", "not a fresh_flights result file ("),
        ('{"part": "sim", "seed": 1}', "not a fresh_flights result file (no results, summary)"),
        (
            '{"part": "tunnel", "seed": 1, "summary": {}, "results": []}',
            "part 'tunnel' is not one of sim, independent",
        ),
    ],
)
def test_a_draw_file_that_is_not_a_result_is_refused_in_one_line(
    tmp_path, content, message, capsys
):
    path = tmp_path / "result.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(SystemExit) as ended:
        main(["--draw", str(path), "--figure", str(tmp_path / "cases.png")])
    assert ended.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"--draw {path}: " in error and message in error
    assert not (tmp_path / "cases.png").exists()


def test_the_figure_draws_each_cases_interval_test_closure_and_fresh_flights_red_outside(tmp_path):
    results = [
        named([0.25, 0.3, 0.35, 0.39], index=1),
        named([0.41, 0.45, 0.5, 0.42], index=4, closure_test=0.38),
        {"index": 5, "expected": None, "verdict": "none"},
    ]
    output = {
        "part": "independent",
        "seed": 2040,
        "summary": summarise(results),
        "results": results,
    }
    (axis,) = fresh_flights_figure([output]).axes
    assert (
        axis.get_title() == "flapper B, seed 2040: 4 of 8 fresh flights inside (0 below, 4 above)"
    )
    # the named cases only, labelled by their index
    assert [tick.get_text() for tick in axis.get_xticklabels()] == ["1", "4"]
    crosses = [line for line in axis.lines if line.get_marker() == "x"]
    red = [line.get_xydata()[0].tolist() for line in crosses if line.get_color() == "tab:red"]
    assert sorted(red) == [[1.0, 0.41], [1.0, 0.42], [1.0, 0.45], [1.0, 0.5]]
    dots = [line.get_xydata()[0].tolist() for line in axis.lines if line.get_marker() == "o"]
    assert dots == [[0.0, 0.3], [1.0, 0.38]]
    (first, second) = axis.collections
    assert first.get_segments()[0][:, 1].tolist() == [0.2, 0.4]
    # --draw writes the same picture from saved results
    saved = tmp_path / "seed.json"
    saved.write_text(json.dumps(output))
    picture = tmp_path / "cases.png"
    main(["--draw", str(saved), "--figure", str(picture)])
    assert picture.read_bytes().startswith(b"\x89PNG")


def flights_of(generator, count, shared_spread):
    """``count`` flights of 16 runs: noise energy gamma(2) per run, times one lognormal factor per
    flight (``shared_spread``: its log's standard deviation), and an effect of energy 1 per run that
    the model removes (before = noise + 1, after = noise)."""
    flights = []
    for _ in range(count):
        noise = generator.gamma(2.0, 1.0, 16) * np.exp(shared_spread * generator.standard_normal())
        flights.append((noise + 1.0, noise))
    return flights


def test_intraclass_correlation_sees_a_factor_the_runs_of_a_flight_share():
    # 40 flights: the estimate's spread with independent runs is about 0.012 (20 seeds), and a
    # shared factor of spread 0.5 gives 0.29 +- 0.05, so both bounds sit near four spreads away
    independent = intraclass_correlation(flights_of(np.random.default_rng(7), 40, 0.0))
    shared = intraclass_correlation(flights_of(np.random.default_rng(7), 40, 0.5))
    assert abs(independent) < 0.05
    assert shared > 0.1


def test_replay_holds_every_flight_against_every_other_ones_interval():
    generator = np.random.default_rng(3)
    usual = flights_of(generator, 1, 0.0)[0]
    odd = (usual[0] * 4.0, usual[1])  # the same noise beside an effect of 4x the energy
    result = {
        "fresh_run_energies_before": [usual[0], usual[0], odd[0]],
        "fresh_run_energies_after": [usual[1], usual[1], odd[1]],
    }
    summary = replay([result, {"expected": None, "verdict": "none"}], seed=5)
    # two identical flights hold each other; the odd one closes far above their intervals and
    # each of them far below its interval
    assert summary["cases"] == 1
    assert summary["as_flown"] == {
        "pairs": 6,
        "inside": 2,
        "below": 2,
        "above": 2,
        "inside_rate": pytest.approx(2 / 6),
    }
    assert summary["runs_regrouped_at_random"]["pairs"] == 6 * 20


def test_replay_needs_two_fresh_flights_in_a_case():
    one = {"fresh_run_energies_before": [np.ones(16)], "fresh_run_energies_after": [np.ones(16)]}
    assert replay([one, {"expected": None, "verdict": "none"}], seed=1) is None
