"""Typed reading of one table of a TOML file, every mistake naming the file, table and key.

Rig files, sweep plans and model files all read their tables through :class:`TomlTable`, so a user sees the same
kind of one-line message for the same kind of mistake, e.g. ``rig.toml: [limits].pitch_deg: 'x' must be a finite
number``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import check_input_file


class _Required:
    """The default of a key that must be present (``None`` is a default like any other)."""

    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()
"""Default of :class:`TomlTable`'s getters: the key must be present. Pass ``default=None`` for an optional key
that reads as None when absent."""


def is_finite_number(value: Any) -> bool:
    """True for an int or float (not a bool) that is finite."""
    return not isinstance(value, bool) and isinstance(value, int | float) and math.isfinite(value)


class TomlTable:
    """Typed access to one table of a TOML file.

    Parameters
    ----------
    path : pathlib.Path
        The file (named in every message; relative file fields resolve against its folder).
    section : str
        The table's name, e.g. ``"limits"`` or ``"balance.can"``.
    table : object
        The parsed table; anything but a dict is refused.
    allowed_keys : iterable of str
        Keys the table may have; any other key is refused (a typo must not drop a limit).
    """

    def __init__(
        self, path: Path | str, section: str, table: Any, allowed_keys: Iterable[str]
    ) -> None:
        self.path = Path(path)
        self.section = section
        if not isinstance(table, dict):
            raise UserInputError(f"{path}: [{section}]", "must be a table (a [section] header)")
        self.table = table
        allowed = sorted(allowed_keys)
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            raise UserInputError(
                f"{path}: [{section}].{unknown[0]}",
                f"unknown key; allowed keys are {', '.join(allowed)}",
            )

    def where(self, key: str) -> str:
        """``"<file>: [<section>].<key>"``, the place named in messages."""
        return f"{self.path}: [{self.section}].{key}"

    def get(self, key: str, default: Any = REQUIRED) -> Any:
        """The raw value; a missing key is refused unless a default (None included) is given."""
        if key not in self.table:
            if default is REQUIRED:
                raise UserInputError(self.where(key), "required key is missing")
            return default
        return self.table[key]

    def _absent(self, key: str, default: Any) -> bool:
        """True when ``key`` is missing and its default is None: an optional key a getter returns as None."""
        return key not in self.table and default is None

    def text(self, key: str, default: Any = REQUIRED, choices: Iterable[str] = ()) -> Any:
        """A non-empty string, one of ``choices`` when given (None for an absent key whose default is None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        if not isinstance(value, str) or not value.strip():
            raise UserInputError(self.where(key), f"{value!r} must be a non-empty string")
        choices = tuple(choices)
        if choices and value not in choices:
            raise UserInputError(self.where(key), f"{value!r} must be one of {', '.join(choices)}")
        return value

    def boolean(self, key: str, default: Any = REQUIRED) -> Any:
        """``true`` or ``false`` (None for an absent key whose default is None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        if not isinstance(value, bool):
            raise UserInputError(self.where(key), f"{value!r} must be true or false")
        return value

    def number(
        self,
        key: str,
        default: Any = REQUIRED,
        *,
        minimum: float | None = None,
        positive: bool = False,
    ) -> Any:
        """A finite number, optionally > 0 or >= ``minimum`` (None for an absent key whose default is None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        if not is_finite_number(value):
            raise UserInputError(self.where(key), f"{value!r} must be a finite number")
        if positive and value <= 0:
            raise UserInputError(self.where(key), f"{value!r} must be > 0")
        if minimum is not None and value < minimum:
            raise UserInputError(self.where(key), f"{value!r} must be >= {minimum:g}")
        return float(value)

    def integer(
        self, key: str, default: Any = REQUIRED, *, minimum: int = 0, maximum: int | None = None
    ) -> Any:
        """A whole number in ``minimum..maximum`` (None for an absent key whose default is None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise UserInputError(self.where(key), f"{value!r} must be a whole number")
        if value < minimum:
            raise UserInputError(self.where(key), f"{value} must be >= {minimum}")
        if maximum is not None and value > maximum:
            raise UserInputError(self.where(key), f"{value} must be in {minimum}..{maximum}")
        return value

    def numbers(self, key: str, count: int, meaning: str, default: Any = REQUIRED) -> Any:
        """A list of exactly ``count`` finite numbers; ``meaning`` describes them in the message (None for an
        absent key whose default is None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        if (
            not isinstance(value, list)
            or len(value) != count
            or not all(is_finite_number(v) for v in value)
        ):
            raise UserInputError(
                self.where(key), f"{value!r} must be {count} finite numbers {meaning}"
            )
        return [float(v) for v in value]

    def interval(self, key: str) -> tuple[float, float]:
        """``[minimum, maximum]`` with minimum below maximum."""
        low, high = self.numbers(key, 2, "[minimum, maximum]")
        if low >= high:
            raise UserInputError(self.where(key), f"minimum {low:g} must be below maximum {high:g}")
        return low, high

    def file(self, key: str) -> Path:
        """An existing regular file of readable size, relative to the TOML file's folder."""
        relative = self.text(key)
        resolved = (self.path.parent / relative).resolve()
        if not resolved.exists():
            raise UserInputError(
                self.where(key), f"file {relative!r} not found (looked for {resolved})"
            )
        try:
            check_input_file(resolved)
        except UserInputError as error:
            raise UserInputError(self.where(key), f"{relative!r}: {error.problem}") from None
        return resolved
