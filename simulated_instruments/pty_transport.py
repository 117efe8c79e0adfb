"""Pseudo-terminal pairs: the real serial transport behind which simulated instruments run.

The simulator owns the master end; the driver opens the slave end by its path (``/dev/pts/N``) with
pyserial exactly as it would open ``/dev/ttyUSB0``. The slave is put in raw mode (no echo, no line
editing, no CR/LF translation) so binary frames pass unchanged. Closing the master makes the slave
fail like an unplugged USB adapter: ``in_waiting`` raises ``OSError`` (EIO), ``read`` raises
``SerialException``.
"""

from __future__ import annotations

import errno
import os
import select
import tty
from dataclasses import dataclass


@dataclass
class PseudoTerminalPair:
    """An open pty pair: ``master_fd`` for the simulator, ``slave_path`` for the driver."""

    master_fd: int
    slave_fd: int
    slave_path: str

    @classmethod
    def open_raw(cls) -> PseudoTerminalPair:
        """Open a pty pair with the slave in raw mode and the master non-blocking."""
        master_fd, slave_fd = os.openpty()
        tty.setraw(slave_fd)
        os.set_blocking(master_fd, False)
        return cls(master_fd, slave_fd, os.ttyname(slave_fd))

    def read_available(self, timeout_s: float) -> bytes | None:
        """Bytes the driver wrote, waiting ``timeout_s``; b"" if none, None once the pty is gone."""
        if self.master_fd < 0:
            return None
        try:
            readable, _, _ = select.select([self.master_fd], [], [], timeout_s)
            if not readable:
                return b""
            return os.read(self.master_fd, 65536)
        except BlockingIOError:
            return b""
        except OSError as error:
            if error.errno == errno.EIO:  # slave closed by the driver for now; not fatal
                return b""
            return None

    def write_some(self, data: bytes) -> int:
        """Write as much of ``data`` as the pty buffer takes now; return the byte count written."""
        if self.master_fd < 0 or not data:
            return 0
        try:
            return os.write(self.master_fd, data)
        except (BlockingIOError, InterruptedError):
            return 0

    def close_master(self) -> None:
        """Close the simulator's end (what an unplugged cable looks like to the driver)."""
        if self.master_fd >= 0:
            os.close(self.master_fd)
            self.master_fd = -1

    def close(self) -> None:
        """Close both ends."""
        self.close_master()
        if self.slave_fd >= 0:
            os.close(self.slave_fd)
            self.slave_fd = -1
