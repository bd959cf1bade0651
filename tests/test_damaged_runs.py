"""Damaged run files: every reader answers within seconds, with the same data or one clear
line; ``station recover`` salvages what is readable into a file that reads, or says it
cannot.

Two run files of two units are written by the recorder's writer: one closed, one still
held by its writer when it is copied (as a killed recorder leaves it: readers open it in
SWMR mode). Each is cut short (to 3 kB, 50 %, 99.9 % of its length) and has single bits
flipped at random places (``python benchmarks/bench_reliability.py`` runs many more). Every reader
(analyze, grade and report, watch,
the TUI's live view and run list, recover) runs on every copy, timed, under a watchdog
that ends the test run if one hangs: HDF5's SWMR reader used to retry every bad
metadata block for hours, and read past the end of a truncated file as zeros.
"""

from __future__ import annotations

import contextlib
import faulthandler
import io
from pathlib import Path

import numpy as np
import pytest

from devices.protocols import DeviceDescription
from station.cli import main
from station.model.documents import (
    Descriptor,
    EventBatch,
    LogEntry,
    RunStart,
    RunStop,
    data_keys,
    utc_now,
)
from station.model.runs import RunMetadata
from station.storage.hdf5_writer import RunFileWriter
from tests.damage_helpers import damaged_copies, sweep_here

RATE_HZ = 500.0


def _write_run(path: Path, *, close: bool) -> RunFileWriter:
    writer = RunFileWriter(path, flush_interval_s=0.5)
    writer(
        RunStart(
            "uid", utc_now(), ("unit1", "unit2"), 10.0, str(path), RunMetadata(profile="VG951")
        )
    )
    for uid in ("unit1", "unit2"):
        d = DeviceDescription("TEST", uid, "stim300", "serial", ("x", "y", "z"), RATE_HZ, True,
                              256, False, True)
        writer(Descriptor(uid, f"sim+serial://{uid}", d, data_keys(d), utc_now(), "sim", 1.0))
    rng = np.random.default_rng(4)
    for k in range(6):  # six flushes of 1000 samples, a gap in each
        for uid in ("unit1", "unit2"):
            counter = np.arange(k * 1010, k * 1010 + 1000)
            gap = LogEntry("gap", k * 2.0, 1, 10, int(counter[0]) - 11, "counter+elapsed",
                           missing_low=10, missing_high=266)
            writer(EventBatch(uid, k, rng.normal(0.0, 0.01, (1000, 3)), counter,
                              counter / RATE_HZ, np.zeros(1000, np.uint32),
                              temperature_c=np.full(1000, 25.0), log=(gap,)))
        writer.flush()
    if close:
        writer(RunStop(utc_now(), "duration"))
    return writer


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory: pytest.TempPathFactory) -> list:
    tmp = tmp_path_factory.mktemp("damaged")
    closed = tmp / "closed.h5"
    _write_run(closed, close=True)
    held = tmp / "held.h5"
    writer = _write_run(held, close=False)  # a killed recorder's file: still open for write
    killed = tmp / "killed.h5"
    killed.write_bytes(held.read_bytes())
    writer(RunStop(utc_now(), "duration"))
    results = []
    # A reader that hangs ends the test run with every thread's stack, after 120 s.
    faulthandler.dump_traceback_later(120.0, exit=True)
    try:
        for original, seed in ((closed, 1), (killed, 2)):
            copies = damaged_copies(original, tmp / original.stem, flips=6, seed=seed,
                                    cuts=(0.0, 0.5, 0.999))
            results += sweep_here(original, copies)
    finally:
        faulthandler.cancel_dump_traceback_later()
    return results


def test_every_reader_answers_a_damaged_file_within_seconds(outcomes) -> None:
    slow = [o for o in outcomes if o.seconds > 5.0]
    assert not slow, slow
    print(
        f"{len(outcomes)} reads of damaged files, slowest {max(o.seconds for o in outcomes):.2f} s"
    )


def test_every_reader_gives_the_same_data_or_one_clear_line(outcomes) -> None:
    bad = [o for o in outcomes if not o.ok]
    assert not bad, bad
    kinds = {o.kind for o in outcomes}
    assert {"clear error", "same data"} <= kinds  # both happen: a flip in unused space reads
    # a cut file never reads whole (the run list reads only the run's state: it may)
    cuts = [o for o in outcomes if "-cut" in o.path and o.reader in ("analyze", "grade, report")]
    assert cuts and all(o.kind == "clear error" for o in cuts), cuts


def test_recover_salvages_the_readable_part_of_a_cut_file(outcomes) -> None:
    salvaged = [o for o in outcomes if o.reader == "recover" and o.kind == "salvaged"
                and "-cut" in o.path]
    refused = [o for o in outcomes if o.reader == "recover" and o.kind == "clear error"]
    assert salvaged and refused  # half a file salvages; its first 3 kB do not
    assert all("cut3000" in o.path or "bit" in o.path for o in refused), refused


def test_the_command_line_says_one_line_and_exits_2(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "run.h5"
    _write_run(run, close=True)
    (cut,) = damaged_copies(run, tmp_path / "cut", flips=0, seed=0, cuts=(0.5,))
    folder = tmp_path / "folder.h5"
    folder.mkdir()
    binary = tmp_path / "binary.csv"
    binary.write_bytes(bytes(range(256)) * 4)
    for argv in (["analyze", str(cut)], ["grade", str(cut), "--profile", "VG951"],
                 ["report", str(cut), "--out", str(tmp_path / "r")], ["watch", str(cut)],
                 ["analyze", str(folder)], ["analyze", str(binary), "--rate", "100"],
                 ["recover", str(folder)]):
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err, (argv, err)
