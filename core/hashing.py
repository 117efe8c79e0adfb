"""Content hashes that name the calibration and configuration files a recording used."""

from __future__ import annotations

import hashlib
from pathlib import Path

from ornitail.core.input_files import read_input_bytes


def content_hash_of_bytes(data: bytes) -> str:
    """Return ``"sha256:<hex>"`` for ``data``."""
    return "sha256:" + hashlib.sha256(data).hexdigest()


def content_hash_of_file(path: str | Path) -> str:
    """Return ``"sha256:<hex>"`` of the file's bytes; a missing file is a user error."""
    return content_hash_of_bytes(read_input_bytes(path))
