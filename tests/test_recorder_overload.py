"""The books of every protocol on a host overloaded on purpose.

Six units (STIM300 and KVH DSP-1750 with 8- and 7-bit counters, Xbus, raw CAN, CANopen,
Modbus TCP) record together while the host is made to fall behind: two processes spin
beside the recorder for the whole run, and every unit's process (its reader, and the
simulator where it runs in that process) is frozen (SIGSTOP) for 0.3-0.7 s again and
again, first right as the units start. A frozen simulator loses the samples it could
not send on time, whole counter wraps of them (a STIM300 wraps every 0.128 s at any rate);
a frozen reader finds a backlog larger than a tty read hands over at once, or a CAN
bus queue, when it wakes. For every unit the simulator's own count of samples sent must
lie within what was recorded plus the fewest and the most samples its gaps may have
lost: a count the timing cannot pin is an interval, never a certain count that misses
wraps.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

import pytest

from station.model.documents import RunStop
from station.recording.recorder import Recorder, RunConfig
from tests.devices.helpers import multicast_unavailable
from tests.test_recorder_helpers import assert_books

CANOPEN_BUS = "virtual" if multicast_unavailable() else "udp_multicast"
UNITS = {
    "stim300": "sim+serial://STIM300?protocol=stim300&rate=1000&drop=0.01",
    "kvh1750": "sim+serial://DSP-1750?protocol=kvh1750&rate=1000&drop=0.01",
    "xbus": "sim+serial://MTI-630?protocol=xbus&rate=1000&drop=0.01",
    "can": "sim+can://STIM300?rate=1000&drop=0.01",
    "canopen": f"sim+canopen://STIM300/5?interface={CANOPEN_BUS}&rate=100&drop=0.01",
    "modbus": "sim+modbus+tcp://STIM300?rate=50&drop=0.02",
}
DURATION_S = 3.0


@contextmanager
def busy_processes(n: int) -> Iterator[None]:
    """``n`` processes spinning on the CPU beside this one until the block ends."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        yield
    finally:
        for proc in procs:
            proc.kill()
            proc.wait()


def _signal(pid: int, signum: int) -> None:
    with suppress(ProcessLookupError):  # (a unit that ended meanwhile)
        os.kill(pid, signum)


def _overload(recorder: Recorder, done: threading.Event, rng: random.Random,
              busy: int) -> None:
    """From the units' start until ``done``: ``busy`` processes spinning, and every
    unit's process frozen for 0.3-0.7 s again and again (first at once)."""
    while not done.is_set() and not (recorder.workers
                                     and all(w.start_utc for w in recorder.workers)):
        done.wait(0.001)
    with busy_processes(busy):
        while not done.is_set():
            pids = [w.pid for w in recorder.workers if w.pid is not None and not w.done]
            for pid in pids:
                _signal(pid, signal.SIGSTOP)
            try:
                done.wait(rng.uniform(0.3, 0.7))
            finally:
                for pid in pids:
                    _signal(pid, signal.SIGCONT)
            done.wait(rng.uniform(0.2, 0.6))


def record_overloaded(path: Path, seed: int, *, busy: int = 2,
                      duration_s: float = DURATION_S) -> RunStop:
    """Record :data:`UNITS` (seeded) into ``path`` on a host overloaded from the units'
    start to the duration (``busy`` spinning processes, every unit's process frozen now
    and then)."""
    urls = tuple(f"{url}&seed={seed + i}" for i, url in enumerate(UNITS.values()))
    recorder = Recorder(RunConfig(urls, duration_s, path, backoff_max_s=0.1))
    done = threading.Event()
    overload = threading.Thread(target=_overload, daemon=True,
                                args=(recorder, done, random.Random(seed), busy))
    overload.start()
    try:
        recorder.prepare()
        timer = threading.Timer(duration_s, done.set)  # the finish is not overloaded
        timer.daemon = True
        timer.start()
        return recorder.run()
    finally:
        done.set()
        overload.join()


@pytest.fixture(scope="module")
def overloaded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    stop = record_overloaded(tmp_path_factory.mktemp("overload") / "r.h5", seed=11)
    for name, t in zip(UNITS, stop.totals, strict=True):
        print(f"{name}: recorded {t.samples_recorded} + missing {t.samples_missing_declared} "
              f"[{t.samples_missing_low}, {t.samples_missing_high}], sent {t.samples_sent}")
    return dict(zip(UNITS, stop.totals, strict=True))


@pytest.mark.parametrize("name", UNITS)
@pytest.mark.slow
def test_books_hold_on_an_overloaded_host(overloaded: dict, name: str) -> None:
    t = overloaded[name]
    assert t.samples_recorded > 0 and t.samples_missing_declared > 0  # it ran, it lost
    assert_books(t.samples_recorded, t.samples_missing_low, t.samples_missing_declared,
                 t.samples_missing_high, t.samples_sent, t)
