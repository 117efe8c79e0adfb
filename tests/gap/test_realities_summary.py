"""The three-realities benchmark's scoring (benchmarks/gap_realities.py ``summarise``) on hand-made case
results: every count is exact, so the bookkeeping of false alarms and misses is checked without a flight."""

from gap_realities import summarise


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
