"""A real headless Chromium (Debian's ``chromium`` and ``chromedriver``, driven by Selenium)
and a real ``station serve`` on 127.0.0.1 and a free port, for the browser tests and the
docs' screenshots (``python -m tests.web_screenshots``).

Chromium missing is a failure that says how to install it, never a skip: ``.ci/run``
installs it.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

CHROMIUM = Path(os.environ.get("STATION_CHROMIUM", "/usr/bin/chromium"))
CHROMEDRIVER = Path(os.environ.get("STATION_CHROMEDRIVER", "/usr/bin/chromedriver"))
#: Seconds a server is waited for before the test fails.
START_TIMEOUT_S = 30.0


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def chromium(width: int = 1280, height: int = 900) -> Iterator[object]:
    """A headless Chromium under Selenium's WebDriver (``webdriver.Chrome``), closed at the
    end.

    Raises
    ------
    RuntimeError
        Chromium or its driver is not installed (the message gives the apt command).
    """
    missing = [str(p) for p in (CHROMIUM, CHROMEDRIVER) if not p.is_file()]
    if missing:
        raise RuntimeError(f"{', '.join(missing)} missing: apt-get install -y chromium "
                           "chromium-driver (.ci/run does)")
    from selenium import webdriver

    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                f"--window-size={width},{height}", "--hide-scrollbars"):
        options.add_argument(arg)
    driver = webdriver.Chrome(options=options,
                              service=webdriver.ChromeService(executable_path=str(CHROMEDRIVER)))
    try:
        yield driver
    finally:
        driver.quit()


def screenshot(driver: object, path: Path, most_px: int = 3000) -> None:
    """Save the whole page (up to ``most_px`` pixels high) as the PNG ``path``: the window
    made as high as the page for the shot, then set back."""
    size = driver.get_window_size()  # type: ignore[attr-defined]
    high = driver.execute_script(  # type: ignore[attr-defined]
        "return document.documentElement.scrollHeight;")
    driver.set_window_size(  # type: ignore[attr-defined]
        size["width"], min(most_px, max(size["height"], int(high) + 120)))
    try:
        driver.save_screenshot(str(path))  # type: ignore[attr-defined]
    finally:
        driver.set_window_size(size["width"], size["height"])  # type: ignore[attr-defined]


@dataclass
class Server:
    """A ``station serve`` process starting on 127.0.0.1 and ``url``'s port."""

    url: str
    process: subprocess.Popen

    def wait(self) -> str:
        """The base URL, once the server accepts connections.

        Raises
        ------
        RuntimeError
            The server ended, or did not listen within :data:`START_TIMEOUT_S`.
        """
        port = int(self.url.rsplit(":", 1)[1])
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                    return self.url
            except OSError:
                if self.process.poll() is not None or time.monotonic() > deadline:
                    err = self.process.stderr.read().decode() if self.process.stderr else ""
                    raise RuntimeError(f"station serve did not start: {err}") from None
                time.sleep(0.05)


@contextmanager
def served(db: Path | str, runs: tuple[Path, ...] = ()) -> Iterator[Server]:
    """``station serve --db DB [--runs ...]`` on 127.0.0.1 and a free port, started as a
    separate process (:meth:`Server.wait` for it: start the browser meanwhile), stopped at
    the end."""
    port = free_port()
    command = [sys.executable, "-m", "station", "serve", "--db", str(db), "--port", str(port)]
    if runs:
        command += ["--runs", *map(str, runs)]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        yield Server(f"http://127.0.0.1:{port}", process)
    finally:
        process.terminate()
        process.wait(timeout=10)
