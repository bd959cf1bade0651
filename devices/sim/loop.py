"""The background thread every threaded simulated device runs its loop in."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable


class DeviceLoop:
    """Starts a simulated device's ``_run`` in a daemon thread and stops it once.

    Subclasses implement ``_run`` and poll ``self._stop`` (a :class:`threading.Event`)
    in it: ``while not self._stop.wait(period_s): ...``.
    """

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def _run(self) -> None:
        raise NotImplementedError

    def _start_loop(self, name: str) -> None:
        """Start the loop thread (``name`` shows in thread dumps)."""
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _stop_loop(self, timeout_s: float = 5.0) -> None:
        """Ask the loop to end and wait for it (at most ``timeout_s`` wall s)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=timeout_s)


def wait_for_listener(
    port: int, timeout_s: float, what: str, on_timeout: Callable[[], None]
) -> None:
    """Return once a server accepts TCP connections on 127.0.0.1:``port``.

    Raises
    ------
    TimeoutError
        Nothing listened within ``timeout_s`` (wall s); ``on_timeout`` (the server's stop)
        has run first.
    """
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
            return
        except OSError as exc:
            if time.monotonic() > deadline:
                on_timeout()
                raise TimeoutError(f"{what} on port {port} did not start") from exc
            time.sleep(0.01)
