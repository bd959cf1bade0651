"""The run file: HDF5 layout, the SWMR writer, the reader, and recovery after a crash.

The layout is documented in ``docs/hdf5-layout.md``. In short: one file per run, one
group per unit under ``/units``, one chunked, resizable dataset per recorded quantity
(every dataset carries its ``units`` attribute), a compound ``events`` log per unit, and
a ``committed`` marker per unit telling how many samples and log entries were on disk at
the last flush. The writer runs in SWMR mode and flushes at least every
``flush_interval_s`` so that a live reader (``station watch``, the TUI) reads while it
writes; after a SIGKILL the file opens with ``h5py.File(path, "r", swmr=True)`` and
everything up to the last flush is there. :func:`recover_run` closes such a file
properly (:mod:`station.hdf5_recover`: clears the superblock's open-for-write flags,
trims to the committed lengths, records the run as interrupted).
"""

from __future__ import annotations

import errno
import json
import os
import resource
import shutil
import socket
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from station.errors import DiskSpaceError, RecorderError, RecordFormatError
from station.model.documents import (
    Descriptor,
    Document,
    EventBatch,
    LogEntry,
    RunStart,
    RunStop,
    UnitTally,
    utc_now,
)
from station.model.records import RateRecord
from station.model.runs import RunEvent, RunInfo, UnitRun

FORMAT = "gyro-station-run"
FORMAT_VERSION = 1
#: Stop reason of a run that ended at its duration (any other reason is an interruption).
REASON_DURATION = "duration"
#: Every unit was a replayed capture, and each reached its end before the duration.
REASON_END_OF_REPLAY = "end of the replayed capture"
REASON_RECOVERED = "interrupted: the recorder stopped without closing the file (recovered)"

EVENT_DTYPE = np.dtype([("time_s", "<f8"), ("kind", "S16"), ("count", "<i8"),
                        ("missing_samples", "<i8"), ("after_counter", "<i8"),
                        ("method", "S16"), ("detail", "S120")])
EVENT_UNITS = {"time_s": "s", "kind": "", "count": "1", "missing_samples": "1",
               "after_counter": "1", "method": "", "detail": ""}
STATE_DTYPE = np.dtype([("state", "S16"), ("stop_utc", "S32"), ("stop_reason", "S128"),
                        ("last_flush_utc", "S32")])
#: Per-sample datasets of a unit, in the order the reader checks them.
SAMPLE_DATASETS = ("rate", "counter", "receive_time", "status", "device_time", "temperature")
_BATCH_FIELDS = {"rate": "rate_deg_s", "counter": "counter", "receive_time": "receive_time_s",
                 "status": "status", "device_time": "device_time_s",
                 "temperature": "temperature_c"}


def chunk_rows(sample_rate_hz: float) -> int:
    """Rows per chunk: about one second of samples, a power of two in 256..16384."""
    rows = 2 ** int(np.ceil(np.log2(max(sample_rate_hz, 1.0))))
    return int(min(max(rows, 256), 16384))


def bytes_per_sample(descriptor: Descriptor) -> int:
    """Bytes one sample of this unit takes on disk (all its data keys)."""
    return sum(int(np.dtype(k.dtype).itemsize * int(np.prod(k.shape, dtype=np.int64)))
               for k in descriptor.keys)


def writable_bytes(path: Path) -> int:
    """Bytes that can still be written to ``path``: free disk space, or the process's file
    size limit (RLIMIT_FSIZE) minus the file's size when that is smaller."""
    free = shutil.disk_usage(path.parent).free
    limit, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if limit != resource.RLIM_INFINITY:
        size = path.stat().st_size if path.exists() else 0
        free = min(free, max(0, limit - size))
    return int(free)


def text_value(value: Any) -> str:
    """An HDF5 attribute or field as text (bytes decoded as UTF-8)."""
    if isinstance(value, bytes | np.bytes_):
        return bytes(value).decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.shape == ():
        return text_value(value[()])
    return str(value)


def fixed_text(text: str, size: int) -> np.ndarray:
    """``text`` as a fixed-size byte string of ``size`` bytes (truncated)."""
    return np.array(text.encode("utf-8")[:size], dtype=f"S{size}")


def _is_disk_full(exc: OSError | RuntimeError) -> bool:
    message = str(exc).lower()
    return (getattr(exc, "errno", None) in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT)
            or "no space" in message or "file too large" in message)


class RunFileWriter:
    """Writes run documents to one HDF5 file in SWMR mode (a subscriber of the recorder).

    Samples are buffered per unit and written every ``flush_interval_s`` (s, wall clock):
    datasets resized, data written, file flushed, then the ``committed`` markers and the
    run state updated and flushed again, so a marker never counts unflushed data.

    Parameters
    ----------
    path : Path
        The file to create (must not exist).
    flush_interval_s : float
        Longest time between flushes, s (the issue asks at most 1 s).
    reserve_bytes : int
        Stop (raise :class:`DiskSpaceError`) once less than this much can still be written.

    Raises
    ------
    DiskSpaceError
        From :meth:`flush` when the disk (or the file size limit) is full.
    """

    def __init__(self, path: Path, *, flush_interval_s: float = 0.5,
                 reserve_bytes: int = 16 << 20) -> None:
        if not 0 < flush_interval_s <= 1.0:
            raise ValueError("flush_interval_s must be in (0, 1] s")
        self.path = Path(path)
        self.flush_interval_s = flush_interval_s
        self.reserve_bytes = reserve_bytes
        self._file: h5py.File | None = None
        self._pending: dict[str, list[EventBatch]] = {}
        self._committed: dict[str, tuple[int, int]] = {}
        #: Per unit, the counts of what is committed on disk (samples, gaps, ...).
        self.committed: dict[str, UnitTally] = {}
        self._last_flush = time.monotonic()
        self.flushes = 0
        self.stopped = False
        #: The final flush or close failed (a full disk): HDF5 still holds the file open.
        self.close_failed = False

    # -- documents -----------------------------------------------------------------
    def __call__(self, document: Document) -> None:
        """Take one run document."""
        if isinstance(document, RunStart):
            self._start(document)
        elif isinstance(document, Descriptor):
            self._describe(document)
        elif isinstance(document, EventBatch):
            self._pending[document.unit_id].append(document)
        elif isinstance(document, RunStop):
            self.close(document.reason, document.stop_utc)

    def _h5(self) -> h5py.File:
        if self._file is None:
            raise RecorderError(f"{self.path}: the run file is not open")
        return self._file

    def _start(self, doc: RunStart) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        f = h5py.File(self.path, "w-", libver="latest")
        self._file = f
        meta = {"format": FORMAT, "format_version": FORMAT_VERSION, "run_uid": doc.uid,
                "profile": doc.profile, "profile_version": doc.profile_version,
                "profile_sha256": doc.profile_sha256, "profile_path": doc.profile_path,
                "operator": doc.operator,
                "lot": doc.lot, "station_host": doc.station_host or socket.gethostname(),
                "software_version": doc.software_version, "start_utc": doc.start_utc,
                "duration_requested_s": doc.duration_s, "writer_pid": os.getpid(),
                "unit_ids": json.dumps(list(doc.unit_ids)), "bench": doc.bench}
        f.attrs.update(meta)
        f.attrs["duration_requested_s_units"] = "s"
        # Fixed-size so they can be modified in place in SWMR mode and on a full disk.
        f.attrs.create("stop_utc", fixed_text("", 32))
        f.attrs.create("stop_reason", fixed_text("", 128))
        state = np.zeros(1, STATE_DTYPE)
        state[0] = (b"recording", b"", b"", doc.start_utc.encode())
        f.create_dataset("run_state", data=state)
        f.create_group("units")

    def _describe(self, doc: Descriptor) -> None:
        f = self._h5()
        d = doc.description
        g = f["units"].create_group(doc.unit_id)
        g.attrs.update({
            "unit_id": doc.unit_id, "url": doc.url, "model": d.model,
            "serial_number": d.serial_number, "protocol": d.protocol,
            "transport": d.transport, "axes": json.dumps(list(d.axes)),
            "sample_rate_hz": d.sample_rate_hz, "sample_rate_hz_units": "Hz",
            "counter_modulus": -1 if d.counter_modulus is None else d.counter_modulus,
            "has_device_time": d.has_device_time, "has_temperature": d.has_temperature,
            "settings": json.dumps(dict(d.settings)), "start_utc": doc.start_utc,
            "time_base": doc.time_base, "time_warp": doc.time_warp})
        rows = chunk_rows(d.sample_rate_hz)
        for key in doc.keys:
            ds = g.create_dataset(key.name, shape=(0, *key.shape), maxshape=(None, *key.shape),
                                  chunks=(rows, *key.shape), dtype=key.dtype)
            ds.attrs.update({"units": key.unit, "description": key.description})
            if key.name == "rate":
                ds.attrs["axes"] = json.dumps(list(d.axes))
        ev = g.create_dataset("events", shape=(0,), maxshape=(None,), chunks=(256,),
                              dtype=EVENT_DTYPE)
        ev.attrs.update({"units": json.dumps(EVENT_UNITS),
                         "description": "event log: connects, disconnects, CRC errors, "
                                        "resyncs, gaps (missing_samples, method)"})
        c = g.create_dataset("committed", data=np.zeros(2, np.int64))
        c.attrs.update({"units": "1", "description": "[samples, events] on disk at the "
                                                     "last flush: read no further"})
        self._pending[doc.unit_id] = []
        self._committed[doc.unit_id] = (0, 0)
        self.committed[doc.unit_id] = UnitTally()

    # -- flushing ------------------------------------------------------------------
    def flush_if_due(self) -> None:
        """Flush when ``flush_interval_s`` has passed since the last flush."""
        if time.monotonic() - self._last_flush >= self.flush_interval_s:
            self.flush()

    def _write_unit(self, g: h5py.Group, batches: list[EventBatch]) -> tuple[int, int]:
        n0, m0 = self._committed[g.name.rsplit("/", 1)[-1]]
        n = sum(len(b) for b in batches)
        for name in SAMPLE_DATASETS:
            if name not in g or n == 0:
                continue
            parts = [getattr(b, _BATCH_FIELDS[name]) for b in batches]
            data = np.concatenate([p for p in parts if p is not None])
            ds = g[name]
            ds.resize(n0 + n, axis=0)
            ds[n0:n0 + n] = data
        log = [e for b in batches for e in b.log]
        if log:
            ev = g["events"]
            ev.resize(m0 + len(log), axis=0)
            ev[m0:] = events_array(log)
        return n0 + n, m0 + len(log)

    def flush(self) -> None:
        """Write the buffered batches, flush, then commit the markers and flush again.

        Raises
        ------
        DiskSpaceError
            The disk or the file size limit is full (the data committed before are
            intact), or fewer than ``reserve_bytes`` remain.
        """
        f = self._h5()
        self._last_flush = time.monotonic()
        try:
            if not f.swmr_mode:
                f.swmr_mode = True
            new = {uid: self._write_unit(f["units"][uid], batches)
                   for uid, batches in self._pending.items() if batches}
            f.flush()
            for uid, counts in new.items():
                f["units"][uid]["committed"][:] = counts
                self._committed[uid] = counts
            f["run_state"]["last_flush_utc", 0] = utc_now().encode()
            f.flush()
            for uid in new:
                for batch in self._pending[uid]:
                    self.committed[uid].add(batch)
                self._pending[uid] = []
        except (OSError, RuntimeError) as exc:  # h5py raises either for a failed write
            if _is_disk_full(exc) or writable_bytes(self.path) < self.reserve_bytes:
                raise DiskSpaceError(f"disk full while writing {self.path}: {exc}") from exc
            raise RecorderError(f"cannot write {self.path}: {exc}") from exc
        self.flushes += 1
        left = writable_bytes(self.path)
        if left < self.reserve_bytes:
            raise DiskSpaceError(f"disk nearly full: {left / 1e6:.1f} MB left for {self.path} "
                                 f"(reserve {self.reserve_bytes / 1e6:.1f} MB)")

    def close(self, reason: str, stop_utc: str | None = None) -> None:
        """Flush what is left (if the disk allows), record the stop, close the file."""
        if self._file is None:
            return
        f, stop = self._file, stop_utc or utc_now()
        try:
            try:
                self.flush()
            except DiskSpaceError as exc:
                if "disk" not in reason:
                    reason = f"disk full: {exc}"
            state = f["run_state"][0]
            state["state"], state["stop_utc"] = b"stopped", stop.encode()
            state["stop_reason"] = reason.encode()[:128]
            f["run_state"][0] = state
            f.attrs.modify("stop_utc", fixed_text(stop, 32))
            f.attrs.modify("stop_reason", fixed_text(reason, 128))
            f.flush()
        except (OSError, RuntimeError):
            self.close_failed = True  # a full disk: the committed data stand
        finally:
            self._file = None
            self.stopped = True
            try:
                f.close()
            except (OSError, RuntimeError):
                self.close_failed = True


def events_array(log: list[LogEntry]) -> NDArray[np.void]:
    """Event-log entries as rows of :data:`EVENT_DTYPE`."""
    rows = np.zeros(len(log), EVENT_DTYPE)
    for i, e in enumerate(log):
        rows[i] = (e.time_s, e.kind.encode()[:16], e.count, e.missing_samples,
                   e.after_counter, e.method.encode()[:16], e.detail.encode()[:120])
    return rows


# -- reading -------------------------------------------------------------------------

def open_run_file(path: str | Path) -> h5py.File:
    """Open a run file read-only in SWMR mode (live, killed, closed or recovered alike).

    Raises
    ------
    RecordFormatError
        Not an HDF5 file, or not a run file of this station.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(2, "No such file", str(path))
    try:
        f = h5py.File(path, "r", swmr=True)
    except OSError as exc:
        raise RecordFormatError(f"{path}: cannot open as an HDF5 run file: {exc}") from exc
    if text_value(f.attrs.get("format", "")) != FORMAT:
        f.close()
        raise RecordFormatError(f"{path}: not a gyro-station run file (no format={FORMAT!r})")
    return f


def run_state(f: h5py.File) -> dict[str, str]:
    """The run state row (``state``, ``stop_utc``, ``stop_reason``, ``last_flush_utc``)."""
    ds = f["run_state"]
    ds.refresh()
    row = ds[0]
    return {name: text_value(row[name]) for name in STATE_DTYPE.names or ()}


@dataclass(frozen=True)
class UnitData:
    """The committed data of one unit of a run file (read-only arrays, units as stored)."""

    unit_id: str
    attrs: dict[str, Any]
    rate_deg_s: NDArray[np.float64]
    counter: NDArray[np.int64]
    receive_time_s: NDArray[np.float64]
    status: NDArray[np.uint32]
    device_time_s: NDArray[np.float64] | None
    temperature_c: NDArray[np.float64] | None
    events: NDArray[np.void]

    @property
    def axes(self) -> tuple[str, ...]:
        """Axis names, in the column order of ``rate_deg_s``."""
        return tuple(json.loads(self.attrs["axes"]))

    @property
    def sample_rate_hz(self) -> float:
        """Nominal sample rate, Hz."""
        return float(self.attrs["sample_rate_hz"])


def unit_ids(f: h5py.File) -> list[str]:
    """Unit ids of a run file, in recording order."""
    return list(json.loads(text_value(f.attrs["unit_ids"])))


def read_unit(f: h5py.File, unit_id: str, *, start: int = 0) -> UnitData:
    """Committed samples ``start:`` and the committed event log of one unit.

    Only what the ``committed`` marker counts is read: data written after the last flush
    of a killed recorder are ignored.
    """
    g = f["units"][unit_id]
    for ds in g.values():
        ds.refresh()
    n = min([int(g["committed"][0]), *(g[k].shape[0] for k in SAMPLE_DATASETS if k in g)])

    def col(name: str) -> Any:
        return g[name][start:n] if name in g else None

    attrs = {k: (text_value(v) if isinstance(v, bytes | str | np.bytes_) else v.item()
                 if isinstance(v, np.generic) else v) for k, v in g.attrs.items()}
    return UnitData(unit_id, attrs, col("rate"), col("counter"), col("receive_time"),
                    col("status"), col("device_time"), col("temperature"),
                    committed_events(f, unit_id))


def committed_events(f: h5py.File, unit_id: str) -> NDArray[np.void]:
    """The committed event log of one unit (rows of :data:`EVENT_DTYPE`)."""
    g = f["units"][unit_id]
    g["committed"].refresh()
    g["events"].refresh()
    return g["events"][:min(int(g["committed"][1]), g["events"].shape[0])]


@dataclass(frozen=True)
class UnitCounts:
    """Counts of one unit from its committed data and event log."""

    unit_id: str
    samples_recorded: int
    samples_missing_declared: int
    gaps: int
    crc_errors: int
    reconnects: int
    disconnects: int
    last_time_s: float


def unit_counts(f: h5py.File, unit_id: str) -> UnitCounts:
    """Samples, missing samples, gaps, CRC errors, reconnects of one unit (committed)."""
    ev = committed_events(f, unit_id)
    g = f["units"][unit_id]
    n = int(g["committed"][0])
    kinds = ev["kind"]
    last = float(g["receive_time"][n - 1]) if n else 0.0
    return UnitCounts(unit_id, n, int(ev["missing_samples"][kinds == b"gap"].sum()),
                      int((kinds == b"gap").sum()),
                      int(ev["count"][kinds == b"crc_error"].sum()),
                      int((kinds == b"reconnect").sum()), int((kinds == b"disconnect").sum()),
                      last)


def run_events(unit: UnitData) -> tuple[RunEvent, ...]:
    """A unit's event log as :class:`RunEvent` s (the gap method goes in the detail)."""
    out = []
    for row in unit.events:
        method, detail = text_value(row["method"]), text_value(row["detail"])
        text = "; ".join(t for t in (f"counted by {method}" if method else "", detail) if t)
        out.append(RunEvent(unit.unit_id, text_value(row["kind"]), float(row["time_s"]),
                            int(row["count"]), int(row["missing_samples"]), text))
    return tuple(out)


def gap_sample_index(counter: NDArray[np.int64], receive_time_s: NDArray[np.float64],
                     events: NDArray[np.void]) -> NDArray[np.int64] | None:
    """Grid index of each sample from the unit's gap events (None when no gap is inside).

    A gap goes after the sample whose counter is its ``after_counter``; a gap without one
    (-1, or a counter not among the samples) goes before the first sample received at or
    after its ``time_s``. Gaps before the first sample or after the last (a simulated
    unit's samples made before it was first read) are outside the record. Fields are read
    by name, so a log with more columns reads the same.
    """
    n = len(counter)
    names = events.dtype.names or ()
    gaps = events[events["kind"] == b"gap"] if "kind" in names else events[:0]
    if n == 0 or len(gaps) == 0:
        return None
    inserted = np.zeros(n, dtype=np.int64)
    for row in gaps:
        after = int(row["after_counter"]) if "after_counter" in names else -1
        i = int(np.searchsorted(counter, after, side="right")) if after >= 0 else -1
        if i <= 0 or counter[i - 1] != after:
            i = int(np.searchsorted(receive_time_s, float(row["time_s"]), side="left"))
        if 0 < i < n:
            inserted[i] += int(row["missing_samples"])
    if not inserted.any():
        return None
    return np.arange(n, dtype=np.int64) + np.cumsum(inserted)


def unit_record(unit: UnitData, source: str) -> RateRecord:
    """The unit's committed samples as a :class:`RateRecord` (deg/s), gaps on its time grid."""
    index = gap_sample_index(np.asarray(unit.counter), np.asarray(unit.receive_time_s), unit.events)
    return RateRecord(np.asarray(unit.rate_deg_s, dtype=np.float64), unit.sample_rate_hz,
                      unit.axes, source, unit.temperature_c, index)


def read_run(path: str | Path) -> RunInfo:
    """Read a run file into a :class:`RunInfo` (the interface grading, reports, TUI use).

    A run whose file was never closed (recorder killed) reads as ``interrupted``.

    Raises
    ------
    RecordFormatError
        Not a run file of this station.
    """
    with open_run_file(path) as f:
        state = run_state(f)
        units = []
        for uid in unit_ids(f):
            u = read_unit(f, uid)
            units.append(UnitRun(
                unit_id=uid, model=u.attrs["model"], serial_number=u.attrs["serial_number"],
                record=unit_record(u, f"{path}#{uid}"), protocol=u.attrs["protocol"],
                transport=u.attrs["transport"], settings=json.loads(u.attrs["settings"]),
                events=run_events(u)))
        a = {k: text_value(v) for k, v in f.attrs.items()}
    stopped = state["state"] == "stopped"
    return RunInfo(
        path=str(path), units=tuple(units), profile=a.get("profile", ""),
        profile_version=a.get("profile_version", ""),
        profile_sha256=a.get("profile_sha256", ""), profile_path=a.get("profile_path", ""),
        operator=a.get("operator", ""), lot=a.get("lot", ""),
        station_host=a.get("station_host", ""),
        software_version=a.get("software_version", ""), start_utc=a.get("start_utc", ""),
        bench=a.get("bench", ""),
        stop_utc=state["stop_utc"] if stopped else state["last_flush_utc"],
        stop_reason=state["stop_reason"] if stopped else "interrupted: file not closed "
                                                         "(recorder killed or crashed)",
        interrupted=not (stopped and state["stop_reason"] in (REASON_DURATION,
                                                               REASON_END_OF_REPLAY)))


def run_attributes(path: str | Path) -> dict[str, str]:
    """The run file's root attributes as text (profile, operator, start_utc, ...)."""
    with open_run_file(path) as f:
        return {k: text_value(v) for k, v in f.attrs.items()}


def read_run_record(path: str | Path, unit: str | None = None) -> RateRecord:
    """One unit's record from a run file (default: the first unit), by unit id or serial.

    Raises
    ------
    RecordFormatError
        No such unit (the message lists the units).
    """
    with open_run_file(path) as f:
        ids = unit_ids(f)
        if not ids:
            raise RecordFormatError(f"{path}: the run has no units")
        chosen = ids[0] if unit is None else None
        for uid in ids:
            if unit in (uid, text_value(f["units"][uid].attrs["serial_number"])):
                chosen = uid
                break
        if chosen is None:
            raise RecordFormatError(f"{path}: no unit {unit!r}; units: {', '.join(ids)}")
        return unit_record(read_unit(f, chosen), f"{path}#{chosen}")
