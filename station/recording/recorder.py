"""The recorder engine: several gyros at once, each in a process of its own, into one file.

:class:`Recorder` starts one process per unit (:mod:`station.recording.unit_process`), which opens
the unit's adapter from its device URL (and the simulated device behind a ``sim+`` URL),
refuses a bad configuration before anything is recorded (:meth:`Recorder.prepare`), then
starts every unit. Each unit reads its device on its own time base, reconnects after a
disconnect while the others go on (:mod:`station.recording.unit_worker`), and sends its event
batches here. The engine routes documents to the subscribers (the HDF5 writer first,
then the progress line and anything else) and flushes the file at least every
``flush_interval_s``. A unit stops at its duration, on :meth:`Recorder.request_stop`
(Ctrl-C, SIGTERM), or when the disk fills; every unit then reports how it ended, with
its simulator's count of samples sent and the CPU time it used.
"""

from __future__ import annotations

import dataclasses
import math
import os
import socket
import time
import uuid
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from multiprocessing.connection import wait
from pathlib import Path
from typing import TYPE_CHECKING

from analysis.units.conversions import STANDARD_GRAVITY_M_S2
from devices.protocols import DeviceDescription
from devices.url_text import is_simulated
from station.errors import Problem, RecorderError, RunConfigurationError, UsageError
from station.model.documents import (
    Dispatcher,
    RunStart,
    RunStop,
    Subscriber,
    UnitTotals,
    utc_now,
)
from station.model.runs import RunMetadata
from station.model.version import software_version
from station.recording.unit_process import UnitProcess
from station.recording.unit_worker import ReadSettings
from station.storage.hdf5 import (
    REASON_DEVICE_LOST,
    REASON_DURATION,
    REASON_END_OF_REPLAY,
    bytes_per_sample,
    writable_bytes,
)
from station.storage.hdf5_writer import RunFileWriter

if TYPE_CHECKING:
    from station.model.profiles import Profile

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
    metadata : RunMetadata
        What the run records about itself besides the profile: operator, lot, bench (the
        recorder adds the profile, the station host and the software version at the start).
    flush_interval_s : float
        Longest time between file flushes, s (<= 1).
    read_timeout_s : float
        Wait per adapter read, s (wall).
    backoff_initial_s, backoff_max_s : float
        Reconnect delays, s (wall): doubled after each failed attempt up to the maximum.
    answer_timeout_s : float
        Each unit must deliver a first sample within this time (wall s) of reporting that
        it reads its device (of the supplies' switch-on in a test sequence) or the run is
        refused: the time its process took to start and open the device does not count.
    reserve_bytes : int or None
        Stop once less than this can be written (default: 8 MiB + 10 s of data).
    """

    urls: tuple[str, ...]
    duration_s: float
    out: Path
    profile: Profile | None = None
    metadata: RunMetadata = dataclasses.field(default_factory=RunMetadata)
    flush_interval_s: float = 0.5
    read_timeout_s: float = 0.05
    backoff_initial_s: float = 0.05
    backoff_max_s: float = 1.0
    answer_timeout_s: float = 5.0
    reserve_bytes: int | None = None


def run_file_path(out: Path, uid: str) -> Path:
    """The run file: ``out`` itself if it ends in .h5/.hdf5, else a new name inside it."""
    if out.suffix.lower() in (".h5", ".hdf5"):
        return out
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return out / f"run-{stamp}-{uid[:8]}.h5"


def _check_against_profile(d: DeviceDescription, profile: Profile, *,
                           replayed: bool = False) -> list[str]:
    """What keeps unit ``d`` from a run of ``profile`` (one line each, with the fix). A
    replay (``replay://``: what a unit sent, as it sent it) is recorded at its own rate
    whatever the profile's: nothing can configure it, and grading notes the difference."""
    problems = []
    if not replayed and profile.sample_rate_hz is not None and not math.isclose(
            d.sample_rate_hz, profile.sample_rate_hz, rel_tol=1e-6):
        problems.append(f"the device reports {d.sample_rate_hz:g} Hz, profile "
                        f"{profile.name} expects {profile.sample_rate_hz:g} Hz: configure the "
                        f"device's output rate (URL key rate=) or choose the right profile")
    missing = [a for a in profile.axes if a not in d.axes]
    if missing:
        problems.append(f"the device has {d.n_axes} axes ({', '.join(d.axes)}), "
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
    on_listening : callable, optional
        Called once every unit reads its device, before the first samples are awaited:
        a test sequence switches the units' supplies on here, so that the recording
        holds their turn-on (the run then waits ``answer_timeout_s`` for their first
        samples).
    """

    #: Longest a unit's process may take to start and open its device, wall s.
    open_timeout_s = 120.0

    def __init__(self, config: RunConfig, subscribers: Sequence[Subscriber] = (), *,
                 on_listening: Callable[[], None] | None = None) -> None:
        if not config.urls:
            raise UsageError("no unit to record: give --unit DEVICE_URL (or a profile with "
                             "a transport url)")
        self.config = config
        self.uid = uuid.uuid4().hex
        self.path = run_file_path(config.out, self.uid)
        self.workers: list[UnitProcess] = []
        self.writer: RunFileWriter | None = None
        self.dispatcher = Dispatcher()
        self._extra = list(subscribers)
        self._on_listening = on_listening
        self._stop_reason: str | None = None
        self.stop_reason = ""
        self.engine_cpu_s = 0.0
        self.wall_s = 0.0

    # -- before the run ------------------------------------------------------------
    def estimate_bytes(self) -> int:
        """Estimated size of the run file, bytes (samples x bytes per sample, +5 %)."""
        total = 0.0
        for w in self.workers:
            per_sample = bytes_per_sample(w.descriptor())
            total += per_sample * w.descriptor().description.sample_rate_hz * \
                self.config.duration_s
        return int(total * 1.05) + (1 << 20)

    def _reserve(self) -> int:
        if self.config.reserve_bytes is not None:
            return self.config.reserve_bytes
        rate = sum(bytes_per_sample(w.descriptor()) * w.descriptor().description.sample_rate_hz
                   for w in self.workers)
        return int((8 << 20) + 10 * rate)

    def _open_units(self) -> list[Problem]:
        cfg = self.config
        profile = cfg.profile
        accel_g = profile.accel_range_g if profile is not None else None
        settings = ReadSettings(cfg.duration_s, cfg.read_timeout_s, cfg.backoff_initial_s,
                                cfg.backoff_max_s, accel_limit_m_s2=(
                                    None if accel_g is None else accel_g * STANDARD_GRAVITY_M_S2))
        limit = profile.range_deg_s if profile is not None else None
        self.workers = [UnitProcess(f"unit{i + 1}", url, settings, limit)
                        for i, url in enumerate(cfg.urls)]
        deadline = time.monotonic() + self.open_timeout_s
        found: list[Problem] = []
        for w in self.workers:
            w.wait_opened(max(1.0, deadline - time.monotonic()))
            problems: list[str] = []
            if profile is None and not is_simulated(w.url):
                problems.append("real hardware (and a replayed capture of it) needs --profile "
                                "PROFILE (it gives the model, sample rate and axes to check)")
            if w.opened is None:
                problems.append(
                    f"bad device URL: {w.problem}; see `station devices --json` for the URL "
                    f"of each protocol" if w.problem_stage == "url" else
                    f"device not reachable: {w.problem}; check that it is powered and "
                    f"connected, the port or address in the URL, and that no other program "
                    f"holds the port")
            elif profile is not None:
                problems += _check_against_profile(
                    w.opened.description, profile, replayed=w.opened.replayed)
            found += [Problem(text, w.unit_id, w.url) for text in problems]
        return found

    def _check_disk(self) -> list[Problem | str]:
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
            problems: list[Problem | str] = [*self._open_units()]
            if not problems:
                problems = self._check_disk()
            if not problems:
                self._start_units()
                since = 0.0
                if self._on_listening is not None:
                    self._await_units(lambda w: w.started.is_set(), self.open_timeout_s)
                    self._on_listening()
                    since = time.monotonic()  # the units answer from their switch-on
                problems = [*self._await_first_samples(since)]
        except BaseException:
            self._abort()
            raise
        if problems:
            self._abort()
            raise RunConfigurationError(problems)

    def check_units(self) -> tuple[DeviceDescription, ...]:
        """Open every unit, check it against the profile, wait for its first sample, and
        release it: what :meth:`prepare` checks of the units, with nothing written (no
        file, no folder). Returns each unit's description.

        Raises
        ------
        RunConfigurationError
            Every problem found with a unit.
        """
        try:
            problems = self._open_units()
            if not problems:
                self._start_units()
                problems = self._await_first_samples()
        finally:
            self._abort()
        if problems:
            raise RunConfigurationError(problems)
        return tuple(w.opened.description for w in self.workers if w.opened is not None)

    def _start_units(self) -> None:
        for w in self.workers:
            w.start(utc_now())

    def _await_units(self, ready: Callable[[UnitProcess], bool], timeout_s: float) -> None:
        """Take the units' messages until ``ready`` holds for each (or it ended), at most
        ``timeout_s`` wall s."""
        deadline = time.monotonic() + timeout_s
        waiting = list(self.workers)
        while waiting and time.monotonic() < deadline:
            readable = wait([w.conn for w in waiting], timeout=0.05)
            for w in waiting:
                if w.conn in readable:
                    w.receive()
            waiting = [w for w in waiting if not ready(w) and not w.done]

    def _await_first_samples(self, since: float = 0.0) -> list[Problem]:
        """Wait for every unit's first sample: ``answer_timeout_s`` from the moment the
        unit reported that it reads its device (or from ``since``, ``time.monotonic``,
        if later); returns a problem for each unit that sent none."""
        timeout_s, asked = self.config.answer_timeout_s, time.monotonic()

        def settled(w: UnitProcess) -> bool:
            now = time.monotonic()
            if w.answered.is_set():
                return True
            if w.started_at is None:  # not reading yet: its process is still starting
                return now - asked > self.open_timeout_s
            return now - max(w.started_at, since) > timeout_s

        self._await_units(settled, self.open_timeout_s + timeout_s)
        return [Problem(
            # a unit that ended on an error before its first sample says why (a device
            # configured without the output the protocol needs: devices.errors.NoRateError)
            f"ended before its first sample: {w.error}" if w.done and w.error else
            f"no sample within {self.config.answer_timeout_s:g} s: check the "
            f"protocol and rate in the URL, and that the device is streaming"
            + (f" ({w.error})" if w.error else "") + ("" if w.started_at is not None else
                                                      " (it did not start reading)"),
            w.unit_id, w.url)
            for w in self.workers if not w.answered.is_set()]

    def _abort(self) -> None:
        for w in self.workers:
            if w.start_utc:
                w.stop()
            else:
                w.close()
        for w in self.workers:
            while not w.done and w.receive(10.0):
                pass
            w.join()

    # -- the run -------------------------------------------------------------------
    def request_stop(self, reason: str) -> None:
        """Ask every unit to stop (safe from a signal handler); ``reason`` is recorded."""
        if self._stop_reason is None:
            self._stop_reason = reason

    def _dispatch_pending(self) -> None:
        for w in self.workers:
            pending, w.pending = w.pending, []
            for doc in pending:
                self.dispatcher.emit(doc)

    def _flush(self) -> None:
        assert self.writer is not None
        if self.writer.failed is not None:
            return
        try:
            self.writer.flush_if_due()
        except RecorderError as exc:
            self.request_stop(getattr(exc, "reason", "") or f"write error: {exc}")

    def run(self) -> RunStop:
        """Record until every unit is done; returns the stop document.

        :meth:`prepare` is called first if it was not.
        """
        if not self.workers:
            self.prepare()
        cfg = self.config
        t0, cpu0 = time.monotonic(), time.process_time()
        self.writer = RunFileWriter(self.path, flush_interval_s=cfg.flush_interval_s,
                                    reserve_bytes=self._reserve())
        subscribers: list[Subscriber] = [self.writer, *self._extra]
        for s in subscribers:
            self.dispatcher.subscribe(s)
        p = cfg.profile
        self.dispatcher.emit(RunStart(
            self.uid, min(w.start_utc for w in self.workers),
            tuple(w.unit_id for w in self.workers), cfg.duration_s, str(self.path),
            dataclasses.replace(
                cfg.metadata, profile=p.name if p else "", profile_version=p.version if p else "",
                profile_sha256=p.sha256 if p else "",
                profile_path=str(Path(p.path).resolve()) if p and p.path else "",
                station_host=socket.gethostname(), software_version=software_version())))
        for w in self.workers:
            self.dispatcher.emit(w.descriptor())
        stopping = False
        while not all(w.done for w in self.workers):
            active = [w for w in self.workers if not w.done]
            for conn in wait([w.conn for w in active], timeout=0.05):
                for w in active:
                    if w.conn is conn:
                        while w.receive():
                            pass
            self._dispatch_pending()
            self._flush()
            if self._stop_reason is not None and not stopping:
                stopping = True
                for w in self.workers:
                    w.stop()
        for w in self.workers:
            w.join()
        self._dispatch_pending()
        self.engine_cpu_s = time.process_time() - cpu0
        self.wall_s = time.monotonic() - t0
        ended = [w.end for w in self.workers if w.end is not None]
        self.stop_reason = self._stop_reason or self._device_lost() or (
            REASON_END_OF_REPLAY if ended and all(e.source_ended for e in ended)
            and len(ended) == len(self.workers) else REASON_DURATION)
        stop = RunStop(utc_now(), self.stop_reason, tuple(self._totals(w) for w in self.workers))
        self.dispatcher.emit(stop)
        return stop

    def _device_lost(self) -> str:
        """The stop reason of a run whose unit ended on an error (its device or its
        process lost) before the run's end, "" if none did."""
        lost = [w for w in self.workers if w.error]
        if not lost:
            return ""
        return (f"{REASON_DEVICE_LOST}: " + "; ".join(f"{w.unit_id} ({w.error})"
                                                      for w in lost))[:128]

    @staticmethod
    def _totals(w: UnitProcess) -> UnitTotals:
        t, end = w.tally, w.end
        return UnitTotals(w.unit_id, w.url, t.samples, t.missing, t.gaps, t.crc_errors,
                          t.reconnects, end.samples_sent if end else None, t.missing_low,
                          t.missing_high, t.bad_samples, end.cpu_s if end else 0.0,
                          end.reader_cpu_s if end else 0.0)
