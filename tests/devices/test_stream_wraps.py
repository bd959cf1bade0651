"""Wrap counts of a byte-stream gyro: only a proven silence adds counter wraps.

An 8-bit counter of datagrams (the STIM300 layout, its counter counting datagrams:
``Stim300Codec`` without a rate, ``counter=datagram``) at 500 Hz wraps every 0.512 s.
A reader starved for longer than half of that must not invent wraps (it used to date the
frames after a silence by the time it got to them), while a real silence of 0.7 s must
still be counted whole. The device here is scripted: a test thread writes real STIM300
datagrams into a pty (a real tty for pyserial), so the timing is exactly the one each
test describes.
"""

from __future__ import annotations

import os
import time
import tty
from collections.abc import Iterator

import numpy as np
import pytest

from devices.codecs.base import Reading
from devices.codecs.stim300 import Stim300Codec
from devices.stream import StreamRateSource
from devices.transports.serial import SerialTransport
from devices.urls import open_device
from tests.devices.helpers import Collected, check_accounting, device_index

RATE_HZ = 500.0
CODEC = Stim300Codec(0x94)


class ScriptedPty:
    """A pty whose device end the test writes STIM300 datagrams into, by counter."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        self.port = os.ttyname(self.slave)

    def send(self, counters: range | list[int]) -> None:
        os.write(self.master, b"".join(
            CODEC.encode(CODEC.from_reading(Reading((0.01, 0.02, 0.03), c % 256, 0, None, 25.0)))
            for c in counters))

    def close(self) -> None:
        for fd in (self.master, self.slave):
            os.close(fd)


@pytest.fixture
def scripted() -> Iterator[tuple[ScriptedPty, StreamRateSource]]:
    pty = ScriptedPty()
    source = StreamRateSource(SerialTransport(pty.port), CODEC, model="STIM300",
                              serial_number="T", sample_rate_hz=RATE_HZ)
    source.open()
    try:
        yield pty, source
    finally:
        source.close()
        pty.close()


def _read_all(source: StreamRateSource, expected: int) -> Collected:
    out = Collected()
    deadline = time.monotonic() + 5.0
    while sum(len(b) for b in out.batches) < expected and time.monotonic() < deadline:
        out.batches.append(source.read(0.05))
    return out


def test_a_starved_reader_invents_no_wraps(scripted) -> None:
    """Frames, a silent read, then the reader starved for 1 s (two counter periods) while
    the next frames wait in the port: they follow on without a sample declared missing.
    The station cannot tell whether whole wraps were lost in that second: it says so
    once, for the read that ended the starvation, bounded by the wraps the second holds."""
    pty, source = scripted
    pty.send(range(0, 20))
    assert len(_read_all(source, 20).counter) == 20
    assert len(source.read(0.05)) == 0  # a real silence of 50 ms: 25 sample periods
    pty.send(range(20, 40))
    time.sleep(1.0)  # the reader is starved (a loaded host)
    got = _read_all(source, 20)
    (gap,) = got.gaps
    # never a certain wrap: the lower bound is the truth, 0 missing; the best count is 0
    # on a host that ran the 50 ms silent read in about 50 ms (a loaded one that took half
    # a second over it may best-guess one wrap, still within the bounds)
    assert (gap.after_counter, gap.missing_low) == (19, 0)
    assert gap.missing_samples % 256 == 0 and gap.missing_samples <= gap.missing_high
    np.testing.assert_array_equal(got.counter, np.arange(20, 40) + gap.missing_samples)
    # 1.05 s at 500 Hz holds at most two wraps of the 8-bit counter beyond the 20 frames
    assert gap.missing_high in (256, 512)


def test_a_real_silence_longer_than_a_counter_period_is_counted(scripted) -> None:
    """0.7 s without a byte, then counter 360 after 9: one wrap plus a residue of 95, a
    gap of 350 samples counted with the elapsed time."""
    pty, source = scripted
    pty.send(range(0, 10))
    _read_all(source, 10)
    start = time.monotonic()
    while time.monotonic() - start < 0.7:  # the reader watches the silence
        assert len(source.read(0.02)) == 0
    pty.send(range(360, 370))
    got = _read_all(source, 10)
    np.testing.assert_array_equal(got.counter, np.arange(360, 370))
    (gap,) = got.gaps
    assert (gap.after_counter, gap.missing_samples, gap.method) == (9, 350, "counter+elapsed")
    assert gap.missing_low == gap.missing_high == 350  # the reader watched: certain


def test_sim_stalls_with_a_starved_reader_are_exact() -> None:
    """A simulated STIM300 stalls for 0.1 s (50 samples, under half a counter period)
    every 0.5 s while its reader, after every silent read, is starved for 1 s of the
    device's time (500 samples, more than the pty holds: the device waits for the
    reader): every gap is exactly the samples the device lost, no wrap invented. (Its
    counter counts datagrams, ``counter=datagram``: an 8-bit counter that wraps every
    0.512 s; a data sheet STIM300's wraps every 0.128 s, see test_stim300_datasheet.py.)"""
    url = ("sim+serial://STIM300?protocol=stim300&counter=datagram&rate=500&warp=5&seed=5"
           "&history=100000&stall_every_s=0.5&stall_for_s=0.1")
    with open_device(url) as dev:
        dev.source.open()
        got = Collected()
        deadline = time.monotonic() + 20.0
        while len(got.counter) < 2500 and time.monotonic() < deadline:
            batch = dev.source.read(0.01)
            got.batches.append(batch)
            if not len(batch):
                time.sleep(0.2)  # 1 s at warp 5: 500 samples
        core = dev.simulator.core
        offset = device_index(got, core, 256)
        declared, lost = check_accounting(got, core, offset)
        assert len(lost) >= 200  # the stalls happened
        assert declared == lost

