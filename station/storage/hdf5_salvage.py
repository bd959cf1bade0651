"""Salvage of a damaged run file: what is still readable, into a new, valid run file.

A run file cut short (a copy interrupted, a disk that failed) or with flipped bits cannot
be repaired in place: :func:`salvage_run` reads what it can (each attribute, each unit's
datasets chunk by chunk up to the first block that fails its checksum or lies past the
end of the file, never beyond the committed marker), writes it into a new file with the
recorder's layout, and marks that run as salvaged. The original is not touched.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from devices.protocols import DeviceDescription
from station.errors import RecordFormatError
from station.model.documents import Descriptor, RunStart, data_keys
from station.model.runs import RunMetadata
from station.storage.hdf5 import (
    EVENT_DTYPE,
    FORMAT,
    SAMPLE_DATASETS,
    STATE_DTYPE,
    fixed_text,
    text_value,
)
from station.storage.hdf5_open import chunks_within, swmr_reader
from station.storage.hdf5_writer import write_layout

REASON_SALVAGED = "interrupted: salvaged from a damaged run file (recovered)"


@dataclass(frozen=True)
class SalvagedUnit:
    """One unit as salvaged: samples kept, and what the damaged file said it held."""

    unit_id: str
    kept: int
    committed: int | None
    events_kept: int
    note: str


def salvaged_path(path: Path) -> Path:
    """Where the salvage of ``path`` goes: ``NAME.recovered.h5`` beside it."""
    return path.with_name(f"{path.stem}.recovered.h5")


def _get(read: Any, default: Any = None) -> Any:
    """``read()``, or ``default`` when HDF5 cannot read it."""
    try:
        return read()
    except (OSError, RuntimeError, KeyError, ValueError, TypeError):
        return default


def _attrs(obj: h5py.HLObject) -> dict[str, Any]:
    """Every attribute of ``obj`` that still reads (text decoded)."""
    out = {}
    for name in _get(lambda: list(obj.attrs), []):
        value = _get(lambda n=name: obj.attrs[n])
        if value is None:
            continue
        out[name] = text_value(value) if isinstance(value, bytes | np.bytes_ | str) else (
            value.item() if isinstance(value, np.generic) else value)
    return out


def _readable_rows(ds: h5py.Dataset, limit: int, size: int) -> tuple[np.ndarray, int]:
    """Rows ``0:limit`` of ``ds`` up to the first chunk that does not read (its checksum
    fails, or it lies past the end of a file of ``size`` bytes)."""
    rows = ds.chunks[0] if ds.chunks else max(limit, 1)
    parts, n = [], 0
    while n < limit:
        stop = min(n + rows, limit)
        if not _get(lambda a=n, b=stop: chunks_within(ds, a, b, size), False):
            break
        part = _get(lambda a=n, b=stop: ds[a:b])
        if part is None:
            break
        parts.append(part)
        n += len(part)
    data = np.concatenate(parts) if parts else np.empty((0, *ds.shape[1:]), ds.dtype)
    return data, n


@dataclass
class _Unit:
    unit_id: str
    attrs: dict[str, Any]
    data: dict[str, np.ndarray]
    events: np.ndarray
    committed: int | None
    note: str


def _read_unit(g: h5py.Group, unit_id: str, size: int) -> _Unit:
    attrs = _attrs(g)
    committed = _get(lambda: [int(v) for v in g["committed"][:]])
    names = [k for k in SAMPLE_DATASETS if _get(lambda k=k: k in g, False)]
    shapes = {k: _get(lambda k=k: g[k].shape[0], 0) for k in names}
    limit = min([*shapes.values(), committed[0] if committed else min(shapes.values(), default=0)],
                default=0)
    data, n = {}, limit
    for k in names:
        rows, got = _readable_rows(g[k], limit, size)
        data[k] = rows
        n = min(n, got)
    data = {k: v[:n] for k, v in data.items()}
    ev_limit = min(_get(lambda: g["events"].shape[0], 0),
                   committed[1] if committed else _get(lambda: g["events"].shape[0], 0))
    events, _ = (_readable_rows(g["events"], ev_limit, size)
                 if _get(lambda: "events" in g, False)
                 else (np.zeros(0, EVENT_DTYPE), 0))
    note = "" if n == limit else f"{limit - n} committed samples unreadable"
    if committed is None:
        note = "its committed marker is unreadable: " + (note or "every readable row kept")
    return _Unit(unit_id, attrs, data, events, None if committed is None else committed[0],
                 note)


def _description(u: _Unit) -> DeviceDescription:
    a = u.attrs
    modulus = int(a.get("counter_modulus", -1))
    return DeviceDescription(
        model=str(a.get("model", "")), serial_number=str(a.get("serial_number", "")),
        protocol=str(a.get("protocol", "")), transport=str(a.get("transport", "")),
        axes=tuple(json.loads(a["axes"])), sample_rate_hz=float(a["sample_rate_hz"]),
        has_counter=True, counter_modulus=None if modulus < 0 else modulus,
        has_device_time="device_time" in u.data, has_temperature="temperature" in u.data,
        settings=tuple((str(k), str(v)) for k, v in json.loads(a.get("settings", "{}")).items()))


def salvage_run(path: Path, out: Path) -> list[SalvagedUnit]:
    """Copy what is readable of the damaged run file ``path`` into a new run file ``out``.

    Raises
    ------
    RecordFormatError
        Nothing to salvage: not a run file, its root or every unit unreadable.
    """
    units: list[_Unit] = []
    size = path.stat().st_size
    try:
        f = swmr_reader(path)
    except (OSError, RuntimeError, KeyError, ValueError) as exc:
        raise RecordFormatError(f"{path}: cannot be recovered: HDF5 cannot open it at all "
                                f"({' '.join(str(exc).split())[:160]})") from exc
    with f:
        root = _attrs(f)
        if root.get("format") != FORMAT:
            raise RecordFormatError(f"{path}: cannot be recovered: its run metadata do not "
                                    f"read (the start of the file is damaged)")
        state = _get(lambda: f["run_state"][0])
        ids = _get(lambda: json.loads(root["unit_ids"])) or _get(lambda: list(f["units"]), [])
        for uid in ids:
            g = _get(lambda u=uid: f["units"][u])
            if g is not None:
                unit = _get(lambda grp=g, u=uid: _read_unit(grp, u, size))
                if unit is not None and "axes" in unit.attrs and all(
                        k in unit.data for k in ("rate", "counter", "receive_time", "status")):
                    units.append(unit)
    if not units:
        raise RecordFormatError(f"{path}: cannot be recovered: no unit's data read")
    start = RunStart(str(root.get("run_uid", "")), str(root.get("start_utc", "")),
                     tuple(u.unit_id for u in units), float(root.get("duration_requested_s", 0)),
                     str(out), RunMetadata.from_attributes(root))
    descriptors = []
    for u in units:
        d = _description(u)
        descriptors.append(Descriptor(u.unit_id, str(u.attrs.get("url", "")), d, data_keys(d),
                                      str(u.attrs.get("start_utc", "")),
                                      str(u.attrs.get("time_base", "")),
                                      float(u.attrs.get("time_warp", 1.0))))
    last_flush = "" if state is None else text_value(state["last_flush_utc"])
    with h5py.File(out, "w-", libver="latest") as f:
        write_layout(f, start, descriptors)
        for u in units:
            g = f["units"][u.unit_id]
            n = len(next(iter(u.data.values())))
            for k, rows in u.data.items():
                g[k].resize(n, axis=0)
                g[k][:] = rows
            events = np.zeros(len(u.events), EVENT_DTYPE)
            for name in u.events.dtype.names or ():
                if name in (EVENT_DTYPE.names or ()):
                    events[name] = u.events[name]
            if "missing_low" not in (u.events.dtype.names or ()):
                events["missing_low"] = events["missing_high"] = events["missing_samples"]
            g["events"].resize(len(events), axis=0)
            g["events"][:] = events
            g["committed"][:] = (n, len(events))
        row = np.zeros(1, STATE_DTYPE)
        row[0] = (b"stopped", last_flush.encode(), REASON_SALVAGED.encode()[:128],
                  last_flush.encode())
        f["run_state"][0] = row[0]
        f.attrs.modify("stop_utc", fixed_text(last_flush, 32))
        f.attrs.modify("stop_reason", fixed_text(REASON_SALVAGED, 128))
        f.attrs["salvaged_from"] = str(path)
    return [SalvagedUnit(u.unit_id, len(next(iter(u.data.values()))), u.committed,
                         len(u.events), u.note) for u in units]
