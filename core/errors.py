"""The one error type for user mistakes.

Every mistake in something a user supplies (a file, a field in it, a command-line value) is raised as
:class:`UserInputError`, which names where the mistake is and what is wrong. The CLI turns it into a
one-line message on stderr and exit code 2; the GUI shows it in a message box. Anything else that
escapes is a bug in ornitail and is allowed to show a traceback.
"""

from __future__ import annotations

import math
from collections.abc import Iterable


class UserInputError(Exception):
    """A mistake in user-supplied input.

    Parameters
    ----------
    where : str
        The file, field or option the mistake is in, e.g. ``"rig.toml: [balance].calibration"``.
    problem : str
        What is wrong, in words a tunnel engineer understands, e.g. ``"file not found"``.
    remedy_parameter : str, optional
        The parameter of the raising function that would accept the input (``"keep_saturated"``); a front end
        that has an option for it names the option after the message.
    """

    def __init__(self, where: str, problem: str, remedy_parameter: str | None = None) -> None:
        super().__init__(f"{where}: {problem}")
        self.where = where
        self.problem = problem
        self.remedy_parameter = remedy_parameter


def require_finite(where: str, values: float | Iterable[float]) -> None:
    """Raise :class:`UserInputError` if any of ``values`` is NaN or infinite."""
    items = [values] if isinstance(values, int | float) else list(values)
    for index, value in enumerate(items):
        if not math.isfinite(float(value)):
            suffix = "" if len(items) == 1 else f" (item {index + 1})"
            raise UserInputError(where, f"value {value!r}{suffix} is not a finite number")
