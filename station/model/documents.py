"""Run documents: what a recording emits, and what its file writer, live views and TUI consume.

A run is a stream of documents, as in bluesky: one :class:`RunStart`, one
:class:`Descriptor` per unit (its data keys with dtype, shape and unit), then
:class:`EventBatch` es (samples and link-log entries of one unit), and one
:class:`RunStop`. Subscribers are plain callables ``subscriber(document)``; nothing
downstream of the recorder reaches into a device.

Times inside documents are seconds on the unit's own time base, counted from the moment
the recorder started reading that unit (simulated seconds for a time-warped simulation);
wall-clock instants are UTC ISO 8601 strings.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime

import numpy as np
from numpy.typing import NDArray

from devices.protocols import (
    NO_DEVICE_STATUS,
    DeviceDescription,
    Gap,
    MissingBounds,
    SampleBatch,
)
from station.model.kinds import LogKind, LogMethod
from station.model.runs import RunMetadata

#: How run documents and run files write a time: UTC, ISO 8601 with microseconds.
UTC_FORMAT = "%Y-%m-%dT%H:%M:%S.%fZ"


def utc_now() -> str:
    """The current time, UTC, ISO 8601 with microseconds (``2026-11-21T23:40:01.123456Z``)."""
    return datetime.now(UTC).strftime(UTC_FORMAT)


def utc_seconds(text: str) -> float | None:
    """A time :func:`utc_now` wrote, as seconds since the epoch (``time.time()``); None
    for text that is not one (an empty stamp)."""
    try:
        return datetime.strptime(text, UTC_FORMAT).replace(tzinfo=UTC).timestamp()
    except ValueError:
        return None


@dataclass(frozen=True)
class DataKey:
    """One per-sample quantity of a unit: its name, dtype, per-sample shape and unit."""

    name: str
    dtype: str
    shape: tuple[int, ...]
    unit: str
    description: str


def data_keys(description: DeviceDescription) -> tuple[DataKey, ...]:
    """The data keys a unit records, from what its device describes (shape per sample)."""
    keys = [
        DataKey("rate", "float64", (description.n_axes,), description.rate_unit,
                "angular rate per axis, columns in the order of the axes attribute"),
        DataKey("counter", "int64", (), "1",
                "device sample counter, unwrapped (monotonic across wraps and gaps)"),
        DataKey("receive_time", "float64", (), description.time_unit,
                "station receive time since the unit's start, on the unit's time base"),
        DataKey("status", "uint32", (), "1",
                "validity by the protocol's own status bits: 0 = the device says the sample "
                "is good, non-zero = it flags the sample (or a part of it) not valid"),
        DataKey("device_status", "int64", (), "1",
                "the device's status word as sent (-1: the sample came with none)"),
    ]
    if description.has_device_time:
        keys.append(DataKey("device_time", "float64", (), description.time_unit,
                            "device time stamp as sent"))
    if description.has_temperature:
        keys.append(DataKey("temperature", "float64", (), description.temperature_unit,
                            "sensor temperature as reported by the device"))
    if description.accel_axes:
        keys.append(DataKey("accel", "float64", (len(description.accel_axes),),
                            description.accel_unit,
                            "specific force per accelerometer axis, one row per rate row "
                            "(the same datagram), columns in the order of the axes attribute"))
    return tuple(keys)


@dataclass(frozen=True)
class RunStart:
    """The run's start, emitted once before anything else.

    Attributes
    ----------
    uid : str
        Unique id of the run.
    start_utc : str
        Start of the run, UTC.
    unit_ids : tuple of str
        The units, in the order given.
    duration_s : float
        Requested duration, s (on each unit's own time base).
    file : str
        Path of the run file.
    metadata : RunMetadata
        Profile, operator, lot, station, software version, bench.
    """

    uid: str
    start_utc: str
    unit_ids: tuple[str, ...]
    duration_s: float
    file: str
    metadata: RunMetadata = field(default_factory=RunMetadata)


@dataclass(frozen=True)
class Descriptor:
    """One unit: the device's description, its URL, its data keys and its time base.

    ``time_warp`` is the unit clock's seconds per wall second (1 for real hardware).
    """

    unit_id: str
    url: str
    description: DeviceDescription
    keys: tuple[DataKey, ...]
    start_utc: str
    time_base: str
    time_warp: float = 1.0


@dataclass(frozen=True)
class LogEntry(MissingBounds):
    """One entry of a unit's event log (:class:`MissingBounds` gives a gap's ``low`` and
    ``high``; 0 for other entries).

    Attributes
    ----------
    kind : str
        One of :data:`station.model.kinds.LOG_KINDS`.
    time_s : float
        Unit time, s since the unit's start.
    count : int
        How many (CRC errors, bytes skipped); 1 otherwise.
    missing_samples : int
        For a gap: number of samples lost (the best count).
    after_counter : int
        For a gap: unwrapped counter of the last sample before it (-1 otherwise).
    method : str
        For a gap: how it was counted (``counter``, ``counter+elapsed``, ``device_time``).
    detail : str
        Free text.
    missing_low, missing_high : int or None
        For a gap: the fewest and most samples it may have lost (a counter whose wrap
        count the timing cannot pin down); None: exactly ``missing_samples``.
    """

    kind: LogKind
    time_s: float
    count: int = 1
    missing_samples: int = 0
    after_counter: int = -1
    method: LogMethod = ""
    detail: str = ""
    missing_low: int | None = None
    missing_high: int | None = None


@dataclass(frozen=True)
class EventBatch:
    """Samples and log entries of one unit since its previous batch (units as in its keys)."""

    unit_id: str
    seq: int
    rate_deg_s: NDArray[np.float64]
    counter: NDArray[np.int64]
    receive_time_s: NDArray[np.float64]
    status: NDArray[np.uint32]
    device_time_s: NDArray[np.float64] | None = None
    temperature_c: NDArray[np.float64] | None = None
    log: tuple[LogEntry, ...] = ()
    #: Specific force, m/s^2, shape (n, n_accel_axes); None for a gyro-only unit.
    accel_m_s2: NDArray[np.float64] | None = None
    #: The device's status word of each sample as sent (-1: none came with it); None:
    #: no sample of the batch came with one.
    device_status: NDArray[np.int64] | None = None

    def __len__(self) -> int:
        return int(self.counter.shape[0])

    @classmethod
    def from_samples(cls, unit_id: str, seq: int, batch: SampleBatch, t0_s: float,
                     extra_log: Sequence[LogEntry] = ()) -> EventBatch:
        """A document from an adapter's batch; adapter times (s) are shifted by ``-t0_s``."""
        log = [LogEntry(e.kind, e.receive_time_s - t0_s, e.count, detail=e.detail)
               for e in batch.events]
        log += [LogEntry("gap", _gap_time_s(batch, g) - t0_s, 1, g.missing_samples,
                         g.after_counter, g.method, missing_low=g.low, missing_high=g.high)
                for g in batch.gaps]
        log += list(extra_log)
        log.sort(key=lambda e: e.time_s)
        return cls(unit_id, seq, batch.rate_deg_s, batch.counter, batch.receive_time_s - t0_s,
                   batch.status, batch.device_time_s, batch.temperature_c, tuple(log),
                   batch.accel_m_s2, batch.device_status)

    @classmethod
    def join(cls, batches: Sequence[EventBatch]) -> EventBatch:
        """One batch holding ``batches`` (of one unit, in order) one after the other; it
        takes the first one's ``seq``."""
        first = batches[0]
        if len(batches) == 1:
            return first
        full = [b for b in batches if len(b)] or [first]

        def cat(name: str) -> NDArray | None:
            parts = [getattr(b, name) for b in full]
            return None if any(p is None for p in parts) else np.concatenate(parts)

        return cls(first.unit_id, first.seq,
                   np.concatenate([b.rate_deg_s for b in full]),
                   np.concatenate([b.counter for b in full]),
                   np.concatenate([b.receive_time_s for b in full]),
                   np.concatenate([b.status for b in full]), cat("device_time_s"),
                   cat("temperature_c"), tuple(e for b in batches for e in b.log),
                   cat("accel_m_s2"),
                   None if all(b.device_status is None for b in full)
                   else np.concatenate([b.device_status_words() for b in full]))

    def device_status_words(self) -> NDArray[np.int64]:
        """The device's status word of each sample (-1 where none came with it)."""
        if self.device_status is None:
            return np.full(len(self), NO_DEVICE_STATUS, dtype=np.int64)
        return np.asarray(self.device_status, dtype=np.int64)


def _gap_time_s(batch: SampleBatch, gap: Gap) -> float:
    """Receive time (s, adapter clock) of the first sample after ``gap``: the moment the
    gap became known, on the same clock as every other sample of the unit (the adapter's
    own stamp is used only when that sample is not in the batch)."""
    after = gap.after_counter + gap.missing_samples + 1
    i = int(np.searchsorted(batch.counter, after))
    if i < len(batch) and int(batch.counter[i]) == after:
        return float(batch.receive_time_s[i])
    return gap.receive_time_s


@dataclass(frozen=True)
class UnitTotals:
    """What one unit recorded, for the stop document and ``--json-summary``.

    ``samples_sent`` is the simulator's own count of samples it generated (None for real
    hardware): it must lie within ``samples_recorded + samples_missing_low`` and
    ``samples_recorded + samples_missing_high`` (equal bounds where every gap's count is
    certain). ``cpu_s`` is the CPU time of the unit's process (its reader, and its
    simulator if it has one), ``reader_cpu_s`` the reading thread's alone, s.
    """

    unit_id: str
    url: str
    samples_recorded: int
    samples_missing_declared: int
    gaps: int
    crc_errors: int
    reconnects: int
    samples_sent: int | None = None
    samples_missing_low: int = 0
    samples_missing_high: int = 0
    bad_samples: int = 0
    cpu_s: float = 0.0
    reader_cpu_s: float = 0.0


@dataclass(frozen=True)
class RunStop:
    """The end of the run: when, why, and each unit's totals."""

    stop_utc: str
    reason: str
    totals: tuple[UnitTotals, ...] = ()


Document = RunStart | Descriptor | EventBatch | RunStop
Subscriber = Callable[[Document], None]


@dataclass
class UnitTally:
    """Running counts of one unit, kept from its event batches (progress line, totals)."""

    samples: int = 0
    missing: int = 0
    gaps: int = 0
    crc_errors: int = 0
    reconnects: int = 0
    disconnects: int = 0
    last_time_s: float = 0.0
    connected: bool = True
    missing_low: int = 0
    missing_high: int = 0
    bad_samples: int = 0

    def add(self, batch: EventBatch) -> None:
        """Count a batch's samples and log entries."""
        self.samples += len(batch)
        if len(batch):
            self.last_time_s = float(batch.receive_time_s[-1])
            self.connected = True
        for entry in batch.log:
            if entry.kind == "gap":
                # A gap whose best count is 0 only says whole wraps may be missing.
                self.gaps += 1 if entry.missing_samples else 0
                self.missing += entry.missing_samples
                self.missing_low += entry.low
                self.missing_high += entry.high
            elif entry.kind == "bad_sample":
                self.bad_samples += entry.count
            elif entry.kind == "crc_error":
                self.crc_errors += entry.count
            elif entry.kind == "reconnect":
                self.reconnects += 1
                self.connected = True
            elif entry.kind == "disconnect":
                self.disconnects += 1
                self.connected = False


@dataclass
class Dispatcher:
    """Sends each document to every subscriber, in order."""

    subscribers: list[Subscriber] = field(default_factory=list)

    def subscribe(self, subscriber: Subscriber) -> None:
        """Add a subscriber (it sees documents emitted from now on)."""
        self.subscribers.append(subscriber)

    def emit(self, document: Document) -> None:
        """Send ``document`` to every subscriber."""
        for subscriber in self.subscribers:
            subscriber(document)
