"""Reading a damaged run file's datasets chunk by chunk, and mending a unit's rows around
the chunks that do not read.

A flipped bit or a cut fails only the chunks it hits: :func:`readable_rows` reads a
dataset one chunk at a time and says which rows read. :func:`mend_rows` then keeps every
row whose rate read and whose place on the counter is known, and declares each run of
rows it cannot keep a gap (an event-log row of method ``salvage``), so the analysis
handles it as any gap and the books count it:

* a counter chunk that does not read is restored where the rows around it pin it (their
  counters differ by exactly the rows between: no sample was lost there), or where the
  device time of its rows reads (counter steps = device-time steps x the nominal rate);
  otherwise its rows are declared a gap;
* a receive-time, device-time or temperature chunk that does not read is interpolated
  along the counter from the readable rows around it (times extrapolated at the nominal
  rate at an end, a temperature held); a column of which no row reads is left out (the
  receive time then stands in as counter / nominal rate);
* a status chunk that does not read is filled with :data:`STATUS_UNREADABLE` (not valid),
  a device-status chunk with -1 (no word read);
* an accel chunk (an IMU's accelerations, from the rate's datagram) that does not read
  costs its rows as a rate chunk does: they are declared a gap.
"""

from __future__ import annotations

from dataclasses import dataclass

import h5py
import numpy as np
from numpy.typing import NDArray

from devices.protocols import NO_DEVICE_STATUS
from station.model.kinds import LogMethod
from station.storage.hdf5 import EVENT_DTYPE
from station.storage.hdf5_open import chunks_within

#: Status of a salvaged sample whose status flags did not read (no device sets every bit).
STATUS_UNREADABLE = 0xFFFFFFFF
#: Gap method of the rows ``station recover`` could not read from a damaged file.
SALVAGE_METHOD: LogMethod = "salvage"
_FAILS = (OSError, RuntimeError, KeyError, ValueError, TypeError)


def readable_rows(ds: h5py.Dataset, limit: int, size: int
                  ) -> tuple[NDArray[np.generic], NDArray[np.bool_]]:
    """Rows ``0:limit`` of ``ds`` (zeros where they do not read) and which rows read.

    A chunk does not read when its checksum fails, its index entry does not read, or it
    lies past the end of a file of ``size`` bytes (it would read as zeros). The whole
    dataset is tried at once first; chunk by chunk only when that fails.
    """
    rows = ds.chunks[0] if ds.chunks else max(limit, 1)
    data = np.zeros((limit, *ds.shape[1:]), ds.dtype)
    ok = np.zeros(limit, bool)
    spans = [(0, limit)] + [(a, min(a + rows, limit)) for a in range(0, limit, rows)]
    for a, b in spans:
        if ok[a:b].all() or a == b:
            continue
        try:
            if chunks_within(ds, a, b, size):
                data[a:b] = ds[a:b]
                ok[a:b] = True
        except _FAILS:
            pass
    return data, ok


def runs_of(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))


@dataclass(frozen=True)
class MendedRows:
    """A unit's rows as salvaged: the columns of the rows kept, the gap events declaring
    the rows that were not, and what was restored (one note per column)."""

    columns: dict[str, NDArray[np.generic]]
    gaps: NDArray[np.void]
    lost: int
    notes: tuple[str, ...]


def _pin_counter(counter: NDArray[np.int64], known: NDArray[np.bool_],
                 device_time: NDArray[np.float64] | None, dt_ok: NDArray[np.bool_] | None,
                 rate_hz: float) -> int:
    """Restore, in place, the counters of unreadable rows the rows around them pin; the
    number of rows restored."""
    n, restored = len(counter), 0
    for a, b in runs_of(~known):
        if 0 < a and b < n and counter[b] - counter[a - 1] == b - a + 1:
            counter[a:b] = counter[a - 1] + np.arange(1, b - a + 1)
        elif device_time is not None and dt_ok is not None:
            anchor = a - 1 if a > 0 and dt_ok[a - 1] else b if b < n and dt_ok[b] else -1
            if anchor < 0 or not dt_ok[a:b].all():
                continue
            steps = np.rint((device_time[a:b] - device_time[anchor]) * rate_hz).astype(np.int64)
            pinned = counter[anchor] + steps
            lo = counter[a - 1] if a > 0 else np.iinfo(np.int64).min
            hi = counter[b] if b < n else np.iinfo(np.int64).max
            if not (np.all(np.diff(pinned) > 0) and lo < pinned[0] and pinned[-1] < hi):
                continue
            counter[a:b] = pinned
        else:
            continue
        known[a:b] = True
        restored += b - a
    return restored


def _interpolated(values: NDArray[np.float64], ok: NDArray[np.bool_],
                  counter: NDArray[np.int64], per_count: float) -> NDArray[np.float64]:
    """``values`` with the rows not ``ok`` interpolated along ``counter`` (extrapolated at
    ``per_count`` per count beyond the readable rows; ``ok`` has at least one row)."""
    good = np.flatnonzero(ok)
    c = counter.astype(np.float64)
    out = np.array(values, dtype=np.float64)
    bad = ~ok
    out[bad] = np.interp(c[bad], c[good], out[good])
    first, last = good[0], good[-1]
    before, after = bad & (c < c[first]), bad & (c > c[last])
    out[before] = out[first] + (c[before] - c[first]) * per_count
    out[after] = out[last] + (c[after] - c[last]) * per_count
    return out


def mend_rows(columns: dict[str, NDArray[np.generic]], ok: dict[str, NDArray[np.bool_]],
              rate_hz: float) -> MendedRows:
    """Keep the rows whose rate read and whose counter is known or pinned; restore the
    other columns of those rows; declare the rest as gaps (see the module docstring).

    ``columns`` and ``ok`` hold the same names (``rate``, ``counter``, ``receive_time``,
    ``status``, optionally ``device_status``, ``device_time``, ``temperature`` and
    ``accel``), each as long as
    ``rate``. An IMU's ``accel`` is mended like the rate: a row kept needs both.
    """
    counter = np.array(columns["counter"], dtype=np.int64)
    known = ok["counter"].copy()
    dt = columns.get("device_time")
    restored = _pin_counter(counter, known, None if dt is None else np.asarray(dt, np.float64),
                            ok.get("device_time"), rate_hz)
    keep = ok["rate"] & known
    if "accel" in ok:  # an IMU's accelerations are kept or lost with their rates' rows
        keep &= ok["accel"]
    notes = [f"{restored} counters restored from the rows around them"] if restored else []
    kept_counter = counter[keep]
    out: dict[str, NDArray[np.generic]] = {"rate": columns["rate"][keep],
                                           "counter": kept_counter}
    if "accel" in columns:
        out["accel"] = columns["accel"][keep]
    for name in ("receive_time", "status", "device_status", "device_time", "temperature"):
        if name not in columns:
            continue
        values, good = columns[name][keep], ok[name][keep]
        if good.all():
            out[name] = values
            continue
        missing = int((~good).sum())
        if name == "status":
            out[name] = np.where(good, values, np.uint32(STATUS_UNREADABLE)).astype(np.uint32)
            notes.append(f"{missing} status flags unreadable (set to {STATUS_UNREADABLE:#x})")
        elif name == "device_status":
            out[name] = np.where(good, values, NO_DEVICE_STATUS).astype(np.int64)
            notes.append(f"{missing} device status words unreadable (set to "
                         f"{NO_DEVICE_STATUS})")
        elif good.any():
            per_count = 0.0 if name == "temperature" else 1.0 / rate_hz  # s per count
            out[name] = _interpolated(np.asarray(values, np.float64), good, kept_counter,
                                      per_count)
            notes.append(f"{missing} {name.replace('_', ' ')}s interpolated along the counter")
        elif name == "receive_time":
            start = kept_counter[0] if len(kept_counter) else 0
            out[name] = (kept_counter - start) / rate_hz
            notes.append("no receive time readable: counter / nominal rate stands in")
        else:
            notes.append(f"no {name.replace('_', ' ')} readable: left out")
    gaps = _gaps(keep, counter, np.asarray(out["receive_time"], np.float64), rate_hz)
    lost = int((~keep).sum())
    if lost:
        where = ", ".join(f"{a}..{b - 1}" for a, b in runs_of(~keep)[:6])
        notes.insert(0, f"{lost} committed samples unreadable (rows {where}"
                        f"{', ...' if len(runs_of(~keep)) > 6 else ''}), declared as gaps")
    return MendedRows(out, gaps, lost, tuple(notes))


def _gaps(keep: NDArray[np.bool_], counter: NDArray[np.int64],
          kept_time: NDArray[np.float64], rate_hz: float) -> NDArray[np.void]:
    """One gap event per run of rows not kept: after the counter of the row before it, at
    the receive time of the first kept row after it (an end: outside the record)."""
    spans = runs_of(~keep)
    events = np.zeros(len(spans), EVENT_DTYPE)
    kept_before = np.cumsum(keep)  # kept rows up to and including each row
    for row, (a, b) in zip(events, spans, strict=True):
        before = int(kept_before[a - 1]) if a > 0 else 0  # kept rows before the span
        if before < len(kept_time):
            time_s = float(kept_time[before])
        else:  # nothing kept after it
            time_s = float(kept_time[-1]) + (b - a + 1) / rate_hz if len(kept_time) else 0.0
        row["time_s"], row["kind"], row["count"] = time_s, b"gap", 1
        row["missing_samples"] = row["missing_low"] = row["missing_high"] = b - a
        row["after_counter"] = counter[a - 1] if a > 0 else -1
        row["method"] = SALVAGE_METHOD.encode()
        row["detail"] = f"rows {a}..{b - 1} of the damaged file unreadable".encode()[:120]
    return events
