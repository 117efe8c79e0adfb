"""Sample-counter gaps: where the driver's counter does not advance by exactly one.

A driver numbers its samples with a uint32 or uint64 counter that wraps modulo 2**bits. A forward
jump of k means k - 1 samples were lost before reaching the recorder (link loss, device overrun or a
block dropped by a full recorder queue); a zero or backward step means the device restarted or
repeated a sample.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np


@dataclass
class CounterGap:
    """One counter discontinuity.

    Attributes
    ----------
    row_index : int
        Row in ``/samples/raw`` of the first sample after the discontinuity.
    counter_before, counter_after : int
        Counter of the row before and of ``row_index``.
    missing_samples : int
        Samples the counter skipped (0 for a backward step or a repeat).
    kind : str
        ``"jump"`` (forward, samples missing) or ``"backward"`` (restart or repeat).
    """

    row_index: int
    counter_before: int
    counter_after: int
    missing_samples: int
    kind: str

    def to_json_dict(self) -> dict[str, Any]:
        """Return the gap as a JSON-serialisable dictionary."""
        return asdict(self)


def find_counter_gaps(
    counters: np.ndarray, previous_counter: int | None = None, first_row_index: int = 0
) -> list[CounterGap]:
    """Find where ``counters`` fails to advance by one (modulo its dtype's range).

    Parameters
    ----------
    counters : numpy.ndarray
        1-D unsigned counters (uint32 or uint64) of consecutive rows.
    previous_counter : int or None
        Counter of the row just before ``counters`` (from the previous block), if any.
    first_row_index : int
        Row index of ``counters[0]`` in the whole recording.
    """
    counters = np.asarray(counters)
    if previous_counter is not None:
        chain = np.concatenate([np.array([previous_counter], dtype=counters.dtype), counters])
        row_offset = first_row_index - 1
    else:
        chain = counters
        row_offset = first_row_index
    if chain.size < 2:
        return []
    steps = np.diff(chain)  # unsigned arithmetic: wraps modulo 2**bits like the counter itself
    gap_positions = np.flatnonzero(steps != 1)
    half_range = np.iinfo(chain.dtype).max // 2
    gaps = []
    for position in gap_positions:
        step = int(steps[position])
        is_forward = 0 < step <= half_range
        gaps.append(
            CounterGap(
                row_index=int(row_offset + position + 1),
                counter_before=int(chain[position]),
                counter_after=int(chain[position + 1]),
                missing_samples=step - 1 if is_forward else 0,
                kind="jump" if is_forward else "backward",
            )
        )
    return gaps
