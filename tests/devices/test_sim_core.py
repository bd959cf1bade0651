"""The simulated device's core: a run's end set with the release of its hold, a hold that no
sample generated meanwhile outlives, and a run's end never below what it generated."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

from devices.sim.clock import WarpClock
from devices.sim.faults import SimCore
from devices.sim.signal import SignalSource

RATE_HZ = 50.0


class SteppedClock(WarpClock):
    """Simulated time set by the test (a host whose scheduling it decides)."""

    def __init__(self) -> None:
        super().__init__(1.0)
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _core(clock: WarpClock) -> SimCore:
    return SimCore(SignalSource("STIM300", RATE_HZ, seed=3), RATE_HZ, clock)


@contextmanager
def generating(core: SimCore) -> Iterator[None]:
    """A device thread taking its samples due all the time, until the block ends."""
    stop = threading.Event()

    def device() -> None:
        while not stop.is_set():
            core.due()

    thread = threading.Thread(target=device, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


def test_a_run_set_with_its_release_ends_on_its_own_clock_however_late_it_is_read() -> None:
    """Held 3 s (3.5 sample periods after it was made, none generated yet), released for
    a 10 s run, read first 40 s later: 500 samples, not one more (the hold is no part of
    the run, nor is the 30 s overrun, nor the part period before the hold)."""
    clock = SteppedClock()
    core = _core(clock)
    clock.now = 0.07
    core.pause()
    clock.now = 3.0
    assert core.due() == []
    core.resume(run_for_s=10.0)
    clock.now = 43.0
    got = [r.counter for r in core.due(limit=100_000)]
    assert got == list(range(500))
    assert core.due() == [] and core.ledger.generated == 500


def test_a_hold_asked_for_during_a_batch_outlives_it() -> None:
    """``pause`` returns once no batch is being generated: nothing is generated after it."""
    core = _core(WarpClock(50.0))
    with generating(core):
        for _ in range(20):
            core.pause()
            before = core.ledger.generated
            threading.Event().wait(0.01)
            assert core.ledger.generated == before
            core.resume()
            threading.Event().wait(0.005)
    assert core.ledger.generated > 0


def test_an_end_set_below_what_it_generated_ends_on_what_it_generated() -> None:
    """A run's end asked for after the device's thread generated past it (a starved thread
    catching up while the station read its count) is the count it generated, never one
    it has already overrun: the station declares the samples up to it."""
    clock = SteppedClock()
    core = _core(clock)
    clock.now = 2.0
    assert len(core.due()) == 100
    assert core.stop_after(60) == 100  # (the 40 after sample 60 were generated all the same)
    clock.now = 4.0
    assert core.due() == [] and core.ledger.generated == 100
    assert core.stop_after(150) == 150


def test_an_end_set_while_a_batch_is_generated_counts_the_whole_batch() -> None:
    """``stop_after`` waits for a batch being generated: the count it returns is one the
    device never passes (20 tries against a thread generating all the time)."""
    core = _core(WarpClock(50.0))
    with generating(core):
        for _ in range(20):
            end = core.stop_after(core.ledger.generated + 5)
            assert end is not None
            threading.Event().wait(0.01)
            assert core.ledger.generated <= end
            core.stop_after(None)
            threading.Event().wait(0.005)
