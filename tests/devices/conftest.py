"""Options and fixtures of the device tests.

``--hardware-port PORT`` with ``--hardware-protocol NAME`` runs the opt-in tests against a
real gyro (e.g. ``--hardware-port /dev/ttyUSB0 --hardware-protocol stim300``); without
them those tests are skipped. pytest reads options only from the conftests of the paths
it starts from, so name this folder: ``pytest tests/devices --hardware-port ...``.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("gyro hardware")
    group.addoption("--hardware-port", default=None,
                    help="serial port, CAN channel or host:port of a real gyro")
    group.addoption("--hardware-protocol", default="stim300",
                    help="protocol of the real gyro (stim300, kvh1750, xbus)")
    group.addoption("--hardware-baud", default=921600, type=int, help="serial line rate")


@pytest.fixture
def hardware(request: pytest.FixtureRequest) -> tuple[str, str, int]:
    """(port, protocol, baud) of the real gyro, or skip."""
    port = request.config.getoption("--hardware-port")
    if port is None:
        pytest.skip("needs a real gyro: pass --hardware-port")
    return (port, request.config.getoption("--hardware-protocol"),
            request.config.getoption("--hardware-baud"))


@pytest.fixture(autouse=True)
def no_leftover_threads() -> Iterator[None]:
    """Every simulator, bus notifier and server thread a test starts is gone after it."""
    before = set(threading.enumerate())
    yield
    deadline = time.monotonic() + 3.0
    while True:
        left = [t for t in threading.enumerate() if t not in before and t.is_alive()]
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.02)
    assert not left, f"threads left running: {[t.name for t in left]}"
