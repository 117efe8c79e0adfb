"""CRC-16/CCITT-FALSE, for single messages and vectorised over many frames at once.

Parameters of the CRC (the "CRC-16/CCITT-FALSE" entry of the usual CRC catalogues): polynomial
0x1021, initial value 0xFFFF, no input or output reflection, no final XOR. Check value: the CRC of
the nine ASCII bytes ``b"123456789"`` is ``0x29B1``.
"""

from __future__ import annotations

import numpy as np

CRC16_POLYNOMIAL = 0x1021
CRC16_INITIAL_VALUE = 0xFFFF
CRC16_CHECK_VALUE = 0x29B1  # CRC of b"123456789"


def _build_table() -> np.ndarray:
    table = np.zeros(256, dtype=np.uint16)
    for byte in range(256):
        register = byte << 8
        for _ in range(8):
            register = (register << 1) ^ CRC16_POLYNOMIAL if register & 0x8000 else register << 1
        table[byte] = register & 0xFFFF
    return table


CRC16_TABLE = _build_table()
_TABLE_AS_INT = [int(value) for value in CRC16_TABLE]


def _build_word_table() -> np.ndarray:
    """CRC register after clocking in 16 zero bits from every 16-bit state (two bytes per step)."""
    state = np.arange(65536, dtype=np.uint32)
    for _ in range(2):
        state = ((state << 8) & 0xFFFF) ^ CRC16_TABLE[(state >> 8) & 0xFF]
    return state.astype(np.uint16)


CRC16_WORD_TABLE = _build_word_table()


def crc16_ccitt_false(data: bytes) -> int:
    """Return the CRC-16/CCITT-FALSE of ``data`` as an int in [0, 65535]."""
    register = CRC16_INITIAL_VALUE
    for byte in data:
        register = ((register << 8) & 0xFFFF) ^ _TABLE_AS_INT[((register >> 8) ^ byte) & 0xFF]
    return register


def crc16_ccitt_false_rows(rows: np.ndarray) -> np.ndarray:
    """Return the CRC of every row of a (m, k) uint8 array as a (m,) uint16 array.

    The loop runs over the columns two bytes at a time (a 65536-entry table), each step vectorised
    over all m rows, so the cost per frame is a few numpy element operations.
    """
    rows = np.asarray(rows, dtype=np.uint8)
    register = np.full(rows.shape[0], CRC16_INITIAL_VALUE, dtype=np.uint16)
    n_pairs = rows.shape[1] // 2
    if n_pairs:
        words = (rows[:, 0 : 2 * n_pairs : 2].astype(np.uint16) << 8) | rows[:, 1 : 2 * n_pairs : 2]
        for column in range(n_pairs):
            register = CRC16_WORD_TABLE[register ^ words[:, column]]
    if rows.shape[1] % 2:
        register = (register << 8) ^ CRC16_TABLE[(register >> 8) ^ rows[:, -1]]
    return register
