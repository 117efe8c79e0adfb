"""Pooling the folds' validation scores (``[baseline].validation = "all-folds"``) on numbers
worked by hand."""

import numpy as np
import pytest

from ornitail.gap.pooled_validation import FoldScores, pool_folds
from ornitail.gap.ranking import CandidateEvidence


def _fold(candidate_sse, start_sse, null_after, null_start, magnitude, correlation):
    evidence = [
        CandidateEvidence("a", magnitude, "s", 1, np.array(candidate_sse), 3.0, correlation, (0, 1))
    ]
    return FoldScores(
        evidence, np.array(start_sse), 10.0, 0.5, 100, np.array(null_after), np.array(null_start)
    )


def test_pooled_scores_join_runs_sum_energies_and_keep_the_first_folds_fit():
    first = _fold([1.0, 2.0], [4.0, 4.0], [[6.0, 1.0], [7.0, 2.0]], [4.0, 4.0], 0.1, 0.2)
    second = _fold([3.0], [9.0], [[1.0], [8.0]], [9.0], 0.3, 0.4)
    pooled = pool_folds([first, second])
    (candidate,) = pooled.evidence
    np.testing.assert_array_equal(candidate.heldout_sse, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(pooled.start_heldout_sse, [4.0, 4.0, 9.0])
    assert (candidate.magnitude, candidate.bounds) == (0.1, (0, 1))  # the first fold's fit
    assert candidate.training_sse == 6.0 and candidate.input_correlation == pytest.approx(0.3)
    assert (pooled.start_training_sse, pooled.training_count) == (20.0, 200)
    # each null direction's per-run energies are joined over the folds, as a candidate's are
    np.testing.assert_array_equal(pooled.null_after_sse, [[6.0, 1.0, 1.0], [7.0, 2.0, 8.0]])
    np.testing.assert_array_equal(pooled.null_start_sse, [4.0, 4.0, 9.0])
