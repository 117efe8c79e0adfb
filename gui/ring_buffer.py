"""A fixed-size ring buffer of rows for live plots: appending never allocates, reading gives time order."""

from __future__ import annotations

import numpy as np


class RingBuffer:
    """The newest ``capacity`` rows of ``columns`` float values.

    Parameters
    ----------
    capacity : int
        Rows kept; older rows are overwritten.
    columns : int
        Values per row.
    """

    def __init__(self, capacity: int, columns: int) -> None:
        if capacity < 1 or columns < 1:
            raise ValueError("capacity and columns must be at least 1")
        self._data = np.zeros((capacity, columns))
        self._next = 0
        self._count = 0

    @property
    def capacity(self) -> int:
        """Rows the buffer holds at most."""
        return self._data.shape[0]

    def __len__(self) -> int:
        return self._count

    def extend(self, rows: np.ndarray) -> None:
        """Append rows (shape ``(n, columns)``), oldest first."""
        rows = np.asarray(rows, dtype=float).reshape(-1, self._data.shape[1])
        capacity = self.capacity
        if len(rows) >= capacity:
            self._data[:] = rows[-capacity:]
            self._next, self._count = 0, capacity
            return
        end = self._next + len(rows)
        if end <= capacity:
            self._data[self._next : end] = rows
        else:
            split = capacity - self._next
            self._data[self._next :] = rows[:split]
            self._data[: end - capacity] = rows[split:]
        self._next = end % capacity
        self._count = min(capacity, self._count + len(rows))

    def latest(self, rows: int | None = None) -> np.ndarray:
        """A copy of the newest ``rows`` rows (all by default), oldest first."""
        count = self._count if rows is None else min(rows, self._count)
        indices = (self._next - count + np.arange(count)) % self.capacity
        return self._data[indices]

    def clear(self) -> None:
        """Forget every row."""
        self._next = self._count = 0
