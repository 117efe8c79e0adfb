"""Cyclic garbage collected in the GUI thread only, while a window is open.

CPython's cyclic collector runs in whichever thread allocates when a generation's count passes its threshold.
Beside the window, threads allocate all the time (the balance pump, the instrument poller, a sweep runner, the
catalog sync and, on the simulated rig, the instruments themselves), so a reference cycle that holds a Qt object
(a widget, a timer, pytest-qt's wait helpers in the tests) is freed in one of them: the object's C++ destructor
then runs outside the thread that owns it, which Qt does not allow, and it can wait on a lock the GUI thread
holds while the GUI thread waits for the GIL. pyqtgraph ships a collector for the same reason
(``pyqtgraph.util.garbage_collector``). One CI run of the window test hung in a way this explains: the GUI
thread entered a Qt slot and never got the GIL, while the one busy thread, a simulated instrument's, was
allocating in numpy. Python stacks cannot show a C++ destructor, and the hang did not come back in 25 repeats
here, so the cause is likely, not proven.

While any window is open automatic collection is off and a timer collects, in the GUI thread, the oldest
generation whose count has passed its threshold (as the automatic collector would have).
"""

from __future__ import annotations

import gc

from PySide6 import QtCore

COLLECTION_INTERVAL_MS = 200
"""How often the GUI thread looks at the collector's counts, ms (the window redraws every ~33 ms)."""

_open_collectors = 0
_automatic_before = True


class MainThreadGarbageCollector:
    """Turns automatic collection off while started and collects on a timer owned by ``parent``."""

    def __init__(self, parent: QtCore.QObject) -> None:
        self._timer = QtCore.QTimer(parent)
        self._timer.timeout.connect(collect_due_generations)
        self._started = False

    def start(self) -> None:
        """Collect in this (the GUI) thread from now on; the first collector started turns automatic collection
        off."""
        global _open_collectors, _automatic_before
        if self._started:
            return
        if _open_collectors == 0:
            _automatic_before = gc.isenabled()
            gc.disable()
        _open_collectors += 1
        self._started = True
        self._timer.start(COLLECTION_INTERVAL_MS)

    def stop(self) -> None:
        """Stop the timer; the last collector stopped turns automatic collection back on if it was on."""
        global _open_collectors
        if not self._started:
            return
        self._timer.stop()
        self._started = False
        _open_collectors -= 1
        if _open_collectors == 0 and _automatic_before:
            gc.enable()


def collect_due_generations() -> int:
    """Collect the oldest generation whose count, and every younger one's, has passed its threshold (what the
    automatic collector does at an allocation); return the number of unreachable objects found."""
    counts, thresholds = gc.get_count(), gc.get_threshold()
    due = -1
    for generation in range(3):
        if counts[generation] <= thresholds[generation]:
            break
        due = generation
    return gc.collect(due) if due >= 0 else 0
