"""Typed reading of one table of a TOML file, every mistake naming the file, table and key.

Rig files, sweep plans, model files, gap baselines, campaign files and hot-wire law files (TOML or JSON) read
their tables through :class:`TomlTable`, so a user sees the same kind of one-line message for the same kind of
mistake, e.g.
``rig.toml: [limits].pitch_deg: 'x' must be a finite number`` (``campaign.toml: seed: -1 must be >= 0`` for a key
at a file's top level).
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


def _place(path: Path, section: str, key: str = "") -> str:
    """``"<file>: [<section>].<key>"`` (``"<file>: <key>"`` at the top level); without a key, the table."""
    if not section:
        return f"{path}: {key}" if key else str(path)
    return f"{path}: [{section}].{key}" if key else f"{path}: [{section}]"


class TomlTable:
    """Typed access to one table of a TOML file.

    Parameters
    ----------
    path : pathlib.Path
        The file (named in every message; relative file fields resolve against its folder).
    section : str
        The table's name, e.g. ``"limits"``, ``"balance.can"`` or ``"configuration[2].log[1]"``; ``""`` for the
        file's top level, whose keys are named without brackets.
    table : object
        The parsed table (of a TOML or a JSON file); anything but a dict is refused.
    allowed_keys : iterable of str or None
        Keys the table may have; any other key is refused (a typo must not drop a limit). None for a table whose
        keys are names the file chooses (a model file's ``[constants]``): any key is taken.
    """

    def __init__(
        self, path: Path | str, section: str, table: Any, allowed_keys: Iterable[str] | None
    ) -> None:
        self.path = Path(path)
        self.section = section
        if not isinstance(table, dict):
            problem = (
                "must be a table (a [section] header)"
                if section
                else "top level must be a table of keys"
            )
            raise UserInputError(self.where(), problem)
        self.table = table
        if allowed_keys is None:
            return
        allowed = sorted(set(allowed_keys))
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            raise UserInputError(
                self.where(unknown[0]), f"unknown key; allowed keys are {', '.join(allowed)}"
            )

    def where(self, key: str = "") -> str:
        """The place of ``key`` named in messages, e.g. ``"rig.toml: [limits].pitch_deg"`` (without a key, the
        table itself)."""
        return _place(self.path, self.section, key)

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

    def _child(self, key: str) -> str:
        """The section name of the table under ``key``."""
        return f"{self.section}.{key}" if self.section else key

    def text(
        self,
        key: str,
        default: Any = REQUIRED,
        choices: Iterable[str] = (),
        *,
        empty: bool = False,
    ) -> Any:
        """A non-empty string (any string with ``empty``), one of ``choices`` when given (None for an absent key
        whose default is None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        choices = tuple(choices)
        if choices and value not in choices:
            raise UserInputError(self.where(key), f"{value!r} must be one of {', '.join(choices)}")
        if not isinstance(value, str) or not (empty or value.strip()):
            kind = "string" if empty else "non-empty string"
            raise UserInputError(self.where(key), f"{value!r} must be a {kind}")
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

    def texts(self, key: str, default: Any = REQUIRED, *, at_least: int = 0) -> Any:
        """A list of non-empty strings, at least ``at_least`` of them (None for an absent key whose default is
        None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        if (
            not isinstance(value, list)
            or len(value) < at_least
            or not all(isinstance(item, str) and item.strip() for item in value)
        ):
            how_many = f"{at_least} or more " if at_least else ""
            raise UserInputError(
                self.where(key), f"{value!r} must be a list of {how_many}non-empty strings"
            )
        return list(value)

    def numbers(
        self, key: str, count: int, meaning: str, default: Any = REQUIRED, *, or_more: bool = False
    ) -> Any:
        """A list of exactly ``count`` finite numbers (at least ``count`` with ``or_more``); ``meaning`` describes
        them in the message (None for an absent key whose default is None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        if (
            not isinstance(value, list)
            or (len(value) < count if or_more else len(value) != count)
            or not all(is_finite_number(v) for v in value)
        ):
            how_many = f"{count} or more" if or_more else f"{count}"
            raise UserInputError(
                self.where(key), f"{value!r} must be {how_many} finite numbers {meaning}"
            )
        return [float(v) for v in value]

    def interval(
        self, key: str, default: Any = REQUIRED, bounds: tuple[str, str] = ("minimum", "maximum")
    ) -> Any:
        """``[low, high]`` with low below high, ``bounds`` naming the two in messages (None for an absent key
        whose default is None)."""
        if self._absent(key, default):
            return None
        low_name, high_name = bounds
        low, high = self.numbers(key, 2, f"[{low_name}, {high_name}]", default)
        if low >= high:
            raise UserInputError(
                self.where(key), f"{low_name} {low:g} must be below {high_name} {high:g}"
            )
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

    def sub_table(
        self, key: str, allowed_keys: Iterable[str] | None, default: Any = REQUIRED
    ) -> TomlTable | None:
        """The table under ``key`` (section ``<section>.<key>``), checked against ``allowed_keys`` (any key when
        None; None for an absent key whose default is None)."""
        if self._absent(key, default):
            return None
        return TomlTable(self.path, self._child(key), self.get(key, default), allowed_keys)

    def tables(
        self,
        key: str,
        allowed_keys: Iterable[str],
        default: Any = REQUIRED,
        *,
        text_key: str | None = None,
    ) -> Any:
        """A list of tables (``[[key]]`` headers or an inline list), the n-th (from 1) read as section
        ``<section>.<key>[n]``; with ``text_key`` a string item stands for the table ``{<text_key> = item}``
        (None for an absent key whose default is None)."""
        if self._absent(key, default):
            return None
        value = self.get(key, default)
        if not isinstance(value, list):
            raise UserInputError(self.where(key), f"{value!r} must be a list of tables")
        allowed = tuple(allowed_keys)
        readers = []
        for number, item in enumerate(value, start=1):
            section = f"{self._child(key)}[{number}]"
            if text_key is not None and isinstance(item, str):
                item = {text_key: item}
            if not isinstance(item, dict):
                kinds = "a table" if text_key is None else f"a table or a string ({text_key})"
                raise UserInputError(_place(self.path, section), f"{item!r} must be {kinds}")
            readers.append(TomlTable(self.path, section, item, allowed))
        return readers
