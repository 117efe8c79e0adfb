"""Crash-safe small files of a run directory: atomic JSON, fsynced journal, liveness lock."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import IO, Any

from ornitail.acquisition.recording_layout import (
    JOURNAL_FILE_NAME,
    RUN_LOCK_FILE_NAME,
    SetPointRecord,
)
from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_input_text
from ornitail.core.input_files import read_json_file as read_json_document

try:
    import fcntl
except ImportError:  # Windows
    fcntl = None
    import msvcrt


def _fsync_directory(directory: Path) -> None:
    if os.name == "nt":
        return
    descriptor = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def write_json_atomically(path: Path, values: dict[str, Any]) -> None:
    """Write ``values`` to ``path`` so a reader sees the old or the new file, never a torn one.

    The text goes to a temporary file in the same directory, is fsynced, replaces ``path`` with
    ``os.replace`` and the directory is fsynced so the rename survives a power cut.
    """
    path = Path(path)
    temporary_path = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(temporary_path, "w", encoding="utf-8") as stream:
        json.dump(values, stream, indent=2, allow_nan=False)
        stream.write("\n")
        stream.flush()
        os.fsync(stream.fileno())
    os.replace(temporary_path, path)
    _fsync_directory(path.parent)


def read_json_file(path: Path) -> dict[str, Any]:
    """Read a JSON object; a missing or malformed file is a :class:`UserInputError`."""
    values = read_json_document(path)  # bounded, UTF-8, finite numbers (core/input_files.py)
    if not isinstance(values, dict):
        raise UserInputError(str(path), "top level is not a JSON object")
    return values


def append_journal_line(run_directory: Path, record: SetPointRecord) -> None:
    """Append one set point to the run's journal and fsync it before returning."""
    line = json.dumps(record.to_json_dict(), allow_nan=False)
    with open(Path(run_directory) / JOURNAL_FILE_NAME, "a", encoding="utf-8") as stream:
        stream.write(line + "\n")
        stream.flush()
        os.fsync(stream.fileno())


def read_journal(run_directory: Path) -> list[SetPointRecord]:
    """Read the completed set points of a run, in the order they were completed.

    A last line cut short by a crash (no newline, not valid JSON) is ignored; a malformed line
    before the last one is a :class:`UserInputError` naming the line. A missing journal means no
    set point was completed.
    """
    path = Path(run_directory) / JOURNAL_FILE_NAME
    if not path.exists() and not path.is_symlink():
        return []
    text = read_input_text(path)
    lines = text.split("\n")
    records = []
    for line_number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        is_last_line = line_number == len(lines)
        try:
            records.append(SetPointRecord.from_json_dict(json.loads(line)))
        except (json.JSONDecodeError, TypeError, KeyError, ValueError, AttributeError) as error:
            if is_last_line:  # torn final write of a crashed process: the set point was not done
                break
            raise UserInputError(
                f"{path}: line {line_number}", f"not a set-point record ({error})"
            ) from None
    return records


class RunLock:
    """An exclusive OS lock on ``run.lock`` held while the recording process lives.

    The kernel drops the lock when the process dies, even on ``kill -9``, so
    :func:`run_is_live` tells a live run from a crashed one without trusting process ids.
    """

    def __init__(self, run_directory: Path) -> None:
        self._path = Path(run_directory) / RUN_LOCK_FILE_NAME
        self._stream: IO[str] | None = None

    def acquire(self) -> None:
        """Take the lock; raise ``RuntimeError`` if another process holds it."""
        stream = open(self._path, "a+")  # noqa: SIM115 - held open for the run's lifetime
        if not _try_lock(stream):
            stream.close()
            raise RuntimeError(f"{self._path} is held by another recording process")
        self._stream = stream

    def release(self) -> None:
        """Release the lock (closing the file releases it)."""
        if self._stream is not None:
            self._stream.close()
            self._stream = None


def _try_lock(stream: IO[str]) -> bool:
    try:
        if fcntl is not None:
            fcntl.flock(stream.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        else:
            stream.seek(0)
            msvcrt.locking(stream.fileno(), msvcrt.LK_NBLCK, 1)
    except OSError:
        return False
    return True


def run_is_live(run_directory: Path) -> bool:
    """Return True if a process still holds the run's lock (the run is being recorded now)."""
    path = Path(run_directory) / RUN_LOCK_FILE_NAME
    if not path.exists():
        return False
    with open(path, "a+") as stream:
        return not _try_lock(stream)
