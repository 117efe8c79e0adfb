"""The benchmark: case drawing, scoring, and a small blind run."""

import pytest

from ornitail.gap.benchmark import KINDS, draw_case, run_benchmark, summarise


def test_cases_are_deterministic_and_follow_the_kinds():
    first = [draw_case(index, 7, 12) for index in range(len(KINDS))]
    again = [draw_case(index, 7, 12) for index in range(len(KINDS))]
    assert first == again
    assert [tuple(case.effects) for case in first] == list(KINDS)
    cg = next(case for case in first if "cg_shift_with_x_h" in case.effects)
    assert abs(cg.x_h_mm - 98.0) >= 17.0


def _result(truth: dict, verdict: str, reported_set: list, top3: bool = True) -> dict:
    return {
        "true_effects": truth,
        "verdict": verdict,
        "reported": reported_set[0] if reported_set else None,
        "reported_set": reported_set,
        "top1": bool(set(truth) & set(reported_set)) and verdict == "effect",
        "top3": top3,
        "closure_reported": 0.4,
    }


def test_scores_and_confusion_matrix_count_what_happened():
    results = [
        _result({}, "none", []),
        _result({}, "effect", ["pitch_damping"]),
        _result({"added_mass": 2.0}, "effect", ["added_mass", "iyy_shift"]),
        _result({"input_delay": 0.05}, "effect", ["added_mass"], top3=False),
        _result({"input_delay": 0.05}, "unexplained", [], top3=False),
    ]
    scores = summarise(results)
    assert scores["top1_accuracy"] == pytest.approx(1 / 3)
    assert scores["top3_accuracy"] == pytest.approx(1 / 3)
    assert scores["false_alarm_rate"] == pytest.approx(0.5)
    counts = scores["confusion_matrix"]["counts"]
    assert counts["none"]["none"] == 1 and counts["none"]["pitch_damping"] == 1
    assert counts["added_mass"]["added_mass"] == 1
    assert counts["input_delay"]["added_mass"] == 1 and counts["input_delay"]["unexplained"] == 1
    assert scores["mean_reported_set_size"] == pytest.approx(1.5)


def test_a_small_blind_benchmark_names_a_clear_effect_and_stays_quiet_without_one():
    # case 0 has no effect, case 1 added mass >= 1.5 x the flat-plate value (closure ~0.3-0.5 in
    # the full benchmark, well above the 0.10 materiality floor and the calibrated null)
    result = run_benchmark(cases=2, seed=3, manoeuvres=12)
    scores = result["scores"]
    assert scores["false_alarm_rate"] == 0.0
    assert scores["top1_accuracy"] == 1.0
    assert result["results"][1]["magnitude_error"] < 0.3
