"""The run file: HDF5 layout, the reader, and what recovery after a crash relies on.

The layout is documented in ``docs/hdf5-layout.md``. In short: one file per run, one
group per unit under ``/units``, one chunked, resizable dataset per recorded quantity
(every dataset carries its ``units`` attribute), a compound ``events`` log per unit, and
a ``committed`` marker per unit telling how many samples and log entries were on disk at
the last flush. The writer runs in SWMR mode and flushes at least every
``flush_interval_s`` so that a live reader (``station watch``, the TUI) reads while it
writes; after a SIGKILL the file opens with ``h5py.File(path, "r", swmr=True)`` and
everything up to the last flush is there. :func:`recover_run` closes such a file
properly (:mod:`station.storage.hdf5_recover`: clears the superblock's open-for-write flags,
trims to the committed lengths, records the run as interrupted).

The writer is :class:`station.storage.hdf5_writer.RunFileWriter`. Readers open files through
:mod:`station.storage.hdf5_open` (no SWMR hang on a damaged file, one-line errors).
"""

from __future__ import annotations

import json
import resource
import shutil
import time
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from station.errors import RecordFormatError
from station.model.documents import Descriptor
from station.model.kinds import log_kind
from station.model.records import RateRecord
from station.model.runs import RunEvent, RunInfo, RunMetadata, UnitRun
from station.storage.hdf5_open import chunks_within, cut_short, open_h5, reading, refresh_alone

FORMAT = "gyro-station-run"
FORMAT_VERSION = 1
#: Stop reason of a run that ended at its duration (any other reason is an interruption).
REASON_DURATION = "duration"
#: Every unit was a replayed capture, and each reached its end before the duration.
REASON_END_OF_REPLAY = "end of the replayed capture"
#: A unit ended on an error (its device, or the process reading it, was lost) before
#: the run's end; the units named follow it.
REASON_DEVICE_LOST = "device lost"
REASON_RECOVERED = "interrupted: the recorder stopped without closing the file (recovered)"

#: Event-log rows. ``missing_low`` and ``missing_high`` (format 1 files written before
#: they were added lack them: read them with :func:`gap_bounds`) bound what a gap may
#: have lost when the wrap count of a counter is not certain.
EVENT_DTYPE = np.dtype([("time_s", "<f8"), ("kind", "S16"), ("count", "<i8"),
                        ("missing_samples", "<i8"), ("after_counter", "<i8"),
                        ("method", "S16"), ("detail", "S120"), ("missing_low", "<i8"),
                        ("missing_high", "<i8")])
EVENT_UNITS = {"time_s": "s", "kind": "", "count": "1", "missing_samples": "1",
               "after_counter": "1", "method": "", "detail": "", "missing_low": "1",
               "missing_high": "1"}
STATE_DTYPE = np.dtype([("state", "S16"), ("stop_utc", "S32"), ("stop_reason", "S128"),
                        ("last_flush_utc", "S32")])
#: Per-sample datasets of a unit, in the order the reader checks them.
SAMPLE_DATASETS = ("rate", "counter", "receive_time", "status", "device_time", "temperature",
                   "accel", "device_status")


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


# -- reading -------------------------------------------------------------------------

@contextmanager
def open_run_file(path: str | Path) -> Iterator[h5py.File]:
    """A run file opened read-only (live, killed, closed or recovered alike), for a
    ``with`` block; an HDF5 failure inside the block is a one-line RecordFormatError.

    A file no writer holds is opened without SWMR; one a recorder holds (live or killed)
    as a SWMR reader that gives up on a damaged block at once (:mod:`station.storage.hdf5_open`).

    Raises
    ------
    RecordFormatError
        Not an HDF5 file, not a run file of this station, truncated or damaged.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(2, "No such file", str(path))
    f = open_h5(path)
    try:
        with reading(path):
            if "format" not in f.attrs:  # (H5Aexists: a damaged header fails it)
                raise RecordFormatError(f"{path}: not a gyro-station run file (no "
                                        f"format={FORMAT!r} attribute)")
            if text_value(f.attrs["format"]) != FORMAT:
                raise RecordFormatError(f"{path}: not a gyro-station run file (its format "
                                        f"is {text_value(f.attrs['format'])!r})")
            yield f
    finally:
        try:
            f.close()
        except (OSError, RuntimeError):
            pass


def run_state(f: h5py.File) -> dict[str, str]:
    """The run state row (``state``, ``stop_utc``, ``stop_reason``, ``last_flush_utc``)."""
    row = refresh_alone(f["run_state"])[0]
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
    #: Specific force, m/s^2 (N, j), one row per rate row; None for a gyro-only unit.
    accel_m_s2: NDArray[np.float64] | None = None
    accel_axes: tuple[str, ...] = ()
    #: The device's status word of each sample as sent (-1: none came with it); None in
    #: a file written before the station kept it. Validity is ``status`` alone.
    device_status: NDArray[np.int64] | None = None

    @property
    def valid(self) -> NDArray[np.bool_]:
        """Which samples the device says are good (``status == 0``: the one convention
        of every protocol, docs/hdf5-layout.md)."""
        return np.asarray(self.status) == 0

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
    for name in list(g):
        if not isinstance(g[name], h5py.Dataset):
            raise RecordFormatError(f"{f.filename}: damaged run file: {unit_id}/{name} is "
                                    f"not a dataset; `station recover {f.filename}` "
                                    f"salvages what is readable")
    n = min([int(refresh_alone(g["committed"])[0]),
             *(refresh_alone(g[k]).shape[0] for k in SAMPLE_DATASETS if k in g)])

    def col(name: str) -> Any:
        return _rows(g[name], start, n) if name in g else None

    _check_inside(f, g, [k for k in SAMPLE_DATASETS if k in g], start, n)

    status, device_status = col("status"), col("device_status")
    if word_in_status(g):
        status, device_status = np.zeros_like(status), np.asarray(status, np.int64)
    return UnitData(unit_id, unit_attributes(g), col("rate"), col("counter"), col("receive_time"),
                    status, col("device_time"), col("temperature"),
                    committed_events(f, unit_id), col("accel"), accel_axis_names(g),
                    device_status)


#: Protocols whose ``status`` held the device's own word, not validity, in files written
#: before ``device_status`` existed (the Xsens StatusWord, whose bits mean good).
WORD_IN_STATUS = frozenset({"xbus"})


def word_in_status(g: h5py.Group) -> bool:
    """Whether the unit group ``g`` is of a file written before ``device_status`` existed
    whose ``status`` holds the device's own word (:data:`WORD_IN_STATUS`): its validity
    is not known, and its samples are read as valid, as the station then read them
    (its ``status`` is read as 0, the word as ``device_status``)."""
    return "device_status" not in g and text_value(g.attrs.get("protocol", "")) in WORD_IN_STATUS


def accel_axis_names(g: h5py.Group) -> tuple[str, ...]:
    """The accelerometer axes of a unit group (its ``accel`` dataset's ``axes``
    attribute); empty for a gyro-only unit."""
    if "accel" not in g:
        return ()
    return tuple(json.loads(text_value(g["accel"].attrs["axes"])))


def unit_attributes(g: h5py.Group) -> dict[str, Any]:
    """A unit group's attributes: text as ``str``, numpy scalars as Python numbers."""
    return {k: (text_value(v) if isinstance(v, bytes | str | np.bytes_) else v.item()
                if isinstance(v, np.generic) else v) for k, v in g.attrs.items()}


def _check_inside(f: h5py.File, g: h5py.Group, names: list[str], start: int, stop: int
                  ) -> None:
    """Refuse rows ``start:stop`` of the datasets ``names`` if the file was cut short under
    them (a chunk past its end reads as zeros, checksum and all)."""
    size = cut_short(Path(f.filename))
    if size is None:
        return
    for name in names:
        if not chunks_within(g[name], start, stop, size):
            raise RecordFormatError(
                f"{f.filename}: cut short ({size} bytes): {g.name.rsplit('/', 1)[-1]}'s "
                f"{name} runs past the end of the file; `station recover {f.filename}` "
                f"salvages what is readable")


def _rows(ds: h5py.Dataset, start: int, stop: int) -> Any:
    """Rows ``start:stop`` of a dataset. A live reader may catch a chunk while the writer
    rewrites it (its checksum then fails): it reads again, a few times, before giving up."""
    tries = 4 if ds.file.swmr_mode else 1
    for attempt in range(tries):
        try:
            return ds[start:stop]
        except OSError:
            if attempt == tries - 1:
                raise
            time.sleep(0.01)
            refresh_alone(ds)
    raise AssertionError("unreachable")


def committed_events(f: h5py.File, unit_id: str) -> NDArray[np.void]:
    """The committed event log of one unit (rows of :data:`EVENT_DTYPE`; a file written
    before ``missing_low``/``missing_high`` existed lacks them: see :func:`gap_bounds`)."""
    g = f["units"][unit_id]
    m = min(int(refresh_alone(g["committed"])[1]), refresh_alone(g["events"]).shape[0])
    _check_inside(f, g, ["events"], 0, m)
    return _rows(g["events"], 0, m)


def gap_bounds(events: NDArray[np.void]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``(missing_low, missing_high)`` of event-log rows: the range of samples each gap
    may have lost (both equal ``missing_samples`` where the count is certain, and in
    files written before the bounds were recorded)."""
    names = events.dtype.names or ()
    if "missing_low" in names and "missing_high" in names:
        return (np.asarray(events["missing_low"], np.int64),
                np.asarray(events["missing_high"], np.int64))
    exact = np.asarray(events["missing_samples"], np.int64)
    return exact, exact.copy()


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
    samples_missing_low: int = 0
    samples_missing_high: int = 0
    bad_samples: int = 0


def unit_counts(f: h5py.File, unit_id: str) -> UnitCounts:
    """Samples, missing samples (with their bounds), gaps, CRC errors, reconnects, bad
    samples of one unit (committed)."""
    ev = committed_events(f, unit_id)
    g = f["units"][unit_id]
    n = int(g["committed"][0])
    kinds = ev["kind"]
    gaps = kinds == b"gap"
    low, high = gap_bounds(ev)
    counted = gaps & (ev["missing_samples"] > 0)  # a best count of 0: only a bound
    last = float(_rows(g["receive_time"], n - 1, n)[0]) if n else 0.0
    return UnitCounts(unit_id, n, int(ev["missing_samples"][gaps].sum()), int(counted.sum()),
                      int(ev["count"][kinds == b"crc_error"].sum()),
                      int((kinds == b"reconnect").sum()), int((kinds == b"disconnect").sum()),
                      last, int(low[gaps].sum()), int(high[gaps].sum()),
                      int(ev["count"][kinds == b"bad_sample"].sum()))


def run_events(unit: UnitData) -> tuple[RunEvent, ...]:
    """A unit's event log as :class:`RunEvent` s (the gap method goes in the detail)."""
    return events_of(unit.unit_id, unit.events)


def events_of(unit_id: str, events: NDArray[np.void]) -> tuple[RunEvent, ...]:
    """Event-log rows of unit ``unit_id`` as :class:`RunEvent` s."""
    out = []
    lows, highs = gap_bounds(events)
    for row, low, high in zip(events, lows, highs, strict=True):
        method, detail = text_value(row["method"]), text_value(row["detail"])
        text = "; ".join(t for t in (f"counted by {method}" if method else "", detail) if t)
        kind = log_kind(text_value(row["kind"]))
        if kind is None:
            raise RecordFormatError(f"unit {unit_id}: an event-log entry of unknown kind "
                                    f"{text_value(row['kind'])!r} (a damaged file, or one "
                                    f"from a newer station)")
        out.append(RunEvent(unit_id, kind, float(row["time_s"]),
                            int(row["count"]), int(row["missing_samples"]), text,
                            int(low), int(high)))
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
    at, missing = gap_insertions(counter, receive_time_s, events)
    if not len(at):
        return None
    inserted = np.zeros(len(counter), dtype=np.int64)
    inserted[at] = missing
    return np.arange(len(counter), dtype=np.int64) + np.cumsum(inserted)


def gap_insertions(counter: NDArray[np.int64], receive_time_s: NDArray[np.float64],
                   events: NDArray[np.void]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(sample positions, samples missing before each) of the gaps inside the record, as
    :func:`gap_sample_index` places them: increasing positions, no zero count. The
    arrays may be memmaps: each gap is found by a binary search."""
    n = len(counter)
    names = events.dtype.names or ()
    gaps = events[events["kind"] == b"gap"] if "kind" in names else events[:0]
    inserted: dict[int, int] = {}
    for row in gaps if n else ():
        after = int(row["after_counter"]) if "after_counter" in names else -1
        i = int(np.searchsorted(counter, after, side="right")) if after >= 0 else -1
        if i <= 0 or counter[i - 1] != after:
            i = int(np.searchsorted(receive_time_s, float(row["time_s"]), side="left"))
        if 0 < i < n:
            inserted[i] = inserted.get(i, 0) + int(row["missing_samples"])
    at = np.array(sorted(k for k, v in inserted.items() if v), dtype=np.int64)
    return at, np.array([inserted[int(k)] for k in at], dtype=np.int64)


def unit_record(unit: UnitData, source: str, *, keep_grid: bool = False) -> RateRecord:
    """The unit's committed valid samples as a :class:`RateRecord` (deg/s), gaps on its
    time grid; the samples the device flagged not valid (``status`` non-zero) are left
    out, missing on the grid as a gap's are (:func:`valid_samples`, ``keep_grid``)."""
    index = gap_sample_index(np.asarray(unit.counter), np.asarray(unit.receive_time_s), unit.events)
    accel = None if unit.accel_m_s2 is None else np.asarray(unit.accel_m_s2, dtype=np.float64)
    record = RateRecord(np.asarray(unit.rate_deg_s, dtype=np.float64), unit.sample_rate_hz,
                        unit.axes, source, unit.temperature_c, index, accel_m_s2=accel,
                        accel_axis_names=unit.accel_axes)
    return valid_samples(record, unit.status, keep_grid=keep_grid)


def valid_samples(record: RateRecord, status: NDArray[np.integer], *,
                  keep_grid: bool = False) -> RateRecord:
    """``record`` without the samples whose ``status`` (one per row) is not 0: those the
    device flagged not valid, rates and accelerations alike, by the protocol's own bits
    (docs/hdf5-layout.md, "Sample validity"). They are missing on the record's time grid,
    as a gap's samples are, so that no figure takes them for data.

    ``keep_grid``: the grid keeps its origin at the first recorded sample, valid or not
    (``sample_index[0]`` is then the number of flagged samples before the first valid
    one: a view that places samples against their receive times); by default it starts
    at the first valid sample. ``record`` itself is returned when every sample is valid.
    """
    flagged = np.asarray(status) != 0
    if not flagged.any():
        return record
    keep = ~flagged
    rows = (np.arange(record.n_samples, dtype=np.int64) if record.sample_index is None
            else np.asarray(record.sample_index, dtype=np.int64))[keep]
    if not keep_grid:
        rows = rows - rows[0] if len(rows) else rows
    index = None if len(rows) and rows[0] == 0 and rows[-1] == len(rows) - 1 else rows
    return RateRecord(
        record.rate_deg_s[keep], record.sample_rate_hz, record.axis_names, record.source,
        None if record.temperature_c is None else record.temperature_c[keep], index,
        None if record.accel_m_s2 is None else record.accel_m_s2[keep],
        record.accel_axis_names)


#: Reads one unit's record from an open run file some other way (the unit id and the
#: record's source given), or returns None to have it read into memory.
LongRecordReader = Callable[[h5py.File, str, str], RateRecord | None]


def read_run(path: str | Path, *, only: Collection[str] | None = None,
             long_record: LongRecordReader | None = None) -> RunInfo:
    """Read a run file into a :class:`RunInfo` (the interface grading, reports, TUI use).

    A run whose file was never closed (recorder killed) reads as ``interrupted``.
    ``only`` names the unit ids to read (None: every unit); the others are left out.
    ``long_record`` reads a unit's record when it returns one (a long unit into scratch
    memmaps: :func:`station.storage.mapped_runs.long_unit_record`); else the unit's
    committed samples are read into memory.

    Raises
    ------
    RecordFormatError
        Not a run file of this station.
    """
    with open_run_file(path) as f:
        state = run_state(f)
        units = []
        for uid in unit_ids(f):
            if only is not None and uid not in only:
                continue
            source = f"{path}#{uid}"
            record = None if long_record is None else long_record(f, uid, source)
            if record is None:
                u = read_unit(f, uid)
                attrs, events, record = u.attrs, u.events, unit_record(u, source)
            else:  # read without the per-sample columns the record does not need
                attrs, events = unit_attributes(f["units"][uid]), committed_events(f, uid)
            units.append(UnitRun(
                unit_id=uid, model=attrs["model"], serial_number=attrs["serial_number"],
                record=record, protocol=attrs["protocol"], transport=attrs["transport"],
                settings=json.loads(attrs["settings"]), events=events_of(uid, events),
                lsb_deg_s=float(attrs.get("lsb_deg_s", 0.0)),
                lsb_relative=float(attrs.get("lsb_relative", 0.0))))
        a = {k: text_value(v) for k, v in f.attrs.items()}
        requested = f.attrs.get("duration_requested_s")
    stopped = state["state"] == "stopped"
    return RunInfo(
        path=str(path), units=tuple(units), metadata=RunMetadata.from_attributes(a),
        start_utc=a.get("start_utc", ""),
        stop_utc=state["stop_utc"] if stopped else state["last_flush_utc"],
        stop_reason=state["stop_reason"] if stopped else "interrupted: file not closed "
                                                         "(recorder killed or crashed)",
        interrupted=not (stopped and state["stop_reason"] in (REASON_DURATION,
                                                               REASON_END_OF_REPLAY)),
        recorded_span_s=float(requested) if stopped and requested is not None
        and state["stop_reason"] == REASON_DURATION else None)


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
        chosen = chosen_unit(f, unit)
        return unit_record(read_unit(f, chosen), f"{path}#{chosen}")


def chosen_unit(f: h5py.File, unit: str | None) -> str:
    """The unit id a ``--unit`` names (unit id or serial number; None: the first unit).

    Raises
    ------
    RecordFormatError
        No units, or no such unit (the message lists the units).
    """
    ids = unit_ids(f)
    if not ids:
        raise RecordFormatError(f"{f.filename}: the run has no units")
    if unit is None:
        return ids[0]
    for uid in ids:
        if unit in (uid, text_value(f["units"][uid].attrs["serial_number"])):
            return uid
    raise RecordFormatError(f"{f.filename}: no unit {unit!r}; units: {', '.join(ids)}")

