"""The diagnosis report as text (the JSON fields are documented in docs/gap-diagnosis.md)."""

from __future__ import annotations

from typing import Any

from ornitail.gap.derivative_candidates import DERIVATIVE_LEVEL_CANDIDATES
from ornitail.gap.validation_weighting import WINSORISED_RUN_ENERGY


def _gap_line(label: str, gap: dict[str, Any]) -> str:
    channels = ", ".join(
        f"{name} {item['value']:.3f} [{item['interval'][0]:.3f}, {item['interval'][1]:.3f}]"
        for name, item in gap["per_channel"].items()
    )
    low, high = gap["interval"]
    return f"{label}: {gap['total']:.3f} [{low:.3f}, {high:.3f}]   per channel: {channels}"


def magnitude_text(magnitude: dict[str, Any]) -> str:
    """A magnitude as text: "at least X" / "at most X" (at the edge of the range) when the fit sits
    on the candidate's upper / lower bound, else the plain value, with its unit."""
    prefix = {"upper": "at least ", "lower": "at most "}.get(magnitude["at_bound"], "")
    edge = " (at the edge of the range)" if magnitude["at_bound"] else ""
    return f"{prefix}{magnitude['value']:.4g} {magnitude['unit']}{edge}"


def _strongest_moves(refit: dict[str, Any]) -> str:
    """The moved derivatives, the change furthest from zero in its interval's half-widths first."""

    def strength(item: dict[str, Any]) -> float:
        low, high = item["change_interval"]
        return abs(item["change"]) / max((high - low) / 2, 1e-300)

    moved = [(strength(item), name) for name, item in refit["derivatives"].items() if item["moved"]]
    if not moved:
        return "no single one's interval apart from zero"
    return "moved, strongest first: " + ", ".join(name for _, name in sorted(moved, reverse=True))


def derivative_refit_lines(refit: dict[str, Any] | None) -> list[str]:
    """The derivative re-fit (docs/gap-diagnosis.md, Method step 7) as text; none when not asked."""
    if not refit:
        return []
    if refit["derivatives"] is None:
        return [f"derivative re-fit: none ({refit['reason']})"]
    low, high = refit["closure_interval"]
    lines = [
        f"derivative re-fit ({refit['method']}, {refit['training_runs']} training runs; the most a "
        f"linear re-fit closes on test runs: {refit['closure_test']:.3f} [{low:.3f}, {high:.3f}], on its "
        f"training runs {refit['closure_training']:.3f}):",
    ]
    if refit["supported_by_test_runs"]:
        lines.append(
            f"  left by it on test runs: {refit['remainder_fraction_test']:.3f} of the baseline's gap, the "
            "nonlinear remainder and noise that no change of the derivatives took up (the sparse-regression "
            "pointer below reads it)"
        )
    else:
        lines.append(
            "  not supported by the test runs: the re-fit predicts them no better than the baseline, so the moves "
            "(*) fit the training runs only and do not say where the model is wrong"
        )
    for name, item in refit["derivatives"].items():
        low, high = item["change_interval"]
        mark = "*" if item["moved"] else " "
        lines.append(
            f" {mark}{name:10s} {item['baseline']:+.4g} -> {item['refit']:+.4g} {item['unit']} "
            f"(change [{low:+.3g}, {high:+.3g}])"
        )
    return lines


def _near_miss_lines(report: dict[str, Any]) -> list[str]:
    """When no effect is named although the best candidate does better than a typical random
    direction (the null's median) and either beats the null's 95th percentile or closes at least the
    materiality floor on validation runs: which part of the rule kept it out (random directions
    reaching as much, or its lower bound under the lower-bound threshold)."""
    rule, top = report["detection_rule"], report["ranking"][0]
    closure, threshold = top["validation_closure"], rule["threshold"]
    if (
        report["verdict"] == "effect"
        or closure <= rule["null_closures_median"]
        or (closure <= threshold and closure < rule["materiality_floor"])
    ):
        return []
    magnitude = {"value": top["magnitude"], "unit": top["unit"], "at_bound": top["at_bound"]}
    bound, bound_threshold = top["simultaneous_lower_bound"], rule["lower_bound_threshold"]
    if closure > threshold:
        head = "not named, though it beats the null"
        why = f"above the null's {threshold:.3f}, but its lower bound {bound:.3f} is under {bound_threshold:.3f}"
    else:
        head = "not named, though it closes more than a typical random direction"
        why = f"but random directions of the model reach as much (the null's 95th percentile {threshold:.3f})"
        if bound <= bound_threshold:
            why += f", and its lower bound {bound:.3f} is under {bound_threshold:.3f}"
    return [
        f"  {head}: {top['name']} ({magnitude_text(magnitude)}) closes {closure:.3f} on validation runs, "
        f"{why}; on test runs it closes {report['closure']['realised_test']:.3f} (how far, below)"
    ]


def _derivative_level_lines(report: dict[str, Any]) -> list[str]:
    """When the named effect is a derivative-level candidate: that it says where the model is off,
    which a missing physical term and the baseline's own linearisation error at the amplitude
    flown would both explain, and which physical effects share its set."""
    if report["verdict"] != "effect" or report["effect"] not in DERIVATIVE_LEVEL_CANDIDATES:
        return []
    physical = [
        name for name in report["indistinguishable_set"] if name not in DERIVATIVE_LEVEL_CANDIDATES
    ]
    shared = f"; it shares its set with {', '.join(physical)}" if physical else ""
    return [
        f"  {report['effect']} is a change of the model's own parameters: it says where the model is off, "
        "not which term is missing there (a physical term, or the baseline's own linearisation error at the "
        f"amplitude flown; docs/gap-diagnosis.md, Detection limits){shared}"
    ]


def _stripped_of(rule: dict) -> str:
    """ ", each orthogonal to ..." when the rule's null directions were stripped of named changes, else nothing."""
    what = rule.get("null_directions_orthogonal_to")
    return f", each orthogonal to {what}" if what else ""


def render_report(report: dict[str, Any]) -> str:
    """Readable summary: verdict, where, ranking, how far the gap shrinks, the sparse pointer."""
    runs = report["runs"]
    rule = report["detection_rule"]
    pooled = report["split"].get("validation_design") == "all-folds"
    roles = (
        f"{report['split']['folds']} folds: {runs['training']} training and {runs['validation']} "
        "validation places over them, every fold's validation scores pooled to choose"
        if pooled
        else f"{runs['training']} to fit and {runs['validation']} to choose in the first fold"
    )
    lines = [
        f"gap diagnosis of {report['data_kind']} data ({runs['total']} runs, {roles}; "
        f"{runs['test']} scored as test runs; seed {report['seed']})",
        f"split: {report['split']['method']}",
        f"detection rule: validation closure above {rule['threshold']:.3f}, the 95th percentile of "
        f"{rule['draws']} random one-parameter directions fitted the same way{_stripped_of(rule)}, "
        "and its lower bound "
        f"({'Bonferroni-t' if pooled else 'bootstrap'}, simultaneous over the candidates that "
        "could have won) above "
        f"{rule['lower_bound_threshold']:.3f}, the larger of their median "
        f"({rule['null_closures_median']:.3f}) and the materiality floor "
        f"{rule['materiality_floor']:.2f}",
    ]
    if report["split"].get("validation_weighting", "none") != "none":
        lines.append(
            f"validation runs {report['split']['validation_weighting']}: "
            f"{report['split']['validation_runs_weighted_down']} of {runs['validation']} above "
            f"{WINSORISED_RUN_ENERGY:g} x the median run's baseline energy, counted as that much in the "
            "ranking and the rule (test closures unweighted)"
        )
    if report["verdict"] == "effect":
        lines.append(
            f"effect: {report['effect']} (magnitude {magnitude_text(report['magnitude'])}), "
            f"indistinguishable set {{{', '.join(report['indistinguishable_set'])}}}, "
            f"confidence {report['confidence']:.2f}"
        )
        second = report.get("second_effect")
        if second:
            lines.append(
                f"second effect on top of it: {second['effect']} (magnitude "
                f"{magnitude_text(second['magnitude'])}, set "
                f"{{{', '.join(second['indistinguishable_set'])}}}, closes a further "
                f"{second['closure_beyond_first']:.3f} of the remaining gap on the test runs)"
            )
    elif report.get("verdict_basis") == "derivative_refit":
        refit = report["derivative_refit"]
        lines.append(
            "effect: unexplained by any named effect, but a re-fit of the model's derivatives closes "
            f"{refit['closure_test']:.3f} of the gap on test runs it did not see: its derivatives are off "
            f"({_strongest_moves(refit)}; see the derivative re-fit below)"
        )
    elif report["verdict"] == "unexplained":
        lines.append(
            "effect: unexplained (a systematic gap that no candidate explains by the detection rule; see the "
            "sparse-regression pointer)"
        )
    else:
        lines.append(
            "effect: none (no candidate passes the detection rule, and the gap shows no systematic part)"
        )
    lines += _derivative_level_lines(report)
    lines += _near_miss_lines(report)
    lines.append("where:")
    lines += [f"  {sentence}" for sentence in report["where"]["summary"]]
    lines.append(
        "ranking (closure on validation runs, 90 % interval, simultaneous lower bound; closure on "
        "training runs):"
    )
    for entry in report["ranking"]:
        low, high = entry["closure_interval"]
        mark = "*" if entry["in_top_set"] else " "
        lines.append(
            f" {mark}{entry['name']:28s} {entry['validation_closure']:+.3f} "
            f"[{low:+.3f}, {high:+.3f}] >= {entry['simultaneous_lower_bound']:+.3f}  "
            f"training {entry['training_closure']:+.3f}  k = "
            f"{magnitude_text({'value': entry['magnitude'], 'unit': entry['unit'], 'at_bound': entry['at_bound']})}"
            f"  P(best) {entry['probability_best']:.2f}"
            + (
                f" (one model with {', '.join(entry['same_model_as'])})"
                if entry["in_top_set"] and entry["same_model_as"]
                else ""
            )
        )
    for name, reason in (report.get("candidates_skipped") or {}).items():
        lines.append(f"  skipped {name}: {reason}")
    closure = report["closure"]
    low, high = closure["interval"]
    lines.append(
        f"how far ({report['best_candidate']}, test runs, normalised RMS with 90 % intervals):"
    )
    lines.append("  " + _gap_line("before", report["gap_before"]))
    lines.append("  " + _gap_line("after ", report["gap_after"]))
    lines.append(
        f"  closure predicted from training {closure['predicted_from_training']:.3f}, on the "
        f"validation runs that chose it {closure['realised_validation']:.3f}, realised on test "
        f"runs {closure['realised_test']:.3f} [{low:.3f}, {high:.3f}] (interval over test runs, "
        "conditional on the chosen effect)"
    )
    if closure.get("fresh_data_interval"):
        fresh_low, fresh_high = closure["fresh_data_interval"]
        lines.append(
            f"  on new data of as many runs (a fresh flight): closure {fresh_low:.3f} to "
            f"{fresh_high:.3f} (90 % prediction interval: these runs' scatter and the new data's own; "
            "not a flight that differs from this one as a whole, e.g. in its slow states)"
        )
    lines += derivative_refit_lines(report.get("derivative_refit"))
    pointer = report["sparse_regression"]
    lines.append(
        "sparse regression of the residual (pointer"
        + (
            "; its linear terms also take up the sensor noise and gust response of the measured states they "
            "are regressed on, so read its nonlinear terms first):"
            if report["data_kind"] == "flight"
            else "):"
        )
    )
    for target, fit in pointer.items():
        terms = ", ".join(f"{name} {value:+.3g}" for name, value in fit["terms"].items())
        lines.append(f"  {target}: {terms or '-'} (explains {100 * fit['explained']:.0f} %)")
    if report.get("written"):
        lines.append("written: " + ", ".join(report["written"]))
    return "\n".join(lines)
