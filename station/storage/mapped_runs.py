"""A long unit of a run file read into scratch memmaps, a chunk at a time.

:func:`long_unit_record` copies one unit's committed rate (and temperature) from the HDF5
datasets into axis-major scratch arrays (:mod:`station.storage.scratch`), reading a few
chunks at a time and only those columns; the :class:`RateRecord` it returns views them
(``rate_deg_s[:, i]`` is one contiguous axis). ``station analyze`` reads its unit so
(:func:`read_long_unit`), and :func:`station.storage.runs.open_run` every unit of a run
(grading, reports). Short units, and units with gaps (whose time grid the in-memory
reader builds), are read by :func:`station.storage.hdf5.read_unit`.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from analysis import blocks
from station.model.records import RateRecord
from station.storage.hdf5 import (
    _check_inside,
    chosen_unit,
    committed_events,
    open_run_file,
    text_value,
)
from station.storage.scratch import scratch_array

#: Rows read from the HDF5 dataset at a time (1.5 MB of a 3-axis float64 rate).
CHUNK_ROWS = 1 << 16


def read_long_unit(path: str | Path, unit: str | None = None) -> RateRecord | None:
    """One unit's record in scratch memmaps when it is long and has no gaps; else None.

    Raises
    ------
    RecordFormatError
        Not a run file, damaged, cut short under the rate, or no such unit.
    """
    with open_run_file(path) as f:
        uid = chosen_unit(f, unit)
        return long_unit_record(f, uid, f"{path}#{uid}")


def long_unit_record(f: h5py.File, uid: str, source: str) -> RateRecord | None:
    """Unit ``uid`` of the open run file ``f`` in scratch memmaps when it is long and has
    no gaps; else None (read it into memory). ``source`` names the record in reports.

    Raises
    ------
    RecordFormatError
        Damaged, or cut short under the rate.
    """
    g = f["units"][uid]
    for name in ("committed", "rate", *(["temperature"] if "temperature" in g else [])):
        g[name].refresh()
    n = min(
        int(g["committed"][0]),
        g["rate"].shape[0],
        *([g["temperature"].shape[0]] if "temperature" in g else []),
    )
    if not blocks.is_long(n):
        return None
    events = committed_events(f, uid)
    if np.any(events["kind"] == b"gap"):
        return None
    _check_inside(f, g, ["rate", *(["temperature"] if "temperature" in g else [])], 0, n)
    axes = tuple(json.loads(text_value(g.attrs["axes"])))
    rate = scratch_array((len(axes), n))
    for a in range(0, n, CHUNK_ROWS):
        b = min(a + CHUNK_ROWS, n)
        rate[:, a:b] = np.asarray(g["rate"][a:b], dtype=np.float64).T
        blocks.release(rate)
    temperature = None
    if "temperature" in g:
        temperature = scratch_array((n,))
        for a in range(0, n, CHUNK_ROWS):
            b = min(a + CHUNK_ROWS, n)
            temperature[a:b] = g["temperature"][a:b]
            blocks.release(temperature)
    return RateRecord(rate.T, float(g.attrs["sample_rate_hz"]), axes, source, temperature, None)
