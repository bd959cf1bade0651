"""Salvage of a damaged run file: what is still readable, into a new, valid run file.

A run file cut short (a copy interrupted, a disk that failed) or with flipped bits cannot
be repaired in place: :func:`salvage_run` reads what it can (each attribute, each unit's
datasets chunk by chunk, never beyond the committed marker: a chunk that fails its
checksum or lies past the end of the file costs only its own rows, declared as a gap,
:mod:`station.storage.hdf5_mend`), writes it into a new file with the recorder's layout,
and marks that run as salvaged. A unit of which no sample reads is left out; a file of
which none does is an error, and nothing is written. The original is not touched.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from devices.protocols import NO_DEVICE_STATUS, DeviceDescription
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
    word_in_status,
)
from station.storage.hdf5_mend import mend_rows, readable_rows
from station.storage.hdf5_open import swmr_reader
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
    lost: int = 0


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


@dataclass
class _Unit:
    unit_id: str
    attrs: dict[str, Any]
    data: dict[str, np.ndarray]
    events: np.ndarray
    committed: int | None
    lost: int
    note: str


def _read_unit(g: h5py.Group, unit_id: str, size: int) -> _Unit:
    """Every readable row of one unit, chunk by chunk, mended (:mod:`.hdf5_mend`): a
    chunk that does not read costs only its own rows, declared as a gap."""
    attrs = _attrs(g)
    committed = _get(lambda: [int(v) for v in g["committed"][:]])
    names = [k for k in SAMPLE_DATASETS if _get(lambda k=k: k in g, False)]
    shapes = {k: _get(lambda k=k: g[k].shape[0], 0) for k in names}
    limit = min([*shapes.values(), committed[0] if committed else min(shapes.values(), default=0)],
                default=0)
    read = {k: readable_rows(g[k], limit, size) for k in names}
    for k in ("receive_time", "status"):  # a column whose header does not read: no row reads
        read.setdefault(k, (np.zeros(limit, "<f8" if k == "receive_time" else "<u4"),
                            np.zeros(limit, bool)))
    if _get(lambda: word_in_status(g), False):  # an older Xbus file: status held the word
        words, ok = read["status"]
        read["device_status"] = (np.asarray(words, np.int64), ok)
        read["status"] = (np.zeros(limit, "<u4"), np.ones(limit, bool))
    # A file written before the device's status word was kept: none read, none sent.
    read.setdefault("device_status", (np.full(limit, NO_DEVICE_STATUS, np.int64),
                                      np.ones(limit, bool)))
    mended = mend_rows({k: v for k, (v, _) in read.items()}, {k: ok for k, (_, ok) in read.items()},
                       float(attrs["sample_rate_hz"]))
    ev_limit = min(_get(lambda: g["events"].shape[0], 0),
                   committed[1] if committed else _get(lambda: g["events"].shape[0], 0))
    events, ev_ok = (readable_rows(g["events"], ev_limit, size)
                     if _get(lambda: "events" in g, False)
                     else (np.zeros(0, EVENT_DTYPE), np.zeros(0, bool)))
    notes = list(mended.notes)
    if not ev_ok.all():
        notes.append(f"{int((~ev_ok).sum())} of {len(ev_ok)} event-log entries unreadable")
    if committed is None:
        notes.insert(0, "its committed marker is unreadable: every readable row kept")
    return _Unit(unit_id, attrs, mended.columns, _with_gaps(events[ev_ok], mended.gaps),
                 None if committed is None else committed[0], mended.lost, "; ".join(notes))


def _with_gaps(events: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """The unit's readable event-log rows (in the layout's dtype) with the salvage's gaps,
    in time order."""
    out = np.zeros(len(events), EVENT_DTYPE)
    for name in events.dtype.names or ():
        if name in (EVENT_DTYPE.names or ()):
            out[name] = events[name]
    if "missing_low" not in (events.dtype.names or ()):
        out["missing_low"] = out["missing_high"] = out["missing_samples"]
    merged = np.concatenate([out, gaps])
    return merged[np.argsort(merged["time_s"], kind="stable")]


def _description(u: _Unit) -> DeviceDescription:
    a = u.attrs
    modulus = int(a.get("counter_modulus", -1))
    return DeviceDescription(
        model=str(a.get("model", "")), serial_number=str(a.get("serial_number", "")),
        protocol=str(a.get("protocol", "")), transport=str(a.get("transport", "")),
        axes=tuple(json.loads(a["axes"])), sample_rate_hz=float(a["sample_rate_hz"]),
        has_counter=True, counter_modulus=None if modulus < 0 else modulus,
        has_device_time="device_time" in u.data, has_temperature="temperature" in u.data,
        settings=tuple((str(k), str(v)) for k, v in json.loads(a.get("settings", "{}")).items()),
        accel_axes=tuple(json.loads(a.get("accel_axes", "[]"))) if "accel" in u.data else (),
        lsb_deg_s=float(a.get("lsb_deg_s", 0.0)), lsb_relative=float(a.get("lsb_relative", 0.0)))


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
        f = swmr_reader(path, read_attempts=1)  # no writer races a salvage
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
                if unit is not None and "axes" in unit.attrs:
                    units.append(unit)
    empty = [SalvagedUnit(u.unit_id, 0, u.committed, 0, "no sample readable: left out of the "
                          "salvage", u.lost) for u in units if not len(u.data["rate"])]
    units = [u for u in units if len(u.data["rate"])]
    if not units:
        raise RecordFormatError(f"{path}: cannot be recovered: no sample of any unit reads "
                                f"(nothing written)")
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
            n = len(u.data["rate"])
            for k, rows in u.data.items():
                g[k].resize(n, axis=0)
                g[k][:] = rows
            g["events"].resize(len(u.events), axis=0)
            g["events"][:] = u.events
            g["committed"][:] = (n, len(u.events))
        row = np.zeros(1, STATE_DTYPE)
        row[0] = (b"stopped", last_flush.encode(), REASON_SALVAGED.encode()[:128],
                  last_flush.encode())
        f["run_state"][0] = row[0]
        f.attrs.modify("stop_utc", fixed_text(last_flush, 32))
        f.attrs.modify("stop_reason", fixed_text(REASON_SALVAGED, 128))
        f.attrs["salvaged_from"] = str(path)
    return [SalvagedUnit(u.unit_id, len(u.data["rate"]), u.committed, len(u.events), u.note,
                         u.lost) for u in units] + empty
