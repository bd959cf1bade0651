"""Recovery of a run file whose recorder died, or that was damaged: ``station recover``.

A recorder killed (SIGKILL, power cut of the process, a crash) leaves its HDF5 file with
the superblock's "open for write / SWMR write" flags set: readers must open it in SWMR
mode, and HDF5 refuses to open it for writing. :func:`recover_run` clears those flags
(as ``h5clear -s`` does, after verifying the superblock checksum), trims every dataset to
the ``committed`` lengths of the last flush, and records the run as interrupted. A run
that stopped but could not close its file (a full disk) is repaired the same way and
keeps its own stop reason. A damaged file (cut short, flipped bits) is not touched: what
still reads is salvaged into a new file (:mod:`station.storage.hdf5_salvage`). Whatever was done,
the result is read back whole before it is reported.
"""

from __future__ import annotations

import os
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from station.errors import RecordFormatError, RunInProgressError
from station.model.documents import utc_seconds
from station.storage.hdf5 import (
    REASON_RECOVERED,
    SAMPLE_DATASETS,
    fixed_text,
    open_run_file,
    read_run,
    read_unit,
    run_state,
    text_value,
    unit_ids,
)
from station.storage.hdf5_open import superblock
from station.storage.hdf5_salvage import salvage_run, salvaged_path


def _rot(x: int, k: int) -> int:
    return ((x << k) | (x >> (32 - k))) & 0xFFFFFFFF


def lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle``: HDF5's metadata checksum (H5_checksum_lookup3)."""
    m = 0xFFFFFFFF
    a = b = c = (0xDEADBEEF + len(data) + initval) & m
    i, length = 0, len(data)
    while length > 12:
        a = (a + int.from_bytes(data[i:i + 4], "little")) & m
        b = (b + int.from_bytes(data[i + 4:i + 8], "little")) & m
        c = (c + int.from_bytes(data[i + 8:i + 12], "little")) & m
        for x, y, z, k in ((0, 2, 1, 4), (1, 0, 2, 6), (2, 1, 0, 8), (0, 2, 1, 16),
                           (1, 0, 2, 19), (2, 1, 0, 4)):
            v = [a, b, c]
            v[x] = ((v[x] - v[y]) & m) ^ _rot(v[y], k)
            v[y] = (v[y] + v[z]) & m
            a, b, c = v
        i += 12
        length -= 12
    if length == 0:
        return c
    tail = data[i:] + bytes(12 - length)
    a = (a + int.from_bytes(tail[0:4], "little")) & m
    b = (b + int.from_bytes(tail[4:8], "little")) & m
    c = (c + int.from_bytes(tail[8:12], "little")) & m
    for x, y, k in ((2, 1, 14), (0, 2, 11), (1, 0, 25), (2, 1, 16), (0, 2, 4), (1, 0, 14),
                    (2, 1, 24)):
        v = [a, b, c]
        v[x] = (v[x] ^ v[y]) - _rot(v[y], k) & m
        a, b, c = v
    return c


def clear_open_flags(path: Path) -> bool:
    """Clear the superblock's file-consistency flags left by a writer that died (h5clear -s).

    Only version 2 and 3 superblocks at offset 0 with 8-byte offsets are handled, and only
    after their stored checksum is verified. Returns whether anything was changed.

    Raises
    ------
    RecordFormatError
        A superblock this function does not know how to patch safely.
    """
    with open(path, "r+b") as fh:
        sb = bytearray(fh.read(48))
        if sb[:8] != b"\x89HDF\r\n\x1a\n" or sb[8] not in (2, 3) or sb[9] != 8:
            raise RecordFormatError(f"{path}: superblock version {sb[8]} not handled")
        if int.from_bytes(sb[44:48], "little") != lookup3(bytes(sb[:44])):
            raise RecordFormatError(f"{path}: superblock checksum does not verify")
        eof = int.from_bytes(sb[28:36], "little")
        if os.path.getsize(path) < eof:
            fh.truncate(eof)  # space allocated but never written: HDF5 needs it present
        if sb[11] == 0:
            return False
        sb[11] = 0
        sb[44:48] = lookup3(bytes(sb[:44])).to_bytes(4, "little")
        fh.seek(0)
        fh.write(sb)
    return True


@dataclass(frozen=True)
class RecoveryResult:
    """What :func:`recover_run` did: samples kept per unit, samples trimmed, the stop.

    ``salvaged_to`` is the new file a damaged run was salvaged into ("" when the file
    itself was repaired or was closed already); ``damage`` says what was wrong with it,
    ``lost`` per unit the committed samples that did not read (declared as gaps in the
    salvage's event log) and ``notes`` per unit what could not be kept, and where.
    """

    path: str
    already_closed: bool
    kept: dict[str, int]
    trimmed: dict[str, int]
    stop_utc: str
    stop_reason: str
    salvaged_to: str = ""
    damage: str = ""
    notes: dict[str, str] = field(default_factory=dict)
    lost: dict[str, int] = field(default_factory=dict)


def _writer_alive(f: h5py.File, state: dict[str, str], stale_s: float) -> bool:
    if text_value(f.attrs.get("station_host", "")) != socket.gethostname():
        return False
    try:
        os.kill(int(f.attrs.get("writer_pid", -1)), 0)
    except (OSError, ValueError):
        return False
    last = utc_seconds(state["last_flush_utc"])
    return last is None or time.time() - last < stale_s


def recover_run(path: str | Path, *, force: bool = False, stale_s: float = 10.0,
                out: str | Path | None = None) -> RecoveryResult:
    """Close a run file its recorder left open, or salvage a damaged one.

    A file whose committed data all read (a recorder killed, or stopped by a full disk)
    is repaired in place: marked interrupted (or keeping its own stop reason), every
    committed sample kept, what was written after the last flush trimmed. A damaged file
    (cut short, flipped bits) is left as it is and what still reads is salvaged into a
    new run file (``out``, default ``NAME.recovered.h5`` beside it). Either way the result
    is read back whole before it is reported.

    Parameters
    ----------
    path : str or Path
        The run file.
    force : bool
        Recover even if its writer looks alive (same host, process there, flushed less
        than ``stale_s`` s ago).
    out : str or Path or None
        Where a salvage goes.

    Raises
    ------
    RunInProgressError
        A live recorder is still writing it.
    RecordFormatError
        Not a run file, nothing in it can be salvaged, or the result does not read.
    """
    path = Path(path)
    try:
        with open_run_file(path) as f:
            state = run_state(f)
            stopped = state["state"] == "stopped"
            if not stopped and not force and _writer_alive(f, state, stale_s):
                raise RunInProgressError(
                    f"{path} is being recorded by process {int(f.attrs['writer_pid'])} on "
                    f"this host (last flush {state['last_flush_utc']}); watch it with "
                    f"`station watch {path}`, or stop that recorder first")
            kept = {u: len(read_unit(f, u).counter) for u in unit_ids(f)}  # every checksum
    except RecordFormatError as exc:
        if "not a gyro-station run file" in str(exc) or "not an HDF5 file" in str(exc) or \
                "is a directory" in str(exc):
            raise
        return _salvage(path, Path(out) if out else salvaged_path(path), str(exc))
    if stopped and not superblock(path).open_for_write:
        return RecoveryResult(str(path), True, kept, dict.fromkeys(kept, 0),
                              state["stop_utc"], state["stop_reason"])
    result = _repair_in_place(path, state)
    _verify(path, f"{path} was repaired but")
    return result


def _repair_in_place(path: Path, state: dict[str, str]) -> RecoveryResult:
    """Clear the open flags, trim to the committed lengths, record the stop."""
    stopped = state["state"] == "stopped"
    clear_open_flags(path)
    kept, trimmed = {}, {}
    stop = state["stop_utc"] if stopped else state["last_flush_utc"]
    reason = state["stop_reason"] if stopped else REASON_RECOVERED
    with h5py.File(path, "r+") as f:
        for uid in unit_ids(f):
            g = f["units"][uid]
            n, m = (int(v) for v in g["committed"][:])
            longest = max(g[k].shape[0] for k in SAMPLE_DATASETS if k in g)
            for k in SAMPLE_DATASETS:
                if k in g:
                    g[k].resize(min(n, g[k].shape[0]), axis=0)
            g["events"].resize(min(m, g["events"].shape[0]), axis=0)
            kept[uid], trimmed[uid] = n, max(0, longest - n)
        row = f["run_state"][0]
        row["state"], row["stop_utc"] = b"stopped", stop.encode()
        row["stop_reason"] = reason.encode()[:128]
        f["run_state"][0] = row
        f.attrs.modify("stop_utc", fixed_text(stop, 32))
        f.attrs.modify("stop_reason", fixed_text(reason, 128))
    return RecoveryResult(str(path), False, kept, trimmed, stop, reason)


def _salvage(path: Path, out: Path, damage: str) -> RecoveryResult:
    if out.exists():
        raise RecordFormatError(f"{path} is damaged and {out} exists already: move it away "
                                f"or give another --out")
    try:
        units = salvage_run(path, out)
        _verify(out, f"{path} is damaged ({damage}); its salvage {out}")
    except BaseException:
        out.unlink(missing_ok=True)
        raise
    with open_run_file(out) as f:
        state = run_state(f)
    return RecoveryResult(
        str(path), False, {u.unit_id: u.kept for u in units},
        {u.unit_id: max(0, (u.committed or u.kept) - u.kept) for u in units},
        state["stop_utc"], state["stop_reason"], salvaged_to=str(out), damage=damage,
        notes={u.unit_id: u.note for u in units if u.note},
        lost={u.unit_id: u.lost for u in units})


def _verify(path: Path, what: str) -> None:
    """Read the run back whole as every reader does (each unit's samples finite), or say
    that it does not read."""
    try:
        run = read_run(path)
    except RecordFormatError as exc:
        raise RecordFormatError(f"{what} does not read: {exc}") from exc
    for unit in run.units:
        if not np.all(np.isfinite(unit.record.rate_deg_s)):
            raise RecordFormatError(f"{what} holds non-finite rates in {unit.unit_id}")
