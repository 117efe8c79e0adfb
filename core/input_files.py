"""Bounded, checked access to the files and folders a user names.

Every file reader in ornitail goes through this module, so every file input is refused the same way,
before anything is read, when it

- does not exist (``file not found``), is a folder, or is not a regular file (a FIFO, a character
  device such as ``/dev/zero``, a socket: ``not a regular file``; such a file could block or never end);
- is larger than :data:`MAX_INPUT_FILE_BYTES` (256 MiB) for files read whole (TOML, CSV, JSON,
  ``.cal``, flight logs). HDF5 sample files and the SQLite catalog are read on demand and are only
  checked to be regular files;
- is not UTF-8 text where text is expected, or not valid TOML / JSON (nesting included).

Output folders and files are prepared before any work starts, so an unwritable ``--out`` or
``--data-root`` is one line naming the path, not a traceback after minutes of computing.
Every mistake is a :class:`~ornitail.core.errors.UserInputError` naming the path.
"""

from __future__ import annotations

import json
import math
import os
import stat
import tomllib
from pathlib import Path
from typing import Any

from ornitail.core.errors import UserInputError

MAX_INPUT_FILE_BYTES = 256 * 1024 * 1024
"""Largest file ornitail reads whole (bytes); larger inputs are refused before reading."""


def _size_text(size: int) -> str:
    return f"{size / 1024**2:.1f} MiB" if size >= 1024**2 else f"{size} bytes"


def check_input_file(path: str | Path, limit: int | None = MAX_INPUT_FILE_BYTES) -> Path:
    """Return ``path`` if it is an existing regular file of at most ``limit`` bytes.

    ``limit=None`` skips the size check (files read on demand, such as HDF5).
    """
    path = Path(path)
    try:
        status = path.stat()
    except FileNotFoundError:
        raise UserInputError(str(path), "file not found") from None
    except (OSError, ValueError) as error:
        reason = getattr(error, "strerror", None) or error
        raise UserInputError(str(path), f"cannot read file ({reason})") from None
    if stat.S_ISDIR(status.st_mode):
        raise UserInputError(str(path), "is a directory, not a file")
    if not stat.S_ISREG(status.st_mode):
        raise UserInputError(
            str(path), "not a regular file (a FIFO, device or socket cannot be read as input)"
        )
    if limit is not None and status.st_size > limit:
        raise UserInputError(
            str(path),
            f"file is {_size_text(status.st_size)}, larger than the {_size_text(limit)} "
            "ornitail reads (MAX_INPUT_FILE_BYTES)",
        )
    return path


def read_input_bytes(path: str | Path, limit: int = MAX_INPUT_FILE_BYTES) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes (never more are read)."""
    path = check_input_file(path, limit)
    try:
        with open(path, "rb") as stream:
            data = stream.read(limit + 1)
    except OSError as error:
        raise UserInputError(str(path), f"cannot read file ({error.strerror or error})") from None
    if len(data) > limit:
        raise UserInputError(str(path), f"file grew beyond {_size_text(limit)} while being read")
    return data


def decode_text(data: bytes, source: str) -> str:
    """``data`` as UTF-8 text (a byte-order mark is dropped); anything else is refused."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise UserInputError(
            source,
            f"not a UTF-8 text file (byte 0x{data[error.start]:02x} at offset {error.start})",
        ) from None


def read_input_text(path: str | Path, limit: int = MAX_INPUT_FILE_BYTES) -> str:
    """The UTF-8 text of a regular file of at most ``limit`` bytes."""
    return decode_text(read_input_bytes(path, limit), str(path))


def parse_toml_text(text: str, source: str) -> dict[str, Any]:
    """A parsed TOML document; invalid or too deeply nested TOML is refused naming ``source``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise UserInputError(source, f"not valid TOML ({error})") from None
    except RecursionError:
        raise UserInputError(source, "not valid TOML (nested too deeply)") from None


def read_toml_file(path: str | Path) -> dict[str, Any]:
    """Read and parse a TOML file (bounded, UTF-8)."""
    return parse_toml_text(read_input_text(path), str(path))


def _refuse_constant(name: str) -> float:
    raise ValueError(f"{name} is not a finite number")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text} is not a finite number")
    return value


def parse_json_text(text: str, source: str, *, finite: bool = True) -> Any:
    """A parsed JSON document; with ``finite``, NaN, Infinity and overflowing numbers are refused."""
    hooks: dict[str, Any] = (
        {"parse_constant": _refuse_constant, "parse_float": _finite_float} if finite else {}
    )
    try:
        return json.loads(text, **hooks)
    except json.JSONDecodeError as error:
        raise UserInputError(source, f"not valid JSON ({error})") from None
    except ValueError as error:
        raise UserInputError(source, f"not valid JSON: {error}") from None
    except RecursionError:
        raise UserInputError(source, "not valid JSON (nested too deeply)") from None


def read_json_file(path: str | Path, *, finite: bool = True) -> Any:
    """Read and parse a JSON file (bounded, UTF-8); see :func:`parse_json_text`."""
    return parse_json_text(read_input_text(path), str(path), finite=finite)


def _refuse_unwritable(path: Path, error: OSError) -> None:
    raise UserInputError(str(path), f"cannot write here ({error.strerror or error})") from None


def prepare_output_directory(path: str | Path) -> Path:
    """Create the folder ``path`` (and its parents) if needed and check it can be written."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UserInputError(str(path), "exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        _refuse_unwritable(path, error)
    if not os.access(path, os.W_OK | os.X_OK):
        raise UserInputError(str(path), "cannot write here (permission denied)")
    return path


def prepare_output_file(path: str | Path) -> Path:
    """Check a file can be written at ``path`` (its folder is created if needed)."""
    path = Path(path)
    if path.is_dir():
        raise UserInputError(str(path), "is a directory, not a file")
    prepare_output_directory(path.parent if str(path.parent) else Path("."))
    if path.exists() and not os.access(path, os.W_OK):
        raise UserInputError(str(path), "cannot write here (permission denied)")
    return path


def read_csv_table(path: str | Path, nrows: int | None = None) -> Any:
    """A CSV file (bounded, UTF-8) as a pandas DataFrame; unreadable CSV is refused naming the file."""
    import io

    import pandas as pd

    text = read_input_text(path)
    try:
        return pd.read_csv(io.StringIO(text), nrows=nrows)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as error:
        message = " ".join(str(error).split())
        raise UserInputError(str(path), f"not a readable CSV file ({message})") from None
