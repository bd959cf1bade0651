"""Xbus setup: GoToConfig / GoToMeasurement neither lift the operator's hold on a
simulated unit nor lose the data frames that arrive before their acknowledgement."""

from __future__ import annotations

import os
import select
import threading
import time
import tty

import numpy as np

from devices.codecs.base import Reading
from devices.codecs.xbus import MID_GOTO_CONFIG, MID_GOTO_MEASUREMENT, XbusCodec, XbusMessage
from devices.stream import StreamRateSource
from devices.transports.serial import SerialTransport
from devices.urls import open_device
from tests.devices.helpers import collect

CODEC = XbusCodec()


def test_setup_commands_leave_the_operators_hold_alone() -> None:
    """The recorder holds a simulated unit until it listens; opening the adapter (its
    GoToConfig / GoToMeasurement) must not start the unit, releasing the hold must."""
    with open_device("sim+serial://MTI-630?protocol=xbus&rate=500&warp=5&seed=2") as dev:
        core = dev.simulator.core
        core.pause()  # a loaded host may let a few samples out before the hold
        before = core.ledger.generated
        dev.source.open()  # acknowledged: the device answers while held
        time.sleep(0.2)
        assert core.ledger.generated == before and core.held
        core.resume()
        got = collect(dev.source, 200)
        assert got.counter[0] < before + 50 and np.all(np.diff(got.counter) == 1)


def _data(counter: int) -> bytes:
    reading = Reading((0.1, 0.2, 0.3), counter, 0, counter / 500.0, 25.0)
    return CODEC.encode(CODEC.from_reading(reading))


def _ack(mid: int) -> bytes:
    return CODEC.encode(XbusMessage(mid + 1, b""))


def test_data_frames_before_the_acknowledgement_are_kept() -> None:
    """A device still streaming when the greeting arrives: its frames before (and
    between) the acknowledgements are samples like any other."""
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    greeting = CODEC.greeting()

    def device() -> None:  # waits for the greeting, answers with data around the acks
        received = b""
        deadline = time.monotonic() + 5.0
        while len(received) < len(greeting) and time.monotonic() < deadline:
            if select.select([master], [], [], 0.05)[0]:
                received += os.read(master, 64)
        os.write(master, _data(0) + _data(1) + _ack(MID_GOTO_CONFIG) + _data(2)
                 + _ack(MID_GOTO_MEASUREMENT) + _data(3))

    thread = threading.Thread(target=device, name="scripted-xbus")
    thread.start()
    source = StreamRateSource(SerialTransport(os.ttyname(slave)), CODEC, model="MTi",
                              serial_number="T", sample_rate_hz=500.0)
    try:
        source.open()
        thread.join(5)
        batch = source.read(0.05)
    finally:
        thread.join(5)
        source.close()
        os.close(master)
        os.close(slave)
    np.testing.assert_array_equal(batch.counter, [0, 1, 2, 3])
    assert batch.gaps == ()
