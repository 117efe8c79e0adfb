import numpy as np

from ornitail.gui.ring_buffer import RingBuffer


def test_ring_keeps_the_newest_rows_in_time_order_across_the_wrap():
    ring = RingBuffer(5, 2)
    ring.extend(np.arange(6).reshape(3, 2))  # rows 0, 1, 2
    ring.extend(np.arange(6, 14).reshape(4, 2))  # rows 3..6: wraps, keeps 2..6
    assert len(ring) == 5
    np.testing.assert_array_equal(ring.latest()[:, 0], [4, 6, 8, 10, 12])
    np.testing.assert_array_equal(ring.latest(2)[:, 0], [10, 12])


def test_a_block_longer_than_the_ring_leaves_its_tail():
    ring = RingBuffer(3, 1)
    ring.extend(np.arange(10.0))
    np.testing.assert_array_equal(ring.latest()[:, 0], [7, 8, 9])
    ring.clear()
    assert len(ring) == 0 and ring.latest().shape == (0, 1)
