"""Benchmark: a simulated campaign configuration's fits with the Fisher information as one matrix product, against
the three-operand ``einsum`` they used.

Equation error and output error sum S[k, c, i] w[c] S[k, c, j] over samples k and channels c at every iteration
(:mod:`ornitail.flight.fisher_information`). The baseline, measured in the same process on the same manoeuvres,
puts back the ``einsum`` forms (numpy's ``einsum`` contracts three operands in C loops, without BLAS). One
configuration (S1 at x_h = 98 mm, 20 simulated doublets, seed 11, as ``ornitail flight campaign --simulate``) is
flown once; both variants analyse it ``--repeats`` times, alternating, and the medians are compared. Printed: both
medians and their ratio (one JSON object with ``--json``).

Usage::

    .venv/bin/python benchmarks/fisher_information.py
    .venv/bin/python benchmarks/fisher_information.py --repeats 5 --json

Exit code 0 when the matrix product is faster than the baseline, 1 otherwise, 2 for a bad option.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
from benchmark_timing import alternating_medians_s, repeats_and_json_options

from ornitail.app.cli_output import emit
from ornitail.flight import equation_error, output_error
from ornitail.flight.campaign import analyse_configuration, configuration_data
from ornitail.flight.campaign_file import CampaignSpec, configuration_from_label
from ornitail.flight.model_file import load_model

SEED = 11


def einsum_information(sensitivities: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The baseline Fisher information."""
    return np.einsum("kci,c,kcj->ij", sensitivities, weights, sensitivities)


def einsum_score(
    sensitivities: np.ndarray, weights: np.ndarray, residuals: np.ndarray
) -> np.ndarray:
    """The baseline score."""
    return np.einsum("kci,c,kc->i", sensitivities, weights, residuals)


def einsum_regressors(matrix_derivatives: np.ndarray, signals: np.ndarray) -> np.ndarray:
    """The baseline equation-error regressors."""
    return np.einsum("jab,kb->kaj", matrix_derivatives, signals)


@contextmanager
def einsum_baseline() -> Iterator[None]:
    """The fits as they were: the ``einsum`` forms in place of the matrix products."""
    replaced = [
        (equation_error, "fisher_information", einsum_information),
        (equation_error, "weighted_score", einsum_score),
        (equation_error, "_regressors", einsum_regressors),
        (output_error, "fisher_information", einsum_information),
    ]
    saved = [(module, name, getattr(module, name)) for module, name, _ in replaced]
    for module, name, function in replaced:
        setattr(module, name, function)
    try:
        yield
    finally:
        for module, name, function in saved:
            setattr(module, name, function)


def main(argv: list[str] | None = None) -> int:
    arguments = repeats_and_json_options("fisher_information", __doc__.splitlines()[0], argv)
    if arguments is None:
        return 2
    campaign = CampaignSpec(
        (configuration_from_label("S1@98", "benchmark", simulated_manoeuvres=20),), seed=SEED
    )
    (configuration,) = campaign.configurations
    spec = load_model(campaign.model)
    data = configuration_data(configuration, SEED, campaign.glitch_rule)

    def analyse() -> object:
        return analyse_configuration(configuration, data, spec, SEED)

    analyse()  # imports and CasADi functions warm
    matrix_product_s, einsum_s = alternating_medians_s(analyse, einsum_baseline, arguments.repeats)
    record = {
        "repeats": arguments.repeats,
        "analysis_matrix_product_s": matrix_product_s,
        "analysis_einsum_s": einsum_s,
    }
    record["einsum_over_matrix_product"] = (
        record["analysis_einsum_s"] / record["analysis_matrix_product_s"]
    )
    emit(
        record,
        arguments.json,
        lambda r: (
            f"fitting 20 simulated manoeuvres of S1: {r['analysis_matrix_product_s']:.2f} s with the Fisher "
            f"information as a matrix product, {r['analysis_einsum_s']:.2f} s with einsum (baseline): "
            f"{r['einsum_over_matrix_product']:.2f}x"
        ),
    )
    return 0 if record["analysis_matrix_product_s"] < record["analysis_einsum_s"] else 1


if __name__ == "__main__":
    sys.exit(main())
