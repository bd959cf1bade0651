"""The run file's writer: layout, SWMR writing, flushing, and a full disk.

:class:`RunFileWriter` is a subscriber of the recorder's documents (layout in
``docs/hdf5-layout.md``, constants in :mod:`station.storage.hdf5`). The file exists under its name
only once its whole layout is written and it is in SWMR mode (built under a hidden name,
then linked into place), so a recorder killed at any instant leaves either no file or one
that opens. Raw data carry Fletcher-32 checksums and go to the file at once (no chunk
cache), so a failed write fails the flush that made it, never later inside a destructor,
and a committed marker only ever counts data the operating system has taken (``fsync``).
"""

from __future__ import annotations

import errno
import json
import os
import socket
import time
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from station.errors import DiskSpaceError, OutputLostError, RecorderError
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
from station.storage.hdf5 import (
    EVENT_DTYPE,
    EVENT_UNITS,
    FORMAT,
    FORMAT_VERSION,
    SAMPLE_DATASETS,
    STATE_DTYPE,
    chunk_rows,
    fixed_text,
    writable_bytes,
)

_BATCH_FIELDS = {"rate": "rate_deg_s", "counter": "counter", "receive_time": "receive_time_s",
                 "status": "status", "device_time": "device_time_s",
                 "temperature": "temperature_c", "accel": "accel_m_s2",
                 "device_status": "device_status"}

#: Files whose writer failed on a full disk: their HDF5 objects are kept alive so that
#: nothing tries to flush them again at garbage collection or at exit (it would fail
#: again, print a traceback per object, and HDF5 can crash the interpreter at exit).
_ABANDONED: list[object] = []


#: What a failed write's errno means for the operator.
_FULL = {errno.ENOSPC: "no space left on device", errno.EFBIG: "file size limit reached",
         errno.EDQUOT: "disk quota exceeded"}


def _disk_full(exc: OSError | RuntimeError) -> str:
    """Why a write failed, when the disk (or a limit) is full; "" otherwise. HDF5 reports
    the system's errno inside its message (``errno = 28``)."""
    code = getattr(exc, "errno", None)
    if code in _FULL:
        return _FULL[code]
    message = str(exc).lower()
    for number, why in _FULL.items():
        if f"errno = {number}," in message or why in message:
            return why
    return "file too large" if "file too large" in message else ""


class RunFileWriter:
    """Writes run documents to one HDF5 file in SWMR mode (a subscriber of the recorder).

    The file is created once the run's start and every unit's descriptor have arrived:
    its whole layout is written under a hidden name, switched to SWMR mode and then
    linked to ``path``, so ``path`` never names a file a reader could not open. Samples
    are buffered per unit and written every ``flush_interval_s`` (s, wall clock):
    datasets resized, data written, file flushed and synced to disk, then the
    ``committed`` markers and the run state updated and flushed again, so a marker never
    counts data that are not on disk.

    Parameters
    ----------
    path : Path
        The file to create (must not exist).
    flush_interval_s : float
        Longest time between flushes, s (the issue asks at most 1 s).
    reserve_bytes : int
        Stop (raise :class:`DiskSpaceError`) once less than this much can still be written.
    sync : bool
        ``fsync`` the data before committing them (default True).

    Raises
    ------
    DiskSpaceError
        From :meth:`flush` when the disk (or the file size limit) is full.
    """

    def __init__(self, path: Path, *, flush_interval_s: float = 0.5,
                 reserve_bytes: int = 16 << 20, sync: bool = True) -> None:
        if not 0 < flush_interval_s <= 1.0:
            raise ValueError("flush_interval_s must be in (0, 1] s")
        self.path = Path(path)
        self.flush_interval_s = flush_interval_s
        self.reserve_bytes = reserve_bytes
        self.sync = sync
        self._file: h5py.File | None = None
        self._start_doc: RunStart | None = None
        self._descriptors: list[Descriptor] = []
        self._pending: dict[str, list[EventBatch]] = {}
        self._committed: dict[str, tuple[int, int]] = {}
        #: Per unit, the counts of what is committed on disk (samples, gaps, ...).
        self.committed: dict[str, UnitTally] = {}
        #: Per unit, the counts of what was handed to the writer (committed or not).
        self.received: dict[str, UnitTally] = {}
        self._last_flush = time.monotonic()
        #: When the last completed flush took its cut (UTC text): every sample handed to
        #: the writer before it is committed; "" before the first.
        self.last_flush_utc = ""
        self.flushes = 0
        self.stopped = False
        #: A write failed (a full disk): nothing more is written; the file is left open
        #: for ``station recover`` (its committed data are intact).
        self.failed: RecorderError | None = None
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
            self.received[document.unit_id].add(document)
        elif isinstance(document, RunStop):
            self.close(document.reason, document.stop_utc)

    def _h5(self) -> h5py.File:
        if self._file is None:
            raise RecorderError(f"{self.path}: the run file is not open (a run start and "
                                f"every unit's descriptor come first)")
        return self._file

    def _start(self, doc: RunStart) -> None:
        self._start_doc = doc
        if not doc.unit_ids:
            self._create()

    def _describe(self, doc: Descriptor) -> None:
        if self._start_doc is None or self._file is not None:
            raise RecorderError(f"{self.path}: a unit descriptor arrived outside the run's "
                                f"start ({doc.unit_id})")
        self._descriptors.append(doc)
        self._pending[doc.unit_id] = []
        self._committed[doc.unit_id] = (0, 0)
        self.committed[doc.unit_id] = UnitTally()
        self.received[doc.unit_id] = UnitTally()
        if len(self._descriptors) == len(self._start_doc.unit_ids):
            self._create()

    def _create(self) -> None:
        """Write the whole layout under a hidden name, go SWMR, link it to ``path``."""
        assert self._start_doc is not None
        self.path.parent.mkdir(parents=True, exist_ok=True)
        building = self.path.with_name(f".{self.path.name}.{os.getpid()}.creating")
        # No chunk cache: every chunk goes to the file inside the write call that made
        # it, so a full disk fails that call (not a flush later, nor a destructor).
        f = h5py.File(building, "w", libver="latest", rdcc_nbytes=0)
        try:
            write_layout(f, self._start_doc, self._descriptors,
                         flush_interval_s=self.flush_interval_s)
            f.flush()
            f.swmr_mode = True  # flushes the layout and marks the file for SWMR readers
            _link_into_place(building, self.path)
        except BaseException:
            f.close()
            building.unlink(missing_ok=True)
            raise
        self._file = f
        self._last_flush = time.monotonic()

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
            if name == "device_status":  # -1 where a sample came with no status word
                data = np.concatenate([b.device_status_words() for b in batches])
            else:
                parts = [getattr(b, _BATCH_FIELDS[name]) for b in batches]
                data = np.concatenate([p for p in parts if p is not None])
            ds = g[name]
            ds.resize(n0 + n, axis=0)
            ds[n0:n0 + n] = data
        log = [e for b in batches for e in b.log]
        if log:
            ev = g["events"]
            ev.resize(m0 + len(log), axis=0)
            ev[m0:] = events_array(log, ev.dtype)
        return n0 + n, m0 + len(log)

    def flush(self) -> None:
        """Write the buffered batches, flush and sync, then commit the markers and flush.

        Raises
        ------
        DiskSpaceError
            The disk or the file size limit is full (the data committed before are
            intact; nothing more is written), or fewer than ``reserve_bytes`` remain.
        RecorderError
            Another write failure (nothing more is written).
        """
        if self.failed is not None:
            raise self.failed
        f = self._h5()
        self._last_flush = time.monotonic()
        cut = utc_now()  # every batch handed over before now is in this flush
        self._check_kept(f)
        try:
            new = {uid: self._write_unit(f["units"][uid], batches)
                   for uid, batches in self._pending.items() if batches}
            f.flush()
            if self.sync and new:
                os.fsync(f.id.get_vfd_handle())
            for uid, counts in new.items():
                f["units"][uid]["committed"][:] = counts
                self._committed[uid] = counts
            f["run_state"]["last_flush_utc", 0] = cut.encode()
            f.flush()
            for uid in new:
                for batch in self._pending[uid]:
                    self.committed[uid].add(batch)
                self._pending[uid] = []
        except (OSError, RuntimeError) as exc:  # h5py raises either for a failed write
            why = _disk_full(exc) or ("no space left" if writable_bytes(self.path) < (64 << 10)
                                      else "")
            self.failed = (DiskSpaceError(f"disk full ({why}) writing {self.path}") if why
                           else RecorderError(f"cannot write {self.path}: {_short(exc)}"))
            self.failed.reason = f"disk full: {why}" if why else f"write error: {_short(exc)}"
            raise self.failed from exc
        self.flushes += 1
        self.last_flush_utc = cut
        try:
            left = writable_bytes(self.path)
        except OSError:  # the folder went away: the next flush says so
            return
        if left < self.reserve_bytes:
            error = DiskSpaceError(f"disk nearly full: {left / 1e6:.1f} MB left for "
                                   f"{self.path} (reserve {self.reserve_bytes / 1e6:.1f} MB)")
            error.reason = (f"disk full: disk nearly full, {left / 1e6:.1f} MB left "
                            f"(reserve {self.reserve_bytes / 1e6:.1f} MB)")
            raise error

    def _check_kept(self, f: h5py.File) -> None:
        """Raise :class:`OutputLostError` (and write nothing more) once the run file has
        no name left: it, or its folder, was removed while the recorder held it open."""
        if os.fstat(f.id.get_vfd_handle()).st_nlink > 0:
            return
        folder = self.path.parent
        what = (f"the output folder {folder} was removed" if not folder.exists()
                else f"the run file {self.path} was deleted")
        self.failed = OutputLostError(f"{what} while recording")
        self.failed.reason = ("output lost: folder removed" if not folder.exists()
                              else "output lost: run file deleted")
        raise self.failed

    def uncommitted(self, unit_id: str) -> int:
        """Samples of a unit handed to the writer, recorded or declared missing, but not
        committed (lost to the file if it failed)."""
        got, done = self.received[unit_id], self.committed[unit_id]
        return got.samples + got.missing - done.samples - done.missing

    def close(self, reason: str, stop_utc: str | None = None) -> None:
        """Flush what is left (if the disk allows), record the stop, close the file.

        After a failed write nothing is flushed again: the stop is written in place into
        the run state (its storage exists already, so a full disk still takes it), and
        the file is left open for ``station recover``, which keeps that reason.
        """
        if self._file is None:
            self.stopped = True
            return
        f, stop = self._file, stop_utc or utc_now()
        if self.failed is None:
            try:
                self.flush()
            except RecorderError as exc:
                if not reason.startswith(("disk full", "write error")):
                    reason = getattr(exc, "reason", str(exc))
        if self.failed is not None and not reason.startswith(("disk full", "write error")):
            reason = getattr(self.failed, "reason", str(self.failed))
        self._file = None
        self.stopped = True
        try:
            state = f["run_state"][0]
            state["state"], state["stop_utc"] = b"stopped", stop.encode()
            state["stop_reason"] = reason.encode()[:128]
            f["run_state"][0] = state
            if self.failed is None:
                f.attrs.modify("stop_utc", fixed_text(stop, 32))
                f.attrs.modify("stop_reason", fixed_text(reason, 128))
                f.flush()
        except (OSError, RuntimeError):
            self.close_failed = True
        if self.failed is not None or self.close_failed:
            self.close_failed = True
            _ABANDONED.append(f)  # never flushed again (see _ABANDONED)
            return
        try:
            f.close()
        except (OSError, RuntimeError):
            self.close_failed = True
            _ABANDONED.append(f)


def _short(exc: BaseException) -> str:
    """HDF5's message on one line, without its dump of names and buffer addresses."""
    text = " ".join(str(exc).split())
    for cut in (" (file write failed", ", filename = ", ", buf = ", ", file descriptor = "):
        text = text.split(cut)[0]
    return text[:160]


def _link_into_place(building: Path, path: Path) -> None:
    """Give the finished file its name (never over an existing file) and drop the
    hidden one."""
    try:
        os.link(building, path)
    except FileExistsError:
        raise RecorderError(f"{path} exists already: choose another --out") from None
    except OSError:  # a file system without hard links
        if path.exists():
            raise RecorderError(f"{path} exists already: choose another --out") from None
        os.rename(building, path)
        return
    building.unlink()


def _checked_dataset(g: h5py.Group, name: str, **kwargs: Any) -> h5py.Dataset:
    """A chunked dataset whose chunks carry Fletcher-32 checksums (a flipped bit or a
    block past the end of the file fails the read instead of passing as data)."""
    return g.create_dataset(name, fletcher32=True, **kwargs)


def write_layout(f: h5py.File, doc: RunStart, descriptors: list[Descriptor], *,
                 flush_interval_s: float | None = None) -> None:
    """Root metadata, run state and every unit's group, datasets and markers (with the
    writer's ``flush_interval_s``, s, when given: how a reader tells a recorder gone)."""
    metadata = doc.metadata.as_attributes()
    metadata["station_host"] = metadata["station_host"] or socket.gethostname()
    meta = {"format": FORMAT, "format_version": FORMAT_VERSION, "run_uid": doc.uid,
            **metadata, "start_utc": doc.start_utc, "duration_requested_s": doc.duration_s,
            "writer_pid": os.getpid(), "unit_ids": json.dumps(list(doc.unit_ids))}
    f.attrs.update(meta)
    f.attrs["duration_requested_s_units"] = "s"
    if flush_interval_s is not None:
        f.attrs["flush_interval_s"] = flush_interval_s
        f.attrs["flush_interval_s_units"] = "s"
    # Fixed-size so they can be modified in place in SWMR mode and on a full disk.
    f.attrs.create("stop_utc", fixed_text("", 32))
    f.attrs.create("stop_reason", fixed_text("", 128))
    state = np.zeros(1, STATE_DTYPE)
    state[0] = (b"recording", b"", b"", doc.start_utc.encode())
    _checked_dataset(f, "run_state", data=state, chunks=(1,))
    units = f.create_group("units")
    for desc in descriptors:
        _unit_layout(units, desc)


def _unit_layout(units: h5py.Group, doc: Descriptor) -> None:
    d = doc.description
    g = units.create_group(doc.unit_id)
    g.attrs.update({
        "unit_id": doc.unit_id, "url": doc.url, "model": d.model,
        "serial_number": d.serial_number, "protocol": d.protocol,
        "transport": d.transport, "axes": json.dumps(list(d.axes)),
        "sample_rate_hz": d.sample_rate_hz, "sample_rate_hz_units": "Hz",
        "counter_modulus": -1 if d.counter_modulus is None else d.counter_modulus,
        "has_device_time": d.has_device_time, "has_temperature": d.has_temperature,
        "settings": json.dumps(dict(d.settings)), "start_utc": doc.start_utc,
        "time_base": doc.time_base, "time_warp": doc.time_warp,
        # the rate word's step on the link (0.0: not known): devices/resolution.py
        "lsb_deg_s": d.lsb_deg_s, "lsb_deg_s_units": "deg/s", "lsb_relative": d.lsb_relative})
    if d.accel_axes:
        g.attrs["accel_axes"] = json.dumps(list(d.accel_axes))
    rows = chunk_rows(d.sample_rate_hz)
    for key in doc.keys:
        ds = _checked_dataset(g, key.name, shape=(0, *key.shape), maxshape=(None, *key.shape),
                              chunks=(rows, *key.shape), dtype=key.dtype)
        ds.attrs.update({"units": key.unit, "description": key.description})
        if key.name == "rate":
            ds.attrs["axes"] = json.dumps(list(d.axes))
        if key.name == "accel":
            ds.attrs["axes"] = json.dumps(list(d.accel_axes))
    ev = _checked_dataset(g, "events", shape=(0,), maxshape=(None,), chunks=(256,),
                          dtype=EVENT_DTYPE)
    ev.attrs.update({"units": json.dumps(EVENT_UNITS),
                     "description": "event log: connects, disconnects, CRC errors, "
                                    "resyncs, bad samples, gaps (missing_samples, "
                                    "missing_low, missing_high, method)"})
    c = _checked_dataset(g, "committed", data=np.zeros(2, np.int64), chunks=(2,))
    c.attrs.update({"units": "1", "description": "[samples, events] on disk at the "
                                                 "last flush: read no further"})


def events_array(log: list[LogEntry], dtype: np.dtype = EVENT_DTYPE) -> NDArray[np.void]:
    """Event-log entries as rows of :data:`EVENT_DTYPE` (or of an older file's ``dtype``)."""
    rows = np.zeros(len(log), dtype)
    names = set(dtype.names or ())
    for i, e in enumerate(log):
        values = {"time_s": e.time_s, "kind": e.kind.encode()[:16], "count": e.count,
                  "missing_samples": e.missing_samples, "after_counter": e.after_counter,
                  "method": e.method.encode()[:16], "detail": e.detail.encode()[:120],
                  "missing_low": e.low, "missing_high": e.high}
        for name, value in values.items():
            if name in names:
                rows[i][name] = value
    return rows
