"""Zaber ASCII protocol messages: commands ``/1 1 move abs 12345`` and replies ``@01 1 OK IDLE -- 0``.

Reference: Zaber's *ASCII Protocol Manual* (firmware 7, https://www.zaber.com/protocol-manual?protocol=ASCII)
and its summary https://www.zaber.com/articles/ascii-protocol. A command is ``/`` + device address + axis number
+ command text, ended by a newline; the device answers one reply line ``@`` + two-digit address + axis + ``OK``
or ``RJ`` (rejected) + ``IDLE`` or ``BUSY`` + the highest-priority warning flag (``--`` for none) + data (the
value asked for, ``0``, or the rejection reason such as ``BADDATA``), ended by CR LF. Message ids and checksums
(optional in the protocol) are not used.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

REPLY_PATTERN = re.compile(r"^@(\d{2}) (\d+) (OK|RJ) (IDLE|BUSY) (\S{2}) (\S+)$")

WARNING_FLAGS = {
    "--": "no warning",
    "FD": "driver disabled",
    "FQ": "encoder error",
    "FS": "stalled and stopped",
    "FT": "excessive twist",
    "FE": "limit error",
    "FF": "critical system error",
    "WH": "device not homed",
    "WR": "no reference position",
    "WL": "unexpected limit trigger",
    "WV": "voltage out of range",
    "WT": "system temperature high",
    "NC": "manual control",
    "NI": "command interrupted",
}
"""Meanings of the flags this project acts on or reports (F: fault, W: warning, N: notice)."""

NOT_HOMED_FLAGS = frozenset({"WH", "WR"})
"""Flags saying the axis has no valid position reference yet."""


def command_line(device: int, axis: int, command: str) -> bytes:
    """``/<device> <axis> <command>\\n`` as bytes."""
    return f"/{device} {axis} {command}\n".encode("ascii")


@dataclass(frozen=True)
class ZaberReply:
    """One reply line, split into its fields."""

    device: int
    axis: int
    accepted: bool
    busy: bool
    warning: str
    data: str

    @property
    def fault(self) -> bool:
        """True for a fault flag (``F?``): the axis needs attention before it moves again."""
        return self.warning.startswith("F")


def parse_reply(line: str) -> ZaberReply | None:
    """The reply ``line`` (without its line end), or None if it is not a reply line."""
    match = REPLY_PATTERN.match(line.strip())
    if match is None:
        return None
    device, axis, flag, status, warning, data = match.groups()
    return ZaberReply(int(device), int(axis), flag == "OK", status == "BUSY", warning, data)


def flag_meaning(flag: str) -> str:
    """``"FS (stalled and stopped)"``."""
    return f"{flag} ({WARNING_FLAGS.get(flag, 'see the Zaber ASCII protocol manual')})"
