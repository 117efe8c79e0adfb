"""Calibration files that travel with a run: copied into the run folder at start, found again by content hash.

The recorder copies every file of ``run.json``'s ``calibration_files`` (balance calibration, tunnel table, ...) into
``<run>/calibration/`` and records its path, its copy and its content hash (``"sha256:<hex>"``). Processing asks
:func:`resolve_calibration_file` for a file by its label; it takes, in this order,

1. an override the user chose (accepted even when its content differs, with a warning),
2. the copy inside the run folder, if its hash matches,
3. the original path, if the file is there and its hash matches (runs recorded before copies were made),
4. a file with that hash directly inside one of the given search folders (not their subfolders),

and otherwise refuses in one line naming ``run.json``'s key, the hash and every place it looked.
See ``docs/recordings.md`` ("Calibration files").
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any

from ornitail.acquisition.recording_layout import CALIBRATION_FOLDER_NAME, RUN_METADATA_FILE_NAME
from ornitail.core.errors import UserInputError
from ornitail.core.hashing import content_hash_of_file

SOURCE_OVERRIDE = "override"
SOURCE_RUN_COPY = "run folder copy"
SOURCE_RECORDED_PATH = "recorded path"
SOURCE_SEARCH_PATH = "search path"


@dataclass(frozen=True)
class CalibrationSources:
    """Where processing may look for a run's calibration files besides the run folder and the recorded path.

    Attributes
    ----------
    search_path : sequence of pathlib.Path
        Folders whose files (not subfolders) are hashed to find a file with the recorded content.
    overrides : mapping of str to pathlib.Path
        ``calibration_files`` label (``"balance"``, ``"tunnel_table"``) -> file used instead of the recorded one.
    """

    search_path: Sequence[Path] = ()
    overrides: Mapping[str, Path] | None = None


@dataclass(frozen=True)
class ResolvedCalibrationFile:
    """The file processing uses for one ``calibration_files`` label of one run.

    Attributes
    ----------
    label : str
        The key in ``run.json``'s ``calibration_files``.
    path : pathlib.Path
        The file to read.
    recorded_hash : str
        The content hash the run was recorded with.
    source : str
        ``"override"``, ``"run folder copy"``, ``"recorded path"`` or ``"search path"``.
    warning : str or None
        One line when an override's content differs from the recorded file's, else None.
    """

    label: str
    path: Path
    recorded_hash: str
    source: str
    warning: str | None = None


def calibration_copy_names(paths: Mapping[str, Path]) -> dict[str, str]:
    """Label -> path of its copy relative to the run folder: ``calibration/<file name>``, or
    ``calibration/<label>-<file name>`` for labels whose files share a name."""
    names = [Path(path).name for path in paths.values()]
    copies = {}
    for label, path in paths.items():
        name = Path(path).name
        unique = names.count(name) == 1
        copies[label] = str(
            PurePosixPath(CALIBRATION_FOLDER_NAME, name if unique else f"{label}-{name}")
        )
    return copies


def write_calibration_copies(run_directory: Path, copies: Mapping[str, bytes]) -> None:
    """Write each ``relative path -> content`` into ``run_directory`` and fsync files and folder."""
    if not copies:
        return
    folder = Path(run_directory) / CALIBRATION_FOLDER_NAME
    folder.mkdir()
    for relative, content in copies.items():
        with open(Path(run_directory) / relative, "xb") as stream:
            stream.write(content)
            stream.flush()
            os.fsync(stream.fileno())
    if os.name != "nt":
        descriptor = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)


def _hash_or_reason(path: Path) -> tuple[str | None, str]:
    """``(hash, "")`` of a readable file, or ``(None, why not)``."""
    try:
        return content_hash_of_file(path), ""
    except UserInputError as error:
        return None, error.problem


def _copy_path(run_directory: Path, copy: Any, where: str) -> Path:
    relative = PurePosixPath(str(copy))
    if not isinstance(copy, str) or relative.is_absolute() or ".." in relative.parts:
        raise UserInputError(f"{where}.copy", f"{copy!r} is not a path inside the run folder")
    return Path(run_directory) / relative


def _search_candidates(search_path: Sequence[Path], preferred_name: str) -> list[Path]:
    """Regular files directly inside the search folders, those named ``preferred_name`` first."""
    files = []
    for folder in search_path:
        try:
            entries = sorted(Path(folder).iterdir())
        except OSError:
            continue
        files += [entry for entry in entries if entry.is_file()]
    return sorted(files, key=lambda path: path.name != preferred_name)


def resolve_calibration_file(
    run_directory: Path,
    metadata: Mapping[str, Any],
    label: str,
    sources: CalibrationSources | None = None,
) -> ResolvedCalibrationFile:
    """The file to use for ``calibration_files.<label>`` of the run in ``run_directory`` (see the module doc).

    Raises
    ------
    UserInputError
        If the run names no such file, its entry is malformed, an override is missing, or no file with the
        recorded content is found (the message names the key, the hash and the places looked at).
    """
    sources = sources or CalibrationSources()
    where = f"{Path(run_directory) / RUN_METADATA_FILE_NAME}: calibration_files.{label}"
    entry = (metadata.get("calibration_files") or {}).get(label)
    if not entry:
        raise UserInputError(where, f"the run names no {label} file")
    recorded_hash = entry.get("hash") if isinstance(entry, Mapping) else None
    if not isinstance(recorded_hash, str):
        raise UserInputError(f"{where}.hash", f"{recorded_hash!r} is not a content hash")
    override = (sources.overrides or {}).get(label)
    if override is not None:
        override_hash = content_hash_of_file(override)  # a missing override is refused here
        warning = None
        if override_hash != recorded_hash:
            warning = (
                f"warning: {override}: used as {label} file of run {metadata.get('run_id')} although its "
                f"content ({override_hash}) differs from the file the run was recorded with ({recorded_hash})"
            )
        return ResolvedCalibrationFile(
            label, Path(override), recorded_hash, SOURCE_OVERRIDE, warning
        )
    looked: list[str] = []
    candidates: list[tuple[Path, str]] = []
    if entry.get("copy") is not None:
        candidates.append((_copy_path(run_directory, entry["copy"], where), SOURCE_RUN_COPY))
    else:
        looked.append("no copy in the run folder")
    recorded_path = entry.get("path")
    if isinstance(recorded_path, str):
        candidates.append((Path(recorded_path), SOURCE_RECORDED_PATH))
    for path, source in candidates:
        found_hash, reason = _hash_or_reason(path)
        if found_hash == recorded_hash:
            return ResolvedCalibrationFile(label, path, recorded_hash, source)
        looked.append(f"{path} ({reason or 'content differs'})")
    preferred = Path(recorded_path).name if isinstance(recorded_path, str) else ""
    for path in _search_candidates(sources.search_path, preferred):
        if _hash_or_reason(path)[0] == recorded_hash:
            return ResolvedCalibrationFile(label, path, recorded_hash, SOURCE_SEARCH_PATH)
    if sources.search_path:
        folders = ", ".join(str(folder) for folder in sources.search_path)
        looked.append(f"the files in {folders} (none matches)")
    else:
        looked.append("no search folders given")
    raise UserInputError(
        where, f"no file with content {recorded_hash} found; looked at: {'; '.join(looked)}"
    )
