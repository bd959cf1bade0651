"""Helpers of the damaged-file tests and the reliability benchmark: damaged copies of a run
file, and every reader run on each of them, timed, in a process of its own (a reader that
hangs cannot hang the caller: it kills the process after a time limit)."""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import random
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from station.errors import RecordFormatError


def damaged_copies(original: Path, folder: Path, *, flips: int, seed: int,
                   cuts: tuple[float, ...] = (0.0, 0.1, 0.5, 0.9, 0.999)) -> list[Path]:
    """Copies of ``original`` cut short (at 3 kB and at each fraction of its length) and
    with one bit flipped (``flips`` copies, bits drawn with ``seed``)."""
    data = original.read_bytes()
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for cut in cuts:
        size = 3000 if cut == 0.0 else int(len(data) * cut)
        path = folder / f"{original.stem}-cut{size}.h5"
        path.write_bytes(data[:size])
        out.append(path)
    rng = random.Random(seed)
    for _ in range(flips):
        bit = rng.randrange(8 * len(data))
        flipped = bytearray(data)
        flipped[bit // 8] ^= 1 << (bit % 8)
        path = folder / f"{original.stem}-bit{bit}.h5"
        path.write_bytes(bytes(flipped))
        out.append(path)
    return out


def flip_in_chunks(original: Path, out: Path, chunks: list[tuple[str, int]]) -> Path:
    """A copy of ``original`` (a closed run file) at ``out`` with one byte flipped in the
    middle of each chunk ``(dataset, chunk number)``, e.g. ``("units/unit1/rate", 5)``."""
    import h5py

    data = bytearray(original.read_bytes())
    with h5py.File(original, "r") as f:
        for name, chunk in chunks:
            ds = f[name]
            info = ds.id.get_chunk_info_by_coord((chunk * ds.chunks[0], *(0,) * (ds.ndim - 1)))
            data[info.byte_offset + info.size // 2] ^= 0xFF
    out.write_bytes(bytes(data))
    return out


def _analyze(path: Path) -> Any:
    from station.storage.hdf5 import read_run_record

    return [read_run_record(path, u).rate_deg_s for u in ("unit1", "unit2")]


def _grade_and_report(path: Path) -> Any:
    from station.storage.hdf5 import read_run

    run = read_run(path)
    return [(u.record.rate_deg_s, [(e.kind, e.missing_samples) for e in u.events])
            for u in run.units]


def _watch(path: Path) -> Any:
    from station.commands.watch import status_lines

    return status_lines(path)[1]


def _tui_live(path: Path) -> Any:
    from station.tui.live import RunPoller

    snapshot = RunPoller(path).poll()
    return [(u.unit_id, u.samples) for u in snapshot.units]


def _tui_runs(path: Path) -> Any:
    from station.services.recorder_process import run_file_state

    state = run_file_state(path)
    return (state.state, state.stop_reason)


def unit_samples(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each unit's (counters, rates) of a run file, as committed."""
    from station.storage.hdf5 import open_run_file, read_unit, unit_ids

    with open_run_file(path) as f:
        return {u: (np.asarray(d.counter), np.asarray(d.rate_deg_s))
                for u in unit_ids(f) for d in (read_unit(f, u),)}


def _recover(path: Path) -> Any:
    """Recover a copy; the result must read, and hold some of each unit's samples."""
    from station.storage.hdf5 import read_run
    from station.storage.hdf5_recover import recover_run

    work = path.with_name(path.stem + "-recovering.h5")
    shutil.copyfile(path, work)
    result = recover_run(work, force=True, out=path.with_name(path.stem + "-salvage.h5"))
    read_run(result.salvaged_to or work)  # reads as every reader reads it
    return unit_samples(Path(result.salvaged_to or work))


def kept_as_recorded(original: dict[str, tuple[np.ndarray, np.ndarray]],
                     got: dict[str, tuple[np.ndarray, np.ndarray]]) -> bool:
    """Whether every unit ``got`` holds (one at least) is a unit of ``original``, and each
    of its samples is the original's sample of the same counter."""
    if not got or not set(got) <= set(original):
        return False
    for uid, (counter, rate) in got.items():
        ref_counter, ref_rate = original[uid]
        at = np.searchsorted(ref_counter, counter)
        if np.any(at >= len(ref_counter)) or not np.array_equal(ref_counter[at], counter) \
                or not np.array_equal(ref_rate[at], rate):
            return False
    return True


#: Every reader of a run file, by the command or screen that uses it.
READERS: dict[str, Callable[[Path], Any]] = {
    "analyze": _analyze, "grade, report": _grade_and_report, "watch": _watch,
    "tui live": _tui_live, "tui run list": _tui_runs, "recover": _recover}


def _same(a: Any, b: Any) -> bool:
    """Equal, arrays included."""
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.shape == b.shape and np.array_equal(a, b)
    if isinstance(a, list | tuple):
        return (isinstance(b, list | tuple) and len(a) == len(b)
                and all(_same(x, y) for x, y in zip(a, b, strict=True)))
    return bool(a == b)


@dataclass(frozen=True)
class Outcome:
    """What one reader did with one damaged file."""

    reader: str
    path: str
    kind: str  # "same data", "clear error", "salvaged" or a failure: "wrong data", "bad error"
    seconds: float
    message: str = ""

    @property
    def ok(self) -> bool:
        return self.kind in ("same data", "clear error", "salvaged")


def _one(reader: str, path: Path, original: Any) -> Outcome:
    t0 = time.monotonic()
    try:
        got = READERS[reader](path)
    except RecordFormatError as exc:
        text = str(exc)
        clear = "\n" not in text and path.stem in text and "Traceback" not in text
        return Outcome(reader, str(path), "clear error" if clear else "bad error",
                       time.monotonic() - t0, text[:300])
    except Exception as exc:  # noqa: BLE001 - the failure being tested for
        return Outcome(reader, str(path), "bad error", time.monotonic() - t0,
                       f"{type(exc).__name__}: {exc}"[:300])
    seconds = time.monotonic() - t0
    if reader == "recover":
        return Outcome(reader, str(path), "salvaged" if kept_as_recorded(original, got)
                       else "wrong data", seconds)
    return Outcome(reader, str(path), "same data" if _same(original, got) else "wrong data",
                   seconds)


def sweep_here(original: Path, damaged: list[Path]) -> list[Outcome]:
    """Every reader on every damaged copy (in this process)."""
    out = []
    for reader, fn in READERS.items():
        reference = unit_samples(original) if reader == "recover" else fn(original)
        out += [_one(reader, path, reference) for path in damaged]
    return out


def sweep(original: Path, damaged: list[Path], timeout_s: float) -> list[Outcome]:
    """:func:`sweep_here` in a process of its own; TimeoutError if it takes longer than
    ``timeout_s`` (a reader hung), the process then killed."""
    ctx = multiprocessing.get_context("spawn")
    pool = concurrent.futures.ProcessPoolExecutor(1, mp_context=ctx)
    try:
        return pool.submit(sweep_here, original, damaged).result(timeout=timeout_s)
    except concurrent.futures.TimeoutError:
        for process in list(pool._processes.values()):  # the hung reader
            process.kill()
        raise TimeoutError(f"the readers did not finish {len(damaged)} damaged files in "
                           f"{timeout_s:g} s: one hangs") from None
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
