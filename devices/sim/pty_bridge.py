"""A null-modem cable between two pseudo-terminals (raw mode): two real ttys, one per end.

Each end is a pty pair; a thread copies bytes between the two masters, so a program that
opens ``port_a`` (a Modbus RTU server) talks to one that opens ``port_b`` (the station).
Neither end knows it is not a serial line.
"""

from __future__ import annotations

import contextlib
import os
import select
import tempfile
import threading
import tty


class PtyBridge:
    """Two linked ptys reachable by stable symlinks ``port_a`` and ``port_b``."""

    def __init__(self) -> None:
        self._dir = tempfile.mkdtemp(prefix="gyro-null-modem-")
        self._fds: list[int] = []
        masters = []
        for name in ("a", "b"):
            master, slave = os.openpty()
            tty.setraw(master)
            tty.setraw(slave)
            os.set_blocking(master, False)
            self._fds += [master, slave]
            masters.append(master)
            os.symlink(os.ttyname(slave), os.path.join(self._dir, name))
        self._a, self._b = masters
        self.port_a = os.path.join(self._dir, "a")
        self.port_b = os.path.join(self._dir, "b")
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="pty-bridge", daemon=True)

    def start(self) -> PtyBridge:
        self._thread.start()
        return self

    def _run(self) -> None:
        peer = {self._a: self._b, self._b: self._a}
        while not self._stop.is_set():
            ready, _, _ = select.select([self._a, self._b], [], [], 0.05)
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except (BlockingIOError, OSError):
                    continue
                with contextlib.suppress(BlockingIOError, OSError):
                    os.write(peer[fd], data)

    def stop(self) -> None:
        """Stop copying, close all four descriptors and remove the links."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
        for fd in self._fds:
            with contextlib.suppress(OSError):
                os.close(fd)
        for port in (self.port_a, self.port_b):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(port)
        with contextlib.suppress(OSError):
            os.rmdir(self._dir)
