"""A numeric continuous-time state-space model and its modes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Mode:
    """One eigenvalue (1/s) of A; for an oscillatory pair (imag > 0), damping ratio and natural
    frequency (rad/s); for a real pole, damping 1 (stable) or -1 (unstable) and |lambda|.
    """

    eigenvalue: complex
    damping_ratio: float
    natural_frequency_rad_s: float
    oscillatory: bool


@dataclass(frozen=True)
class NumericStateSpace:
    """dx/dt = A x + B u, y = C x + D u with numeric matrices (units of the model's signals)."""

    a_matrix: np.ndarray
    b_matrix: np.ndarray
    c_matrix: np.ndarray
    d_matrix: np.ndarray
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]

    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of A sorted by real part (1/s)."""
        values = np.linalg.eigvals(self.a_matrix)
        return values[np.lexsort((values.imag, values.real))]

    def modes(self) -> list[Mode]:
        """Oscillatory pairs (one entry, positive imaginary part) and real poles."""
        return modes_of(self.eigenvalues())


def modes_of(eigenvalues: np.ndarray, imaginary_tolerance: float = 1e-9) -> list[Mode]:
    """Mode list of a set of eigenvalues (see :class:`Mode`)."""
    modes = []
    for value in eigenvalues:
        if value.imag < -imaginary_tolerance:
            continue
        magnitude = abs(value)
        if value.imag > imaginary_tolerance:
            damping = -value.real / magnitude
            modes.append(Mode(complex(value), float(damping), float(magnitude), True))
        else:
            sign = 1.0 if value.real < 0 else -1.0
            modes.append(Mode(complex(value.real, 0.0), sign, float(magnitude), False))
    return modes
