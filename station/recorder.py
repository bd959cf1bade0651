"""The recorder engine: several gyros at once, one thread per unit, into one run file.

:class:`Recorder` opens every unit's adapter from its device URL, refuses a bad
configuration before anything is recorded (:meth:`Recorder.prepare`), then runs one
:class:`UnitWorker` thread per unit. Each worker reads its device on the unit's own time
base (a simulation's warped clock, ``time.monotonic`` for hardware), reconnects with
exponential backoff after a disconnect while the other units go on, and turns every
adapter batch into an :class:`~station.model.documents.EventBatch`. The engine's own thread
routes documents to the subscribers (the HDF5 writer first, then the progress line and
anything else) and flushes the file at least every ``flush_interval_s``. A unit stops at
its duration, on :meth:`Recorder.request_stop` (Ctrl-C, SIGTERM), or when the disk fills.

Simulated units (``sim+`` URLs) are held paused until the recorder listens, as a bench
gyro switched on by the operator, and end cleanly: at their end the recorder turns their
fault injection off and reads until their newest frame, so that every sample the
simulator generated is either recorded or declared missing by a gap (see
``samples_sent`` in :class:`~station.model.documents.UnitTotals`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import queue
import re
import socket
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from devices.errors import DeviceConfigurationError, DeviceError, DeviceTimeoutError
from devices.protocols import SampleBatch
from devices.replay import EndOfReplayError
from devices.urls import OpenedDevice, open_device
from station.errors import DiskSpaceError, RunConfigurationError, UsageError
from station.hdf5 import (
    REASON_DURATION,
    REASON_END_OF_REPLAY,
    RunFileWriter,
    bytes_per_sample,
    writable_bytes,
)
from station.model.documents import (
    Descriptor,
    Dispatcher,
    EventBatch,
    LogEntry,
    RunStart,
    RunStop,
    Subscriber,
    UnitTally,
    UnitTotals,
    data_keys,
    utc_now,
)

if TYPE_CHECKING:
    from station.model.profiles import Profile

_DURATION_RE = re.compile(r"(\d+(?:\.\d*)?|\.\d+)\s*(ms|min|d|h|m|s)?", re.IGNORECASE)
_UNIT_S = {"d": 86400.0, "h": 3600.0, "min": 60.0, "m": 60.0, "s": 1.0, "ms": 1e-3, None: 1.0}


def parse_duration(text: str) -> float:
    """A duration in seconds from ``12h``, ``1h30m``, ``90s``, ``2.5min`` or plain seconds.

    Raises
    ------
    UsageError
        Not a duration, or not > 0.
    """
    s = text.strip().replace(" ", "")
    pos, total = 0, 0.0
    for m in _DURATION_RE.finditer(s):
        if m.start() != pos:
            break
        total += float(m.group(1)) * _UNIT_S[m.group(2).lower() if m.group(2) else None]
        pos = m.end()
    if pos != len(s) or not s or not total > 0 or not math.isfinite(total):
        raise UsageError(f"duration {text!r}: use e.g. 12h, 1h30m, 90s or a number of seconds")
    return total


@dataclasses.dataclass(frozen=True)
class RunConfig:
    """What to record and how.

    Attributes
    ----------
    urls : tuple of str
        Device URLs, one per unit (``sim+serial://STIM300?warp=100``, ``serial:///dev/...``).
    duration_s : float
        Run length, s, on each unit's own time base (simulated seconds for a simulation).
    out : Path
        A folder (a file ``run-<UTC>-<id>.h5`` is made in it) or a ``.h5`` path.
    profile : Profile or None
        Product profile: required for real hardware, optional for simulations.
    operator, lot : str
        For the run metadata.
    flush_interval_s : float
        Longest time between file flushes, s (<= 1).
    read_timeout_s : float
        Wait per adapter read, s (wall).
    backoff_initial_s, backoff_max_s : float
        Reconnect delays, s (wall): doubled after each failed attempt up to the maximum.
    answer_timeout_s : float
        Each unit must deliver a first sample within this time (wall s) or the run is
        refused.
    reserve_bytes : int or None
        Stop once less than this can be written (default: 8 MiB + 10 s of data).
    bench_json : str
        The bench (latitude, axis directions; :mod:`station.model.bench`) as JSON, kept in the
        run file ("" when none was given).
    """

    urls: tuple[str, ...]
    duration_s: float
    out: Path
    profile: Profile | None = None
    operator: str = ""
    lot: str = ""
    flush_interval_s: float = 0.5
    read_timeout_s: float = 0.05
    backoff_initial_s: float = 0.05
    backoff_max_s: float = 1.0
    answer_timeout_s: float = 5.0
    reserve_bytes: int | None = None
    bench_json: str = ""


def run_file_path(out: Path, uid: str) -> Path:
    """The run file: ``out`` itself if it ends in .h5/.hdf5, else a new name inside it."""
    if out.suffix.lower() in (".h5", ".hdf5"):
        return out
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return out / f"run-{stamp}-{uid[:8]}.h5"


def software_version() -> str:
    """The installed gyro-station version ("unknown" when not installed)."""
    try:
        return metadata.version("gyro-station")
    except metadata.PackageNotFoundError:
        return "unknown"


class UnitWorker:
    """Reads one unit in its own thread and puts its event batches on the engine's queue.

    Parameters
    ----------
    unit_id : str
        ``unit1``, ``unit2``, ... in the order of the URLs.
    opened : OpenedDevice
        The adapter (opened) and, for a simulation, the simulator behind it.
    config : RunConfig
        Timeouts, backoff and duration.
    out : queue.Queue
        Where the documents go.
    """

    def __init__(self, unit_id: str, opened: OpenedDevice, config: RunConfig,
                 out: queue.Queue[EventBatch]) -> None:
        self.unit_id = unit_id
        self.opened = opened
        self.config = config
        self.out = out
        self.description = opened.source.describe()
        sim = opened.simulator
        self.clock: Callable[[], float] = (sim.core.clock if sim is not None else
                                           opened.clock or time.monotonic)
        self.time_warp = sim.core.clock.warp if sim is not None else 1.0
        self.time_base = (f"simulated device clock, warp x{self.time_warp:g}" if sim is not None
                          else "the replayed capture's clock (s since it started)"
                          if opened.clock is not None else "station monotonic clock")
        #: The source has nothing more to give (the end of a replayed capture).
        self.source_ended = False
        self.tally = UnitTally()
        self.answered = threading.Event()
        self.done = threading.Event()
        self.stop = threading.Event()
        self.error: BaseException | None = None
        self.cpu_s = 0.0
        self.samples_sent: int | None = None
        self.start_utc = ""
        self._t0 = 0.0
        self._seq = 0
        self._thread = threading.Thread(target=self._run, name=f"recorder-{unit_id}",
                                        daemon=True)

    # -- life cycle ----------------------------------------------------------------
    def start(self) -> None:
        """Start reading (a held simulation starts sampling now)."""
        self.start_utc = utc_now()
        self._t0 = self.clock()
        if self.opened.simulator is not None:
            self.opened.simulator.core.resume()
        self._thread.start()

    def join(self, timeout_s: float | None = None) -> None:
        """Wait for the thread to end."""
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def close(self) -> None:
        """Close the adapter and stop any simulator (for a worker that never started)."""
        self.opened.close()

    def elapsed_s(self) -> float:
        """Time since the unit started, s on its own time base."""
        return self.clock() - self._t0

    def descriptor(self) -> Descriptor:
        """The unit's descriptor document."""
        return Descriptor(self.unit_id, self.opened.url, self.description,
                          data_keys(self.description), self.start_utc, self.time_base,
                          self.time_warp)

    # -- reading -------------------------------------------------------------------
    def _emit(self, batch_or_none: object, extra: Sequence[LogEntry] = ()) -> int:
        if isinstance(batch_or_none, SampleBatch):
            doc = EventBatch.from_samples(self.unit_id, self._seq, batch_or_none, self._t0,
                                          [*self._leading_gap(batch_or_none), *extra])
        elif extra:
            doc = _log_only(self.unit_id, self._seq, self.description.n_axes, extra)
        else:
            return 0
        if len(doc) or doc.log:
            self._seq += 1
            self.tally.add(doc)
            self.out.put(doc)
            if len(doc):
                self.answered.set()
        return len(doc)

    def _leading_gap(self, batch: SampleBatch) -> list[LogEntry]:
        """A simulated unit starts at counter 0 when the recorder starts listening: samples
        it produced before the first one received (a polled register overwritten, a CAN
        frame before the bus was read) are declared as a gap counted by the counter."""
        if self.answered.is_set() or not len(batch) or self.opened.simulator is None:
            return []
        first = int(batch.counter[0])
        if first <= 0:
            return []
        return [LogEntry("gap", float(batch.receive_time_s[0]) - self._t0, 1, first, -1,
                         "counter", "before the first sample received (the simulated "
                                    "device starts at counter 0)")]

    def _read_once(self, backoff_s: float, timeout_s: float | None = None) -> tuple[int, float]:
        """One adapter read (``timeout_s`` wall s, default the config's); returns (samples,
        next backoff s)."""
        cfg = self.config
        try:
            batch = self.opened.source.read(cfg.read_timeout_s if timeout_s is None
                                            else timeout_s)
        except DeviceTimeoutError as exc:
            self._emit(None, [LogEntry("timeout", self.elapsed_s(), detail=str(exc)[:120])])
            return 0, backoff_s
        except EndOfReplayError:
            self.source_ended = True
            return 0, backoff_s
        except DeviceError as exc:
            # Disconnected, or no acknowledgement on reconnect: the adapter logs the
            # disconnect itself; wait and let the next read reopen the link.
            if not isinstance(exc, ConnectionError) and backoff_s == cfg.backoff_initial_s:
                self._emit(None, [LogEntry("error", self.elapsed_s(), detail=str(exc)[:120])])
            self.stop.wait(backoff_s)
            return 0, min(2.0 * backoff_s, cfg.backoff_max_s)
        n = self._emit(batch)
        return n, cfg.backoff_initial_s if n else backoff_s

    def _record(self) -> None:
        backoff = self.config.backoff_initial_s
        while (not self.stop.is_set() and not self.source_ended
               and self.elapsed_s() < self.config.duration_s):
            _, backoff = self._read_once(backoff)

    def _finish_simulation(self) -> None:
        """End a simulated unit cleanly: faults off, its newest frames read, then paused."""
        assert self.opened.simulator is not None
        core = self.opened.simulator.core
        core.clear_faults()
        settle = time.monotonic() + 0.05
        deadline = time.monotonic() + 10.0
        backoff = 0.01
        while time.monotonic() < deadline:
            n, backoff = self._read_once(min(backoff, 0.05))
            if n and time.monotonic() > settle:
                break
        core.pause()
        time.sleep(0.02)  # the device thread finishes its last write

    def _drain(self) -> None:
        empty = 0
        deadline = time.monotonic() + 5.0
        while empty < 2 and time.monotonic() < deadline:
            n, _ = self._read_once(0.01, timeout_s=0.01)
            empty = 0 if n else empty + 1

    def _run(self) -> None:
        try:
            self._record()
            if self.opened.simulator is not None:
                self._finish_simulation()
            self._drain()
            self._emit(None, [LogEntry("end", self.elapsed_s(), detail=(
                "stopped" if self.stop.is_set() else
                REASON_END_OF_REPLAY if self.source_ended else "duration"))])
        except Exception as exc:  # noqa: BLE001 - one unit's failure must not end the others
            self.error = exc
            self._emit(None, [LogEntry("error", self.elapsed_s(),
                                       detail=f"{type(exc).__name__}: {exc}"[:120])])
        finally:
            self.cpu_s = time.thread_time()
            if self.opened.ledger is not None:
                self.samples_sent = self.opened.ledger.generated
            self.opened.close()
            self.done.set()


def _log_only(unit_id: str, seq: int, n_axes: int, log: Sequence[LogEntry]) -> EventBatch:
    return EventBatch(unit_id, seq, np.empty((0, n_axes)), np.empty(0, np.int64),
                      np.empty(0), np.empty(0, np.uint32), log=tuple(log))


def _check_against_profile(unit: str, worker: UnitWorker, profile: Profile) -> list[str]:
    d = worker.description
    problems = []
    if profile.sample_rate_hz is not None and not math.isclose(
            d.sample_rate_hz, profile.sample_rate_hz, rel_tol=1e-6):
        problems.append(f"{unit}: the device reports {d.sample_rate_hz:g} Hz, profile "
                        f"{profile.name} expects {profile.sample_rate_hz:g} Hz: configure the "
                        f"device's output rate (URL key rate=) or choose the right profile")
    missing = [a for a in profile.axes if a not in d.axes]
    if missing:
        problems.append(f"{unit}: the device has {d.n_axes} axes ({', '.join(d.axes)}), "
                        f"profile {profile.name} needs {', '.join(profile.axes)}: connect "
                        f"the right device or choose the right profile")
    return problems


class Recorder:
    """One run: prepare (open and check every unit), then record until done.

    Parameters
    ----------
    config : RunConfig
        What to record.
    subscribers : sequence of callables
        Document subscribers besides the file writer (progress line, TUI bridge, ...).
    """

    def __init__(self, config: RunConfig, subscribers: Sequence[Subscriber] = ()) -> None:
        if not config.urls:
            raise UsageError("no unit to record: give --unit DEVICE_URL (or a profile with "
                             "a transport url)")
        self.config = config
        self.uid = uuid.uuid4().hex
        self.path = run_file_path(config.out, self.uid)
        self.queue: queue.Queue[EventBatch] = queue.Queue()
        self.workers: list[UnitWorker] = []
        self.writer: RunFileWriter | None = None
        self.dispatcher = Dispatcher()
        self._extra = list(subscribers)
        self._stop_reason: str | None = None
        self.stop_reason = ""
        self.engine_cpu_s = 0.0

    # -- before the run ------------------------------------------------------------
    def estimate_bytes(self) -> int:
        """Estimated size of the run file, bytes (samples x bytes per sample, +5 %)."""
        total = 0.0
        for w in self.workers:
            per_sample = bytes_per_sample(w.descriptor())
            total += per_sample * w.description.sample_rate_hz * self.config.duration_s
        return int(total * 1.05) + (1 << 20)

    def _reserve(self) -> int:
        if self.config.reserve_bytes is not None:
            return self.config.reserve_bytes
        rate = sum(bytes_per_sample(w.descriptor()) * w.description.sample_rate_hz
                   for w in self.workers)
        return int((8 << 20) + 10 * rate)

    def _open_units(self) -> list[str]:
        problems: list[str] = []
        profile = self.config.profile
        for i, url in enumerate(self.config.urls):
            name = f"unit{i + 1} ({url})"
            try:
                opened = open_device(url)
            except (DeviceConfigurationError, ValueError) as exc:
                problems.append(f"{name}: bad device URL: {exc}; see `station devices "
                                f"--json` for the URL of each protocol")
                continue
            if opened.simulator is not None:
                opened.simulator.core.pause()  # sampling starts when the recorder listens
            elif profile is None:
                problems.append(f"{name}: real hardware (and a replayed capture of it) "
                                f"needs --profile PROFILE (it gives the model, sample rate "
                                f"and axes to check)")
            try:
                opened.source.open()
            except (DeviceError, OSError) as exc:
                opened.close()
                problems.append(f"{name}: device not reachable: {exc}; check that it is "
                                f"powered and connected, the port or address in the URL, "
                                f"and that no other program holds the port")
                continue
            worker = UnitWorker(f"unit{i + 1}", opened, self.config, self.queue)
            self.workers.append(worker)
            if profile is not None:
                problems += _check_against_profile(name, worker, profile)
        return problems

    def _check_disk(self) -> list[str]:
        out_dir = self.path.parent
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            return [f"cannot create the output folder {out_dir}: {exc}"]
        if self.path.exists():
            return [f"{self.path} exists already: choose another --out"]
        if not os.access(out_dir, os.W_OK):
            return [f"cannot write to {out_dir}: choose another --out"]
        need, free = self.estimate_bytes() + self._reserve(), writable_bytes(self.path)
        if need > free:
            return [f"the run needs about {need / 1e9:.3g} GB in {out_dir} but only "
                    f"{free / 1e9:.3g} GB can be written there: free some space, choose "
                    f"another --out, or shorten --duration"]
        return []

    def prepare(self) -> None:
        """Open every unit and check the configuration; nothing is written before this passes.

        Raises
        ------
        RunConfigurationError
            Every problem found: bad URL, unreachable device, sample rate or axes that do
            not match the profile, not enough disk space, a unit that sends nothing.
        """
        try:
            problems = self._open_units()
            if not problems:
                problems = self._check_disk()
            if not problems:
                for w in self.workers:
                    w.start()
                deadline = time.monotonic() + self.config.answer_timeout_s
                for w in self.workers:
                    if not w.answered.wait(max(0.0, deadline - time.monotonic())):
                        problems.append(
                            f"{w.unit_id} ({w.opened.url}): no sample within "
                            f"{self.config.answer_timeout_s:g} s: check the protocol and "
                            f"rate in the URL, and that the device is streaming")
        except BaseException:
            self._abort()
            raise
        if problems:
            self._abort()
            raise RunConfigurationError(problems)

    def _abort(self) -> None:
        for w in self.workers:
            w.stop.set()
        for w in self.workers:
            if w.start_utc:
                w.join(15.0)
            else:
                w.close()

    # -- the run -------------------------------------------------------------------
    def request_stop(self, reason: str) -> None:
        """Ask every unit to stop (safe from a signal handler); ``reason`` is recorded."""
        if self._stop_reason is None:
            self._stop_reason = reason

    def _dispatch_pending(self, limit: int = 1000) -> None:
        for _ in range(limit):
            try:
                doc = self.queue.get_nowait()
            except queue.Empty:
                return
            self.dispatcher.emit(doc)

    def run(self) -> RunStop:
        """Record until every unit is done; returns the stop document.

        :meth:`prepare` is called first if it was not.
        """
        if not self.workers:
            self.prepare()
        cfg = self.config
        self.writer = RunFileWriter(self.path, flush_interval_s=cfg.flush_interval_s,
                                    reserve_bytes=self._reserve())
        for s in (self.writer, *self._extra):
            self.dispatcher.subscribe(s)
        p = cfg.profile
        self.dispatcher.emit(RunStart(
            self.uid, min(w.start_utc for w in self.workers),
            tuple(w.unit_id for w in self.workers), cfg.duration_s, str(self.path),
            profile=p.name if p else "", profile_version=p.version if p else "",
            profile_sha256=p.sha256 if p else "",
            profile_path=str(Path(p.path).resolve()) if p and p.path else "",
            operator=cfg.operator, lot=cfg.lot,
            station_host=socket.gethostname(), software_version=software_version(),
            bench=cfg.bench_json))
        for w in self.workers:
            self.dispatcher.emit(w.descriptor())
        cpu0 = time.thread_time()
        stopping = False
        while not all(w.done.is_set() for w in self.workers):
            try:
                self.dispatcher.emit(self.queue.get(timeout=0.05))
            except queue.Empty:
                pass
            self._dispatch_pending()
            try:
                self.writer.flush_if_due()
            except DiskSpaceError as exc:
                self.request_stop(f"disk full: {exc}")
            if self._stop_reason is not None and not stopping:
                stopping = True
                for w in self.workers:
                    w.stop.set()
        for w in self.workers:
            w.join()
        self._dispatch_pending(limit=10**9)
        self.engine_cpu_s = time.thread_time() - cpu0
        self.stop_reason = self._stop_reason or (
            REASON_END_OF_REPLAY if all(w.source_ended for w in self.workers)
            else REASON_DURATION)
        totals = tuple(UnitTotals(w.unit_id, w.opened.url, w.tally.samples, w.tally.missing,
                                  w.tally.gaps, w.tally.crc_errors, w.tally.reconnects,
                                  w.samples_sent) for w in self.workers)
        stop = RunStop(utc_now(), self.stop_reason, totals)
        self.dispatcher.emit(stop)
        return stop
