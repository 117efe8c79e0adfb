"""Cyclic garbage is collected in the GUI thread while a window is open, never in the threads beside it."""

import gc
import threading

from PySide6 import QtCore

from ornitail.gui.main_thread_collector import MainThreadGarbageCollector, collect_due_generations


class _Cycle:
    """An object in a reference cycle that records the thread its finaliser ran in."""

    finalised_in: list[str] = []

    def __init__(self) -> None:
        self.itself = self

    def __del__(self) -> None:
        _Cycle.finalised_in.append(threading.current_thread().name)


def _make_cycles_and_allocate_in_a_thread() -> list:
    """Twenty cycles made in a worker, then (kept) allocations far past generation 0's threshold: automatic
    collection would run there, in the worker."""
    kept = []

    def work() -> None:
        for _ in range(20):
            _Cycle()
        kept.extend([] for _ in range(50 * gc.get_threshold()[0]))

    thread = threading.Thread(target=work, name="allocating-worker")
    thread.start()
    thread.join()
    return kept


def test_cycles_made_in_a_worker_are_freed_in_the_gui_thread_and_automatic_collection_comes_back(
    qtbot,
):
    automatic_before = gc.isenabled()
    gc.enable()  # as a process starts; whatever an earlier test left
    owner = QtCore.QObject()
    first, second = MainThreadGarbageCollector(owner), MainThreadGarbageCollector(owner)
    first.start()
    second.start()
    try:
        assert not gc.isenabled()
        _Cycle.finalised_in.clear()
        kept = _make_cycles_and_allocate_in_a_thread()
        assert _Cycle.finalised_in == []  # nothing collected in the worker
        # the timer's collection, in this thread
        qtbot.waitUntil(lambda: len(_Cycle.finalised_in) == 20, timeout=10_000)
        assert set(_Cycle.finalised_in) == {threading.current_thread().name}
        del kept
        first.stop()
        assert not gc.isenabled()  # another window is still open
    finally:
        first.stop()
        second.stop()
        enabled_after = gc.isenabled()
        if not automatic_before:
            gc.disable()
    assert enabled_after


def test_only_generations_past_their_threshold_are_collected():
    automatic_before = gc.isenabled()
    gc.collect()
    generation_0_threshold = gc.get_threshold()[0]
    gc.disable()
    try:
        assert gc.get_count()[0] <= generation_0_threshold
        _Cycle.finalised_in.clear()
        _Cycle()
        assert collect_due_generations() == 0 and _Cycle.finalised_in == []  # below the threshold
        kept = [[] for _ in range(2 * generation_0_threshold)]
        assert collect_due_generations() >= 1 and len(_Cycle.finalised_in) == 1
        del kept
    finally:
        if automatic_before:
            gc.enable()
