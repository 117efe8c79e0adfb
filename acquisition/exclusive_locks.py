"""Exclusive locks the operating system releases when the holding process dies (``fcntl.flock``).

Two things must have one owner at a time: a rig's instruments (two sweeps on one rig would fight over the strut)
and a sweep's chain of runs (two ``--resume`` of one chain would record every remaining point twice). Each is
guarded by an advisory lock on a small lock file. The holder writes who it is into the file (pid, host, command,
since when, and a detail such as the run it records), so that a refusal names the holder in one line. The kernel
drops the lock when the holder exits or is killed (also ``kill -9``); the file itself is never deleted (deleting a
locked file races with a process that has just opened it), and an unlocked file is free whatever it says.

Device lock files live in ``$ORNITAIL_LOCK_DIR``, else ``/run/lock`` (world-writable on Linux), else the temporary
directory; they are named after the device's real path, so ``/dev/serial/by-id/...`` and the ``/dev/ttyACM0`` it
points to share one lock.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import socket
import sys
import tempfile
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

try:
    import fcntl
except (
    ImportError
):  # pragma: no cover - Windows: no advisory locks; pyserial's own open is exclusive there
    fcntl = None  # type: ignore[assignment]

LOCK_DIRECTORY_VARIABLE = "ORNITAIL_LOCK_DIR"
"""Environment variable naming the folder of device lock files (default ``/run/lock``)."""


@dataclass(frozen=True)
class LockHolder:
    """Who holds a lock, as the holder wrote it: process id, host, command line, since (UTC), detail."""

    pid: int | None
    host: str
    command: str
    since_utc: str
    detail: str = ""

    def describe(self) -> str:
        """One phrase: ``process 1234 on host (ornitail sweep plan.toml, since 2024-06-07T10:15:30Z)``."""
        where = f"process {self.pid}" if self.pid is not None else "another process"
        if self.host and self.host != socket.gethostname():
            where += f" on {self.host}"
        facts = [
            text
            for text in (self.command, f"since {self.since_utc}" if self.since_utc else "")
            if text
        ]
        return where + (f" ({', '.join(facts)})" if facts else "")


class LockHeld(Exception):
    """The lock at ``path`` is held by another process (or another open of it in this process)."""

    def __init__(self, path: Path, holder: LockHolder | None) -> None:
        self.path = path
        self.holder = holder
        super().__init__(f"{path} is held by {holder.describe() if holder else 'another process'}")


def _command_line() -> str:
    arguments = [Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "python", *sys.argv[1:]]
    text = " ".join(arguments)
    return text if len(text) <= 160 else text[:157] + "..."


def read_holder(path: Path) -> LockHolder | None:
    """What the holder of the lock file ``path`` wrote about itself (None if nothing readable)."""
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8") or "null")
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict):
        return None
    pid = record.get("pid")
    return LockHolder(
        pid=pid if isinstance(pid, int) else None,
        host=str(record.get("host", "")),
        command=str(record.get("command", "")),
        since_utc=str(record.get("since_utc", "")),
        detail=str(record.get("detail", "")),
    )


def _alive(holder: LockHolder) -> bool:
    """True unless the holder ran on this host and its process is gone."""
    if holder.pid is None or (holder.host and holder.host != socket.gethostname()):
        return True
    try:
        os.kill(holder.pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def current_holder(path: Path, wait_s: float = 1.0) -> LockHolder | None:
    """The holder of a lock that was just found held: the record it wrote, once it names a live process.

    A new holder writes its record right after taking the lock; until then the file may still name a dead
    previous holder, so a stale record is read again for up to ``wait_s``; None if no live holder shows up.
    """
    deadline = time.monotonic() + wait_s
    while True:
        holder = read_holder(path)
        if holder is not None and _alive(holder):
            return holder
        if time.monotonic() >= deadline:
            return None
        time.sleep(0.02)


class ExclusiveLock:
    """An exclusive, non-blocking ``flock`` on the file ``path``, held until :meth:`release` or process death.

    Two opens of one lock file exclude each other even within one process (two rigs or two sweeps in one
    program are refused too).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._fd: int | None = None
        self._since_utc = ""

    @property
    def held(self) -> bool:
        """True between a successful :meth:`acquire` and :meth:`release`."""
        return self._fd is not None

    def acquire(self, detail: str = "") -> None:
        """Take the lock or raise :class:`LockHeld` naming its holder; write who holds it into the file."""
        if self._fd is not None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            writable = True
        except (
            PermissionError
        ):  # another user's lock file: lockable read-only, holder info not written
            fd = os.open(self.path, os.O_RDONLY)
            writable = False
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as error:
                os.close(fd)
                if error.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                    raise LockHeld(self.path, current_holder(self.path)) from None
                raise
        self._fd = fd
        self._since_utc = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
        if writable:
            with contextlib.suppress(OSError):
                os.fchmod(fd, 0o666)  # other users must be able to take a free lock later
            self.update_detail(detail)

    def update_detail(self, detail: str) -> None:
        """Rewrite the holder record with a new ``detail`` (e.g. the run being recorded now)."""
        if self._fd is None:
            return
        record = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "command": _command_line(),
            "since_utc": self._since_utc,
            "detail": detail,
        }
        data = (json.dumps(record) + "\n").encode("utf-8")
        with contextlib.suppress(OSError):
            os.ftruncate(self._fd, 0)
            os.pwrite(self._fd, data, 0)

    def release(self) -> None:
        """Release the lock (closing the file releases it); safe to call twice."""
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)

    def __enter__(self) -> ExclusiveLock:
        self.acquire()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.release()


def lock_directory() -> Path:
    """Folder of device lock files: ``$ORNITAIL_LOCK_DIR``, else ``/run/lock`` if writable, else the temp dir."""
    configured = os.environ.get(LOCK_DIRECTORY_VARIABLE)
    if configured:
        return Path(configured)
    run_lock = Path("/run/lock")
    if run_lock.is_dir() and os.access(run_lock, os.W_OK | os.X_OK):
        return run_lock
    return Path(tempfile.gettempdir())


def _slug(text: str) -> str:
    slug = re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_.")
    return slug[:120] or "device"


def device_lock(device: str) -> ExclusiveLock:
    """The lock of a serial port (by its real path) or of any other device key (e.g. ``can-pcan-PCAN_USBBUS1``)."""
    key = os.path.realpath(device) if device.startswith(os.sep) else device
    return ExclusiveLock(lock_directory() / f"ornitail-{_slug(key)}.lock")
