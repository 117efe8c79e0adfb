"""The diagnosis report as text (the JSON fields are documented in docs/gap-diagnosis.md)."""

from __future__ import annotations

from typing import Any


def _gap_line(label: str, gap: dict[str, Any]) -> str:
    channels = ", ".join(
        f"{name} {item['value']:.3f} [{item['interval'][0]:.3f}, {item['interval'][1]:.3f}]"
        for name, item in gap["per_channel"].items()
    )
    low, high = gap["interval"]
    return f"{label}: {gap['total']:.3f} [{low:.3f}, {high:.3f}]   per channel: {channels}"


def render_report(report: dict[str, Any]) -> str:
    """Readable summary: verdict, where, ranking, how far the gap shrinks, the sparse pointer."""
    runs = report["runs"]
    lines = [
        f"gap diagnosis of {report['data_kind']} data ({runs['total']} runs: "
        f"{runs['training']} to fit, {runs['withheld']} withheld to score; seed {report['seed']})",
    ]
    if report.get("split"):
        lines.append(f"split: {report['split']}")
    if report["verdict"] == "effect":
        magnitude = report["magnitude"]
        lines.append(
            f"effect: {report['effect']} (magnitude {magnitude['value']:.4g} {magnitude['unit']}), "
            f"indistinguishable set {{{', '.join(report['indistinguishable_set'])}}}, "
            f"confidence {report['confidence']:.2f}"
        )
        second = report.get("second_effect")
        if second:
            lines.append(
                f"second effect on top of it: {second['effect']} (magnitude "
                f"{second['magnitude']['value']:.4g} {second['magnitude']['unit']}, set "
                f"{{{', '.join(second['indistinguishable_set'])}}}, closes a further "
                f"{second['closure_beyond_first']:.3f} of the remaining gap)"
            )
    elif report["verdict"] == "unexplained":
        lines.append(
            "effect: unexplained (no candidate closes the gap; see the sparse-regression pointer)"
        )
    else:
        lines.append("effect: none (no candidate closes a significant part of the gap)")
    lines.append("where:")
    lines += [f"  {sentence}" for sentence in report["where"]["summary"]]
    lines.append("ranking (closure on withheld runs, 90 % interval; closure on training runs):")
    for entry in report["ranking"]:
        low, high = entry["closure_interval"]
        mark = "*" if entry["in_top_set"] else " "
        lines.append(
            f" {mark}{entry['name']:28s} {entry['withheld_closure']:+.3f} [{low:+.3f}, {high:+.3f}]"
            f"  training {entry['training_closure']:+.3f}  k = {entry['magnitude']:.4g} "
            f"{entry['unit']}  P(best) {entry['probability_best']:.2f}"
        )
    closure = report["closure"]
    lines.append(
        f"how far ({report['best_candidate']}, withheld runs, normalised RMS with 90 % intervals):"
    )
    lines.append("  " + _gap_line("before", report["gap_before"]))
    lines.append("  " + _gap_line("after ", report["gap_after"]))
    lines.append(
        f"  closure predicted from training {closure['predicted_from_training']:.3f}, "
        f"realised on withheld runs {closure['realised_withheld']:.3f}"
    )
    pointer = report["sparse_regression"]
    lines.append("sparse regression of the residual (pointer):")
    for target, fit in pointer.items():
        terms = ", ".join(f"{name} {value:+.3g}" for name, value in fit["terms"].items())
        lines.append(f"  {target}: {terms or '-'} (explains {100 * fit['explained']:.0f} %)")
    if report.get("written"):
        lines.append("written: " + ", ".join(report["written"]))
    return "\n".join(lines)
