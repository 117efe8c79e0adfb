"""Resuming a sweep that ends incomplete (``ornitail demo``, the benchmarks): how often, and when not."""

from types import SimpleNamespace

import pytest

from ornitail.acquisition.sweep import resumed_while_incomplete


def sweep_ending(*statuses: str):
    """A sweep whose calls end with ``statuses`` in turn; ``calls`` lists the ``resume`` flag of each."""
    remaining = iter(statuses)
    calls: list[bool] = []

    def sweep(resume: bool) -> SimpleNamespace:
        calls.append(resume)
        return SimpleNamespace(status=next(remaining))

    return sweep, calls


def test_an_incomplete_sweep_is_resumed_until_it_completes():
    sweep, calls = sweep_ending("incomplete", "incomplete", "completed")
    assert resumed_while_incomplete(sweep).status == "completed"
    assert calls == [False, True, True]


def test_resumes_stop_at_the_number_asked_and_the_last_result_says_incomplete():
    sweep, calls = sweep_ending(*["incomplete"] * 5)
    assert resumed_while_incomplete(sweep, resumes=2).status == "incomplete"
    assert calls == [False, True, True]


@pytest.mark.parametrize("status", ["completed", "aborted", "failed"])
def test_only_an_incomplete_sweep_is_resumed(status):
    sweep, calls = sweep_ending(status, "completed")
    assert resumed_while_incomplete(sweep).status == status
    assert calls == [False]
