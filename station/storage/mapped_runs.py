"""A long unit of a run file read into scratch memmaps, a chunk at a time.

:func:`long_unit_record` copies one unit's committed rate (and temperature) from the HDF5
datasets into axis-major scratch arrays (:mod:`station.storage.scratch`), reading a few
chunks at a time and only those columns; the :class:`RateRecord` it returns views them
(``rate_deg_s[:, i]`` is one contiguous axis). ``station analyze`` reads its unit so
(:func:`read_long_unit`), and :func:`station.storage.runs.open_run` every unit of a run
(grading, reports); a unit with gaps gets its sample index (the grid index of each
sample, :func:`station.storage.hdf5.gap_sample_index`) in a scratch memmap as well. Samples
the device flagged not valid (``status`` non-zero) are left out, as
:func:`station.storage.hdf5.unit_record` leaves them out of a short unit. Short units are
read by :func:`station.storage.hdf5.read_unit`.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
from numpy.typing import NDArray

from analysis.allan import blocks
from station.model.records import RateRecord
from station.storage.hdf5 import (
    _check_inside,
    accel_axis_names,
    chosen_unit,
    committed_events,
    gap_insertions,
    open_run_file,
    text_value,
    valid_samples,
    word_in_status,
)
from station.storage.hdf5_open import refresh_alone
from station.storage.scratch import scratch_array

#: Rows read from the HDF5 dataset at a time (1.5 MB of a 3-axis float64 rate).
CHUNK_ROWS = 1 << 16


def read_long_unit(path: str | Path, unit: str | None = None) -> RateRecord | None:
    """One unit's record in scratch memmaps when it is long; else None.

    Raises
    ------
    RecordFormatError
        Not a run file, damaged, cut short under the rate, or no such unit.
    """
    with open_run_file(path) as f:
        uid = chosen_unit(f, unit)
        return long_unit_record(f, uid, f"{path}#{uid}")


def long_unit_record(f: h5py.File, uid: str, source: str) -> RateRecord | None:
    """Unit ``uid`` of the open run file ``f`` in scratch memmaps when it is long (with
    gaps, its sample index too); else None (read it into memory). ``source`` names the
    record in reports.

    Raises
    ------
    RecordFormatError
        Damaged, or cut short under the rate.
    """
    g = f["units"][uid]
    extra = [name for name in ("temperature", "accel") if name in g]
    for name in ("committed", "rate", *extra):
        refresh_alone(g[name])
    n = min(int(g["committed"][0]), g["rate"].shape[0], *(g[name].shape[0] for name in extra))
    if not blocks.is_long(n):
        return None
    events = committed_events(f, uid)
    gapped = bool(np.any(events["kind"] == b"gap"))
    columns = ["rate", *extra, *(["counter", "receive_time"] if gapped else [])]
    for name in columns[1:]:
        refresh_alone(g[name])
    n = min(n, *(g[name].shape[0] for name in columns))
    _check_inside(f, g, columns, 0, n)
    axes = tuple(json.loads(text_value(g.attrs["axes"])))
    temperature = _column(g, "temperature", n, np.float64) if "temperature" in g else None
    index = _sample_index(g, events, n) if gapped else None
    accel = _matrix(g, "accel", n) if "accel" in g else None
    record = RateRecord(_matrix(g, "rate", n), float(g.attrs["sample_rate_hz"]), axes, source,
                        temperature, index, accel_m_s2=accel,
                        accel_axis_names=accel_axis_names(g))
    if word_in_status(g):  # an older file whose status is the device's word: all valid
        return record
    refresh_alone(g["status"])
    _check_inside(f, g, ["status"], 0, n)
    if not _any_flagged(g["status"], n):
        return record
    # the samples the device flagged not valid are left out (a copy in memory: rare)
    return valid_samples(record, _column(g, "status", n, np.uint32))


def _matrix(g: h5py.Group, name: str, n: int) -> NDArray[np.float64]:
    """The first ``n`` rows of a 2-D float dataset (rate, accel) as float64, held in a
    scratch memmap column-major (each column contiguous), a chunk at a time."""
    out = scratch_array((g[name].shape[1], n))
    for a in range(0, n, CHUNK_ROWS):
        b = min(a + CHUNK_ROWS, n)
        out[:, a:b] = np.asarray(g[name][a:b], dtype=np.float64).T
        blocks.release(out)
    return out.T


def _column(g: h5py.Group, name: str, n: int, dtype: type) -> np.memmap:
    """The first ``n`` rows of a 1-D dataset in a scratch memmap, a chunk at a time."""
    out = scratch_array((n,), dtype)
    for a in range(0, n, CHUNK_ROWS):
        b = min(a + CHUNK_ROWS, n)
        out[a:b] = g[name][a:b]
        blocks.release(out)
    return out


def _any_flagged(status: h5py.Dataset, n: int) -> bool:
    """Whether any of the first ``n`` samples of a ``status`` dataset is not 0, read a chunk
    at a time (a status column of 24 h at 1 kHz mapped in whole is 346 MB)."""
    return any(bool(np.any(status[a : min(a + CHUNK_ROWS, n)])) for a in range(0, n, CHUNK_ROWS))


def _sample_index(g: h5py.Group, events: np.ndarray, n: int) -> np.memmap | None:
    """The grid index of each of the ``n`` samples (:func:`gap_sample_index`) in a scratch
    memmap, or None when no gap falls inside the record."""
    at, missing = gap_insertions(_column(g, "counter", n, np.int64),
                                 _column(g, "receive_time", n, np.float64), events)
    if not len(at):
        return None
    shift = np.concatenate(([0], np.cumsum(missing)))
    index = scratch_array((n,), np.int64)
    for a in range(0, n, CHUNK_ROWS):
        k = np.arange(a, min(a + CHUNK_ROWS, n), dtype=np.int64)
        index[a : a + len(k)] = k + shift[np.searchsorted(at, k, side="right")]
        blocks.release(index)
    return index
