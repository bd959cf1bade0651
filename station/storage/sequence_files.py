"""The sequence file: a sequence's journal and its segments, in HDF5.

Layout (``docs/hdf5-layout.md``, "Sequence files")::

    /                     attributes: format = "gyro-station-sequence", format_version,
                          sequence, profile (name, version, sha256, path), steps (JSON),
                          unit_ids, unit_urls, power_urls (JSON), chamber_url, time_warp,
                          state, operator, lot, start_utc
    /journal    (M,)      compound: kind, utc, wall_s, clock_s, step, cycle, unit, value, detail
    /segments   (K,)      compound: step, cycle, file, interrupted, superseded
    /segment/<NNN>        external link to the root of segment NNN's run file

Each segment is a run file of the recorder (``<sequence>.segments/sNNN-cCC-unitsK.h5``
beside the sequence file), with its own crash safety; the sequence file is small and is
rewritten whole after every change, to a temporary name, synced and renamed over the old
one, so that a crash at any instant leaves the previous or the new version, never a
damaged one. Open a segment by its link (``f["segment/003"]``) or by the ``file`` column
(relative to the sequence file's folder).
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from station.errors import RecordFormatError
from station.model.records import RateRecord
from station.model.sequence_runs import JournalEntry, Segment, SequenceRun
from station.model.sequences import Step
from station.storage.hdf5 import (
    gap_sample_index,
    open_run_file,
    read_unit,
    text_value,
    unit_record,
)

FORMAT = "gyro-station-sequence"
FORMAT_VERSION = 1
JOURNAL_DTYPE = np.dtype([("kind", "S16"), ("utc", "S32"), ("wall_s", "<f8"), ("clock_s", "<f8"),
                          ("step", "<i4"), ("cycle", "<i4"), ("unit", "S32"), ("value", "<f8"),
                          ("detail", "S200")])
SEGMENT_DTYPE = np.dtype([("step", "<i4"), ("cycle", "<i4"), ("file", "S200"),
                          ("interrupted", "u1"), ("superseded", "u1")])


def is_sequence_file(path: str | Path) -> bool:
    """Whether ``path`` is an HDF5 file with this module's format attribute."""
    try:
        with h5py.File(path, "r") as f:
            return text_value(f.attrs.get("format", "")) == FORMAT
    except (OSError, ValueError):
        return False


def _fixed(text: str, size: int) -> bytes:
    return text.encode("utf-8")[:size]


def write_sequence(run: SequenceRun) -> None:
    """Write ``run`` to ``run.path``, atomically (a temporary file synced and renamed over
    it, the folder synced).

    Raises
    ------
    OSError
        The file cannot be written (the previous version stays).
    """
    path = Path(run.path)
    tmp = path.with_name(f".{path.name}.tmp")
    with h5py.File(tmp, "w") as f:
        a = f.attrs
        a["format"], a["format_version"] = FORMAT, FORMAT_VERSION
        a["sequence"] = run.name
        a["profile"], a["profile_version"] = run.profile, run.profile_version
        a["profile_sha256"], a["profile_path"] = run.profile_sha256, run.profile_path
        a["steps"] = json.dumps([dataclasses.asdict(s) for s in run.steps])
        a["unit_ids"], a["unit_urls"] = json.dumps(run.unit_ids), json.dumps(run.unit_urls)
        a["power_urls"], a["chamber_url"] = json.dumps(run.power_urls), run.chamber_url
        a["time_warp"], a["state"] = run.time_warp, run.state
        a["operator"], a["lot"], a["start_utc"] = run.operator, run.lot, run.start_utc
        journal = np.array([(_fixed(e.kind, 16), _fixed(e.utc, 32), e.wall_s, e.clock_s, e.step,
                             e.cycle, _fixed(e.unit, 32), e.value, _fixed(e.detail, 200))
                            for e in run.journal], dtype=JOURNAL_DTYPE)
        ds = f.create_dataset("journal", data=journal)
        ds.attrs["units"] = json.dumps({"wall_s": "s", "clock_s": "s", "value": "degC or s"})
        f.create_dataset("segments", data=np.array(
            [(s.step, s.cycle, _fixed(s.file, 200), s.interrupted, s.superseded)
             for s in run.segments],
            dtype=SEGMENT_DTYPE))
        for n, s in enumerate(run.segments):
            f[f"segment/{n:03d}"] = h5py.ExternalLink(s.file, "/")
    with open(tmp, "rb") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def read_sequence(path: str | Path) -> SequenceRun:
    """Read a sequence file.

    Raises
    ------
    RecordFormatError
        Not a sequence file of this station, or damaged.
    """
    try:
        with h5py.File(path, "r") as f:
            a = {k: f.attrs[k] for k in f.attrs}
            if text_value(a.get("format", "")) != FORMAT:
                raise RecordFormatError(f"{path}: not a sequence file of this station (no "
                                        f"format={FORMAT!r} attribute)")
            journal = f["journal"][()]
            segments = f["segments"][()]
    except OSError as exc:
        raise RecordFormatError(f"{path}: cannot read the sequence file: {exc}") from exc

    def text(k: str) -> str:
        return text_value(a.get(k, ""))

    steps = tuple(Step(**d) for d in json.loads(text("steps")))
    superseded = "superseded" in (segments.dtype.names or ())  # (files before it: none)
    return SequenceRun(
        path=str(path), name=text("sequence"), profile=text("profile"),
        profile_version=text("profile_version"), profile_sha256=text("profile_sha256"),
        profile_path=text("profile_path"), steps=steps,
        unit_ids=tuple(json.loads(text("unit_ids"))),
        unit_urls=tuple(json.loads(text("unit_urls"))),
        power_urls=tuple(json.loads(text("power_urls"))), chamber_url=text("chamber_url"),
        time_warp=float(a.get("time_warp", 1.0)), state=text("state"),
        journal=tuple(JournalEntry(text_value(r["kind"]), text_value(r["utc"]),  # type: ignore[arg-type]
                                   float(r["wall_s"]), float(r["clock_s"]), int(r["step"]),
                                   int(r["cycle"]), text_value(r["unit"]), float(r["value"]),
                                   text_value(r["detail"])) for r in journal),
        segments=tuple(Segment(int(r["step"]), int(r["cycle"]), text_value(r["file"]),
                               bool(r["interrupted"]), superseded and bool(r["superseded"]))
                        for r in segments),
        operator=text("operator"), lot=text("lot"), start_utc=text("start_utc"))


def segment_path(run: SequenceRun, segment: Segment) -> Path:
    """The run file of ``segment`` (beside the sequence file)."""
    return Path(run.path).parent / segment.file


@dataclasses.dataclass(frozen=True)
class SegmentUnit:
    """One unit's data in one segment, as the sequence figures need them.

    Attributes
    ----------
    record : RateRecord
        The valid samples' rates (deg/s) on the sample grid (gaps, and the samples the
        device flagged not valid, as NaN rows via ``sample_index``; the grid starts at
        the first recorded sample), the temperature the unit reported.
    receive_time_s : ndarray
        Receive time of each recorded sample, s on the unit's time base (from
        ``start_utc``).
    counter, status : ndarray
        The device's counter (unwrapped) and status of each recorded sample.
    start_wall_s : float
        When the recorder started reading the unit, s since the epoch.
    time_warp : float
        Unit clock seconds per wall second.
    attrs : dict
        The unit's attributes in the run file.
    leading_missing : int
        Samples the recorder declared missing before the first it received (a simulated
        unit counts from 0 at its start: what it sent before it was first read).
    grid_index : ndarray or None
        The grid index of each recorded sample, valid or not (None: ``0 .. n - 1``):
        ``record`` holds only the valid samples (``status`` 0) on the same grid.
    """

    record: RateRecord
    receive_time_s: NDArray[np.float64]
    counter: NDArray[np.int64]
    status: NDArray[np.uint32]
    start_wall_s: float
    time_warp: float
    attrs: dict[str, Any]
    leading_missing: int = 0
    grid_index: NDArray[np.int64] | None = None


def read_segment_unit(path: str | Path, unit_id: str) -> SegmentUnit:
    """One unit of a segment's run file (committed data; a killed recorder's file too).

    Raises
    ------
    RecordFormatError
        Not a run file, or no such unit.
    """
    from datetime import datetime

    with open_run_file(path) as f:
        if unit_id not in f["units"]:
            raise RecordFormatError(f"{path}: no unit {unit_id!r}")
        u = read_unit(f, unit_id)
    start = text_value(u.attrs.get("start_utc", ""))
    try:
        start_wall = datetime.fromisoformat(start.replace("Z", "+00:00")).timestamp()
    except ValueError:
        start_wall = float("nan")
    receive = np.asarray(u.receive_time_s, dtype=np.float64)
    ev = u.events
    leading = 0
    if len(ev) and len(receive):
        before = ((ev["kind"] == b"gap") & (ev["after_counter"] < 0)
                  & (ev["time_s"] <= receive[0]))
        leading = int(ev["missing_samples"][before].sum())
    counter = np.asarray(u.counter, dtype=np.int64)
    return SegmentUnit(unit_record(u, f"{path}#{unit_id}", keep_grid=True), receive,
                       counter, np.asarray(u.status), start_wall,
                       float(u.attrs.get("time_warp", 1.0)), dict(u.attrs), leading,
                       gap_sample_index(counter, receive, u.events))
