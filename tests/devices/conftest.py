"""Options and fixtures of the device tests.

``--hardware-url URL`` (any device URL: serial, CAN, CANopen, Modbus) or
``--hardware-port PORT`` with ``--hardware-protocol NAME`` (a serial gyro, e.g.
``--hardware-port /dev/ttyUSB0 --hardware-protocol stim300``) runs the opt-in tests
against a real gyro (``--hardware-seconds S``: how long, 5 s by default); without them
those tests are skipped. pytest reads options only from the
conftests of the paths
it starts from, so name this folder: ``pytest tests/devices --hardware-port ...``.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("gyro hardware")
    group.addoption("--hardware-url", default=None,
                    help="device URL of a real gyro, any transport (see `station devices`): "
                         "e.g. can://can0?interface=socketcan&rate=1000")
    group.addoption("--hardware-port", default=None,
                    help="serial port of a real gyro (shorthand for a serial:// URL)")
    group.addoption("--hardware-protocol", default="stim300",
                    help="protocol of the serial gyro (stim300, kvh1750, xbus)")
    group.addoption("--hardware-baud", default=921600, type=int, help="serial line rate")
    group.addoption("--hardware-seconds", default=5.0, type=float,
                    help="how long the streaming check reads the gyro, s (at least 200 samples)")


@pytest.fixture
def hardware_url(request: pytest.FixtureRequest) -> str:
    """The device URL of the real gyro (``--hardware-url``, or a serial URL built from
    ``--hardware-port``), or skip."""
    url = request.config.getoption("--hardware-url")
    port = request.config.getoption("--hardware-port")
    if url is None and port is None:
        pytest.skip("needs a real gyro: pass --hardware-url or --hardware-port")
    if url is None:
        url = (f"serial://{port}?protocol={request.config.getoption('--hardware-protocol')}"
               f"&baud={request.config.getoption('--hardware-baud')}")
    return str(url)


@pytest.fixture
def hardware_seconds(request: pytest.FixtureRequest) -> float:
    """How long the streaming check reads the real gyro (``--hardware-seconds``), s."""
    return float(request.config.getoption("--hardware-seconds"))


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
