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
import json
import warnings
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
from station.model.profiles import load_profile
from station.model.runs import RunMetadata
from station.services.fleet_tasks import analyze_task, grade_task
from station.storage.hdf5 import open_run_file, read_run, read_unit, unit_counts
from station.storage.hdf5_mend import STATUS_UNREADABLE
from station.storage.hdf5_recover import recover_run
from station.storage.hdf5_writer import RunFileWriter
from tests.damage_helpers import (
    damaged_copies,
    flip_in_chunks,
    kept_as_recorded,
    sweep_here,
    unit_samples,
)

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


@pytest.mark.slow
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


@pytest.fixture(scope="module")
def closed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("chunks") / "run.h5"
    _write_run(path, close=True)  # 6000 samples per unit, chunks of 512 rows, a gap per 1000
    return path


# (dataset of unit1, chunk, samples lost): rate chunk 5 (rows 2560..3071); counter chunk 2
# sits inside one flush (the rows around it pin it), chunk 5 spans a gap (they do not).
CHUNK_DAMAGE = [("rate", 5, 512), ("counter", 2, 0), ("counter", 5, 512),
                ("receive_time", 5, 0), ("status", 5, 0), ("temperature", 11, 0),
                ("rate", 11, 368)]


@pytest.mark.parametrize(("dataset", "chunk", "lost"), CHUNK_DAMAGE)
def test_a_damaged_chunk_costs_only_its_own_samples(closed_run: Path, tmp_path: Path,
                                                    dataset: str, chunk: int, lost: int) -> None:
    damaged = flip_in_chunks(closed_run, tmp_path / "flipped.h5",
                             [(f"units/unit1/{dataset}", chunk)])
    result = recover_run(damaged, out=tmp_path / "salvage.h5")
    assert result.salvaged_to and result.lost == {"unit1": lost, "unit2": 0}
    assert result.kept == {"unit1": 6000 - lost, "unit2": 6000}
    original, salvaged = unit_samples(closed_run), unit_samples(tmp_path / "salvage.h5")
    assert kept_as_recorded(original, salvaged)
    before, after = read_run(closed_run).units[0], read_run(result.salvaged_to).units[0]
    declared = [e for e in after.events if "salvage" in e.detail]
    if lost:  # one gap, after the last sample before the chunk, as long as the chunk
        (gap,) = declared
        first = chunk * 512
        assert gap.missing_samples == gap.missing_low == gap.missing_high == lost
        assert f"rows {first}..{first + lost - 1}" in gap.detail
    else:
        assert not declared
    # the samples kept stand on the original's time grid; the gap holds the lost ones (the
    # record ends at the last sample that reads: lost samples at the end are outside it)
    trailing = lost if chunk == 11 else 0
    assert after.record.span_samples == before.record.span_samples - trailing
    keep = np.isin(original["unit1"][0], salvaged["unit1"][0])
    if dataset == "status":  # flags that do not read are not "good": the analysis leaves
        keep[chunk * 512:chunk * 512 + 512] = False  # those samples out (status alone)
    np.testing.assert_array_equal(after.record.sample_index, before.record.sample_index[keep])
    with open_run_file(result.salvaged_to) as f:
        unit = read_unit(f, "unit1")
        counts = unit_counts(f, "unit1")
    rows = slice(chunk * 512, chunk * 512 + 512)
    if dataset in ("receive_time", "temperature"):  # interpolated along the counter
        np.testing.assert_allclose(unit.receive_time_s, unit.counter / RATE_HZ, atol=1e-9)
        assert np.all(unit.temperature_c == 25.0)
    if dataset == "status":
        assert np.all(unit.status[rows] == STATUS_UNREADABLE) and not unit.status[:rows.start].any()
    # the books: recorded + declared missing as before
    assert counts.samples_recorded + counts.samples_missing_declared == 6000 + 60


def test_a_simulated_run_cut_to_half_salvages_what_reads(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    run = tmp_path / "sim.h5"
    assert main(["simulate", "--model", "VG951", "--duration", "60s", "--rate", "100",
                 "--seed", "1", "--quiet", "--out", str(run)]) == 0
    (cut,) = damaged_copies(run, tmp_path / "cut", flips=0, seed=0, cuts=(0.5,))
    capsys.readouterr()
    assert main(["recover", str(cut), "--json", "--out", str(tmp_path / "salvage.h5")]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["kept"] == {"sim": 6000} and result["lost"] == {"sim": 0}
    assert kept_as_recorded(unit_samples(run), unit_samples(tmp_path / "salvage.h5"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning either
        assert main(["analyze", str(tmp_path / "salvage.h5"), "--json"]) == 0


def _empty_run(path: Path) -> Path:
    writer = RunFileWriter(path, flush_interval_s=0.5)
    writer(RunStart("uid", utc_now(), ("unit1",), 10.0, str(path), RunMetadata(profile="")))
    d = DeviceDescription("TEST", "unit1", "stim300", "serial", ("x", "y", "z"), RATE_HZ, True,
                          256, False, True)
    writer(Descriptor("unit1", "sim+serial://unit1", d, data_keys(d), utc_now(), "sim", 1.0))
    writer.flush()
    writer(RunStop(utc_now(), "duration"))
    return path


def test_every_reader_answers_an_empty_run_in_one_line(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    run = _empty_run(tmp_path / "empty.h5")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for argv, code in ((["analyze", str(run)], 2), (["analyze", str(run), "--json"], 2),
                           (["grade", str(run), "--profile", "VG951"], 2),
                           (["report", str(run), "--profile", "VG951", "--out",
                             str(tmp_path / "r")], 2),
                           (["davar", str(run), "--window-s", "10"], 2),
                           (["watch", str(run)], 0), (["recover", str(run)], 0)):
            assert main(argv) == code, argv
            out, err = capsys.readouterr()
            text = err if code else out
            assert text.count("\n") <= 2 and "Traceback" not in text and "0 samples" in text \
                or "nothing to do" in text, (argv, text)
        for outcome in (analyze_task(str(run), "unit1", None, None),
                        grade_task(str(run), "unit1", load_profile("VG951"), None)):
            assert "\n" not in outcome.error and "0 samples" in outcome.error, outcome


def test_a_salvage_of_nothing_says_so_and_writes_nothing(closed_run: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    every_rate_chunk = [(f"units/{u}/rate", k) for u in ("unit1", "unit2") for k in range(12)]
    no_rate = flip_in_chunks(closed_run, tmp_path / "no-rate.h5", every_rate_chunk)
    (cut,) = damaged_copies(_empty_run(tmp_path / "empty.h5"), tmp_path / "cut", flips=0,
                            seed=0, cuts=(0.999,))
    for damaged, why in ((no_rate, "no sample of any unit reads"), (cut, "cannot be recovered")):
        out = tmp_path / "salvage.h5"
        assert main(["recover", str(damaged), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and why in err, err
        assert not out.exists()
