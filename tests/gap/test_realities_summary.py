"""The three-realities benchmark's scoring (benchmarks/gap_realities.py ``summarise``) on hand-made case
results: every count is exact, so the bookkeeping of false alarms and misses is checked without a flight."""

import json

import pytest
from gap_realities import combine, figure_title, main, seed_ranges, summarise, wilson_interval
from realities_figure import realities_figure


def case(expected, verdict, reported, in_library=True, closure_test=0.2, **more):
    named = [reported] if verdict == "effect" and reported else []
    return {
        "expected": expected,
        "in_library": in_library,
        "verdict": verdict,
        "reported": reported,
        "reported_set": named,
        "closure_test": closure_test,
    } | more


def test_false_alarms_say_how_many_were_derivative_level_findings():
    results = [
        case(None, "effect", "heave_damping"),
        case(None, "effect", "input_delay"),
        case(None, "unexplained", None),
        case(None, "none", None),
    ]
    scores = summarise(results)
    assert scores["false_alarms_on_no_effect"] == "2 of 4"
    assert scores["false_alarms_derivative_level"] == "1 of 4"
    assert scores["unexplained_on_no_effect"] == "1 of 4"


def test_each_in_library_miss_is_listed_with_its_verdict_and_test_closure():
    results = [
        case("input_filter", "effect", "input_filter"),
        case("input_filter", "unexplained", "input_delay", closure_test=0.123),
        case("iyy_shift", "effect", "pitch_damping", closure_test=0.31),
        case("static_stability", "unexplained", None, in_library=False),
    ]
    scores = summarise(results)
    assert scores["named_in_library"] == "1 of 3"
    assert scores["in_library_missed"] == [
        {
            "expected": "input_filter",
            "verdict": "unexplained",
            "reported": "input_delay",
            "closure_test": 0.123,
        },
        {
            "expected": "iyy_shift",
            "verdict": "effect",
            "reported": "pitch_damping",
            "closure_test": 0.31,
        },
    ]
    assert scores["out_of_library_unexplained_or_nearest_derivative"] == "1 of 1"


def test_the_simulator_parts_own_named_flag_decides_a_miss():
    # the simulator's cases score two-effect flights themselves (named when the set holds either effect)
    results = [
        case("added_mass,input_delay", "effect", "input_delay", named_in_library=True),
        case("added_mass", "none", "added_mass", named_in_library=False, closure_test=0.09),
    ]
    scores = summarise(results)
    assert scores["named_in_library"] == "1 of 2"
    assert [miss["expected"] for miss in scores["in_library_missed"]] == ["added_mass"]


def test_wilson_intervals_match_the_closed_form_and_stay_inside_zero_and_one():
    # 1 of 4: centre (0.25 + z^2/8) / (1 + z^2/4), half-width z sqrt(3/64 + z^2/64) / (1 + z^2/4), z = 1.96
    assert wilson_interval(1, 4) == pytest.approx([0.04559, 0.69936], abs=1e-5)
    assert wilson_interval(0, 24)[0] == 0.0 and wilson_interval(24, 24)[1] == 1.0
    assert wilson_interval(0, 0) is None
    scores = summarise([case(None, "effect", "heave_damping")] + [case(None, "none", None)] * 3)
    assert scores["rate_counts"]["false_alarms_on_no_effect"] == [1, 4]
    assert scores["rate_counts"]["out_of_library_unexplained_or_nearest_derivative"] == [0, 0]
    assert scores["rate_intervals_95"]["false_alarms_on_no_effect"] == wilson_interval(1, 4)
    assert scores["rate_intervals_95"]["out_of_library_unexplained_or_nearest_derivative"] is None


def _result_file(path, seed, parts, **design):
    """A result file; files written before the null-directions option have no such key ("any")."""
    path.write_text(
        json.dumps({"seed": seed, "validation": "all-folds", **design, "results": parts})
    )
    return path


def test_combine_pools_every_seed_once_per_part(tmp_path):
    semi = [case("input_delay", "effect", "input_delay")]
    # one seed run as two processes (one per part), each carrying the same semi-real cases, and a second seed
    files = [
        _result_file(
            tmp_path / "sim.json", 1, {"semi_real": semi, "sim": [case(None, "none", None)] * 2}
        ),
        _result_file(
            tmp_path / "ind.json",
            1,
            {"semi_real": semi, "sim": [], "independent": [case(None, "effect", "heave_damping")]},
        ),
        _result_file(
            tmp_path / "two.json",
            2,
            {"semi_real": semi, "sim": [case(None, "effect", "input_delay")]},
        ),
    ]
    pooled = combine(files)
    assert (pooled["validation"], pooled["null_directions"]) == ("all-folds", "any")
    assert pooled["seeds"] == {"semi_real": [1, 2], "sim": [1, 2], "independent": [1]}
    assert pooled["scores"]["semi_real"]["named_in_library"] == "2 of 2"
    assert pooled["scores"]["sim"]["false_alarms_on_no_effect"] == "1 of 3"
    assert pooled["scores"]["independent"]["false_alarms_derivative_level"] == "1 of 1"


def test_results_of_different_designs_are_not_pooled(tmp_path):
    files = [
        _result_file(tmp_path / "any.json", 1, {"sim": [case(None, "none", None)]}),
        _result_file(
            tmp_path / "orthogonal.json",
            2,
            {"sim": [case(None, "none", None)]},
            null_directions="library-orthogonal",
        ),
    ]
    with pytest.raises(
        SystemExit, match=r"orthogonal.json: .*'library-orthogonal', .*; .*any.json differs"
    ):
        combine(files)
    assert combine(files[:1])["scores"]["sim"]["false_alarms_on_no_effect"] == "0 of 1"
    winsorised = _result_file(
        tmp_path / "winsorised.json",
        3,
        {"sim": [case(None, "none", None)]},
        validation_weighting="winsorised",
    )
    with pytest.raises(
        SystemExit,
        match=r"winsorised.json: .*validation_weighting 'winsorised'; .*any.json differs",
    ):
        combine([files[0], winsorised])
    alone = combine([winsorised])
    assert ", validation runs winsorised\n" in figure_title(alone, alone["seeds"])
    # a file from before the key existed was diagnosed with every run by its energy
    assert ", validation runs none\n" in figure_title(combine(files[:1]), {"sim": [1]})


def test_a_file_that_is_not_a_result_is_named_in_one_line(tmp_path):
    stray = tmp_path / "notes.json"
    stray.write_text(json.dumps({"seed": 1}))
    with pytest.raises(SystemExit, match=r"notes.json: not a gap_realities result file") as raised:
        combine([stray])
    assert "\n" not in str(raised.value)


def test_the_figure_puts_each_parts_rate_and_interval_against_the_issues_targets(tmp_path):
    scores = {
        "sim": summarise([case(None, "effect", "heave_damping")] + [case(None, "none", None)] * 3),
        "semi_real": summarise([case("input_delay", "effect", "input_delay")]),
    }
    figure = realities_figure(scores, "title")
    no_effect, in_library, outside, fresh, magnitudes = figure.axes
    # the simulator's 1 of 4 false alarms: its point at 0.25 with the Wilson interval's ends as error bars
    point = next(line for line in no_effect.lines if line.get_marker() == "o")
    assert point.get_xydata().tolist() == [[0.0, 0.25]]
    low, high = wilson_interval(1, 4)
    (bars,) = no_effect.collections
    assert bars.get_segments()[0][:, 1].tolist() == pytest.approx([low, high])
    # the issue's target as a dashed line in each panel
    targets = [
        [line.get_ydata()[0] for line in axis.lines if line.get_linestyle() == "--"]
        for axis in (no_effect, in_library, outside, fresh, magnitudes)
    ]
    assert targets == [[0.05], [0.95], [0.90], [0.90], [20.0]]
    # each named in the panel's corner on the far side of its line (points near a target stay clear of it)
    labels = [
        next(text for text in axis.texts if text.get_text().startswith("dashed: "))
        for axis in (no_effect, in_library)
    ]
    assert [label.get_position()[1] for label in labels] == [0.97, 0.03]
    # a part without cases of a kind says so rather than drawing a point
    texts = [text.get_text() for text in outside.texts]
    assert texts.count("no cases") == 2
    assert [tick.get_text() for tick in no_effect.get_xticklabels()] == ["simulator", "semi-real"]


def test_combine_draws_the_figure_titled_with_each_parts_seeds(tmp_path):
    files = [
        _result_file(tmp_path / f"{seed}.json", seed, {"sim": [case(None, "none", None)]})
        for seed in (2018, 2019, 2020, 2024)
    ]
    picture = tmp_path / "scores.png"
    pooled = main(["--combine", *map(str, files), "--figure", str(picture)])
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert seed_ranges([2024, 2018, 2020, 2019]) == "2018-2020, 2024"
    assert figure_title(pooled, pooled["seeds"]) == (
        "gap diagnosis on three realities, null directions any, validation all-folds, "
        "validation runs none\n"
        "seeds: simulator 2018-2020, 2024"
    )


@pytest.mark.parametrize("option", ["--figure", "--out"])
def test_an_output_in_a_folder_that_does_not_exist_is_refused_in_one_line_before_any_run(
    tmp_path, capsys, option
):
    missing = tmp_path / "no-such-folder" / "scores.png"
    with pytest.raises(SystemExit) as raised:
        main(["--sim-cases", "1", option, str(missing)])
    assert raised.value.code == 2
    (line,) = [text for text in capsys.readouterr().err.splitlines() if "error:" in text]
    assert f"{option} {missing}: the folder {missing.parent} does not exist" in line
