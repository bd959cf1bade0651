"""Each unit in a process of its own: the recorder past the GIL.

Decoding frames, the adapters' timing and a simulated device's encoding are Python work
per sample; 16 units at 2 kHz do not fit one interpreter's lock next to the HDF5 writer
(they starved each other: simulators fell behind, readers read late). So every unit runs
in its own process, forked from a server process that has the device code imported
already (``multiprocessing``'s ``forkserver``): the adapter, the simulator behind a
``sim+`` URL, and a :class:`~station.recording.unit_worker.UnitWorker`. The recorder's process
keeps the HDF5 writer and the other subscribers; event batches come to it over a pipe,
joined into one message per ``batch_s`` (default 50 ms).

The engine side is :class:`UnitProcess`. Its conversation with the child:

=====================  =========================================================
engine -> unit          unit -> engine
=====================  =========================================================
(start of the child)    ``("opened", UnitOpened)`` or ``("error", text)``
``("start", None)``     ``("started", utc)``, ``("batch", EventBatch)`` ... then
                        ``("done", UnitEnd)``
``("stop", None)``      (it finishes as at its duration, then ``done``)
``("close", None)``     (a unit not started: closes its device and exits)
=====================  =========================================================

A unit whose engine disappears (killed) sees its pipe close and stops.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
import types
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any, Literal

from devices.protocols import DeviceDescription
from station.model.documents import Descriptor, EventBatch, UnitTally, data_keys

#: What the engine tells a unit's process, and what the unit reports back (the table above).
Command = Literal["start", "stop", "close"]
Report = Literal["opened", "started", "batch", "done", "error"]
#: Modules the fork server imports once, so that each unit starts without importing them:
#: everything a unit's process imports to open and read any device (the adapters and the
#: simulators behind ``sim+`` URLs: ``devices.urls``; the reader: ``unit_worker``; this
#: module, its target) and what they import only when a device opens or starts (a
#: simulator's random generator, python-can's virtual bus, the CPU-time reading). Nothing
#: of the analysis' fitting (scipy), plotting (matplotlib), JIT (numba) or HDF5 (h5py):
#: ``tests/test_recorder_start.py`` checks both.
PRELOAD = ["station.recording.unit_process", "station.recording.unit_worker", "devices.urls",
           "numpy.random", "can.interfaces.virtual", "resource"]


@dataclass(frozen=True)
class UnitOpened:
    """A unit's device, opened and held (simulations paused) until the run starts."""

    description: DeviceDescription
    time_base: str
    time_warp: float
    replayed: bool = False


@dataclass(frozen=True)
class UnitEnd:
    """How a unit ended: its simulator's count, its error, its CPU time (s)."""

    samples_sent: int | None
    error: str
    source_ended: bool
    reader_cpu_s: float
    cpu_s: float


@contextmanager
def _main_left_alone() -> Iterator[None]:
    """Start a process without ``multiprocessing`` importing this one's ``__main__`` in it.

    A ``forkserver`` or ``spawn`` child imports the parent's main module again (by path
    or by name) before it runs its target: ``station``'s console script would import
    every command, a script read from stdin cannot be found at all. The unit's target
    lives in this module, so the child needs none of it: while the process starts, the
    main module is a blank one.
    """
    main = sys.modules["__main__"]
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        sys.modules["__main__"] = main


def _context() -> Any:
    """The ``forkserver`` context (Linux, macOS), else ``spawn``."""
    try:
        ctx = multiprocessing.get_context("forkserver")
    except ValueError:
        return multiprocessing.get_context("spawn")
    ctx.set_forkserver_preload(PRELOAD)
    return ctx


def start_unit_server() -> None:
    """Start the server process the units fork from, now: it imports the device code
    while this process goes on importing the recorder's (a recorder's units open about
    as much sooner as those imports take). Nothing to do where units are spawned."""
    ctx = _context()
    if ctx.get_start_method() != "forkserver":
        return
    from multiprocessing import forkserver

    with _main_left_alone():
        forkserver.ensure_running()


# -- the unit's process -------------------------------------------------------------

def unit_main(conn: Connection, unit_id: str, url: str, settings: Any,
              rate_limit_deg_s: float | None) -> None:
    """The unit's process: open the device, wait for the start, read, report the end."""
    from devices.errors import DeviceConfigurationError
    from devices.protocols import AccelLimited, RateLimited
    from devices.urls import open_device
    from station.logs import configure_logging
    from station.recording.unit_worker import UnitWorker

    # The recorder turns Ctrl-C and SIGTERM into a clean stop it sends here; the terminal
    # sends Ctrl-C to every process of its group.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    configure_logging()
    send_lock = threading.Lock()

    def send(kind: Report, payload: object) -> None:
        with send_lock:
            try:
                conn.send((kind, payload))
            except OSError:
                pass  # the engine is gone

    try:
        # (a simulation starts held: its samples start when the recorder listens, at
        # the run's start, never before)
        opened = open_device(url, held=True)
    except (DeviceConfigurationError, ValueError) as exc:
        send("error", ("url", str(exc)))
        return
    except Exception as exc:  # noqa: BLE001 - reported to the engine, which says what to do
        send("error", ("open", f"{type(exc).__name__}: {exc}"))
        return
    try:
        opened.source.open()
    except Exception as exc:  # noqa: BLE001 - reported to the engine, which says what to do
        send("error", ("open", str(exc) or type(exc).__name__))
        opened.close()
        return
    if isinstance(opened.source, RateLimited):
        opened.source.limit_rates(rate_limit_deg_s)
    if isinstance(opened.source, AccelLimited):
        opened.source.limit_accel(getattr(settings, "accel_limit_m_s2", None))
    worker = UnitWorker(unit_id, opened, settings, lambda doc: send("batch", doc))
    send("opened", UnitOpened(worker.description, worker.time_base, worker.time_warp,
                                opened.replayed))
    started = False
    while not worker.done.is_set():
        try:
            # (the worker ends on its own at the duration: look at that often, or each
            # record ends up to this long late)
            if not conn.poll(0.02):
                continue
            kind, _ = conn.recv()
        except (EOFError, OSError):
            kind = "stop"  # the engine is gone: end as if asked to
        if kind == "start" and not started:
            started = True
            worker.start()
            send("started", worker.start_utc)  # the unit's time base starts here
        elif kind == "stop" and started:
            worker.stop.set()
        elif kind in ("close", "stop"):
            opened.close()
            return
    worker.join()
    send("done", UnitEnd(worker.samples_sent,
                         "" if worker.error is None else f"{type(worker.error).__name__}: "
                                                         f"{worker.error}",
                         worker.source_ended, worker.cpu_s, time.process_time()))


# -- the engine's handle ------------------------------------------------------------

class UnitProcess:
    """The recorder's handle on one unit running in its own process.

    Parameters
    ----------
    unit_id, url : str
        The unit and its device URL.
    settings : ReadSettings
        How it reads (:class:`station.recording.unit_worker.ReadSettings`).
    rate_limit_deg_s : float or None
        Measurement range from the product profile.
    """

    def __init__(self, unit_id: str, url: str, settings: Any,
                 rate_limit_deg_s: float | None = None) -> None:
        self.unit_id = unit_id
        self.url = url
        self.opened: UnitOpened | None = None
        self.end: UnitEnd | None = None
        self.problem = ""
        #: Where opening failed: "url" (a bad device URL) or "open" (not reachable).
        self.problem_stage = ""
        self.start_utc = ""
        self.tally = UnitTally()
        self.answered = threading.Event()
        #: The unit reads its device (its ``started`` message came).
        self.started = threading.Event()
        #: When (``time.monotonic``) its ``started`` message came: the unit reads from here.
        self.started_at: float | None = None
        #: When its first sample came (``time.monotonic``).
        self.answered_at: float | None = None
        self.pending: list[EventBatch] = []
        ctx = _context()
        self.conn, child = ctx.Pipe()
        self._process = ctx.Process(target=unit_main, name=f"unit-{unit_id}", daemon=True,
                                    args=(child, unit_id, url, settings, rate_limit_deg_s))
        with _main_left_alone():
            self._process.start()
        child.close()

    @property
    def pid(self) -> int | None:
        """The unit's process id."""
        return self._process.pid

    @property
    def done(self) -> bool:
        """The unit has ended (its end report came, or its process is gone)."""
        return self.end is not None or bool(self.problem)

    @property
    def error(self) -> str:
        """Why the unit failed ("" if it did not)."""
        return self.problem or (self.end.error if self.end is not None else "")

    def wait_opened(self, timeout_s: float) -> None:
        """Wait for the device to be opened (or its failure): sets :attr:`opened` or
        :attr:`problem`."""
        deadline = time.monotonic() + timeout_s
        while self.opened is None and not self.problem:
            if not self.receive(max(0.0, deadline - time.monotonic())):
                if time.monotonic() >= deadline:
                    self.problem = f"its process did not open the device within {timeout_s:g} s"
                    return

    def descriptor(self) -> Descriptor:
        """The unit's descriptor document."""
        assert self.opened is not None
        d = self.opened.description
        return Descriptor(self.unit_id, self.url, d, data_keys(d), self.start_utc,
                          self.opened.time_base, self.opened.time_warp)

    def _send(self, kind: Command) -> None:
        try:
            self.conn.send((kind, None))
        except OSError:
            pass

    def start(self, start_utc: str) -> None:
        """Start reading (a held simulation starts sampling now)."""
        self.start_utc = start_utc
        self._send("start")

    def stop(self) -> None:
        """Ask the unit to finish (as at its duration)."""
        self._send("stop")

    def close(self) -> None:
        """Release a unit that never started, and its process."""
        self._send("close")
        self._process.join(10.0)
        if self._process.is_alive():
            self._process.kill()
            self._process.join(5.0)

    def join(self, timeout_s: float = 10.0) -> None:
        """Wait for the process to exit (killed if it does not)."""
        self._process.join(timeout_s)
        if self._process.is_alive():
            self._process.kill()
            self._process.join(5.0)
        self.conn.close()

    def receive(self, timeout_s: float = 0.0) -> bool:
        """Take one message if one comes within ``timeout_s``; returns whether it did.
        Event batches are kept in :attr:`pending` (and counted in :attr:`tally`)."""
        try:
            if not self.conn.poll(timeout_s):
                return False
            kind, payload = self.conn.recv()
        except (EOFError, OSError):
            if not self.done:
                code = self._process.exitcode
                self.problem = (f"its process ended unexpectedly (exit code {code})"
                                if code is not None else "its process closed the link")
            return False
        if kind == "batch":
            self.pending.append(payload)
            self.tally.add(payload)
            if len(payload) and not self.answered.is_set():
                self.answered_at = time.monotonic()
                self.answered.set()
        elif kind == "opened":
            self.opened = payload
        elif kind == "started":  # the instant its time base starts, not when we asked
            self.start_utc = payload
            self.started_at = time.monotonic()
            self.started.set()
        elif kind == "done":
            self.end = payload
        elif kind == "error":
            self.problem_stage, self.problem = payload
        return True


def cpu_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1
