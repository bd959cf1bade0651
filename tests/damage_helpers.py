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


def _recover(path: Path) -> Any:
    """Recover a copy; the result must read, and hold a prefix of each unit's samples."""
    from station.storage.hdf5 import read_run
    from station.storage.hdf5_recover import recover_run

    work = path.with_name(path.stem + "-recovering.h5")
    shutil.copyfile(path, work)
    result = recover_run(work, force=True, out=path.with_name(path.stem + "-salvage.h5"))
    run = read_run(result.salvaged_to or work)
    return {u.unit_id: u.record.rate_deg_s for u in run.units}


#: Every reader of a run file, by the command or screen that uses it.
READERS: dict[str, Callable[[Path], Any]] = {
    "analyze": _analyze, "grade, report": _grade_and_report, "watch": _watch,
    "tui live": _tui_live, "tui run list": _tui_runs, "recover": _recover}


def _same(a: Any, b: Any, prefix: bool) -> bool:
    """Equal (for recover: each unit it kept, a prefix of the original's samples)."""
    if isinstance(a, dict):
        return (isinstance(b, dict) and set(b) <= set(a) and (bool(b) or not prefix)
                and all(_same(a[k], b[k], prefix) for k in b))
    if isinstance(a, np.ndarray):
        return (isinstance(b, np.ndarray) and (len(b) <= len(a) if prefix else a.shape == b.shape)
                and np.array_equal(a[:len(b)], b))
    if isinstance(a, list | tuple):
        return (isinstance(b, list | tuple) and len(a) == len(b)
                and all(_same(x, y, prefix) for x, y in zip(a, b, strict=True)))
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
        return Outcome(reader, str(path), "salvaged" if _same(original, got, True)
                       else "wrong data", seconds)
    return Outcome(reader, str(path), "same data" if _same(original, got, False)
                   else "wrong data", seconds)


def sweep_here(original: Path, damaged: list[Path]) -> list[Outcome]:
    """Every reader on every damaged copy (in this process)."""
    out = []
    for reader, fn in READERS.items():
        if reader == "recover":
            from station.storage.hdf5 import read_run

            reference = {u.unit_id: u.record.rate_deg_s for u in read_run(original).units}
        else:
            reference = fn(original)
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
