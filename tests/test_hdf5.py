"""The run file: layout and units, SWMR reading while writing, the reader and the analysis
commands on it, the superblock checksum, and a disk that fills during a run."""

from __future__ import annotations

import contextlib
import io
import json
import resource
import time
from pathlib import Path

import h5py
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
from station.services.record import EXIT_RUN_FAULT
from station.storage.hdf5 import read_run, read_run_record
from station.storage.hdf5_recover import lookup3
from station.storage.hdf5_writer import RunFileWriter
from station.storage.runs import read_record
from tests.test_recorder_helpers import (
    check_unit_against_signal,
    start_recorder,
    summaries,
    wait_for_samples,
)

RATE_HZ = 100.0


def _description(serial: str, *, temperature: bool) -> DeviceDescription:
    return DeviceDescription(model="TEST", serial_number=serial, protocol="stim300",
                             transport="serial", axes=("x", "y", "z"),
                             sample_rate_hz=RATE_HZ, has_counter=True, counter_modulus=256,
                             has_device_time=False, has_temperature=temperature,
                             settings=(("port", "/dev/null"),))


def _batch(unit: str, seq: int, start: int, n: int, log: tuple[LogEntry, ...] = ()
           ) -> EventBatch:
    counter = np.arange(start, start + n, dtype=np.int64)
    rate = np.column_stack([counter * 1e-3, -counter * 1e-3, np.full(n, 0.5)])
    return EventBatch(unit, seq, rate, counter, counter / RATE_HZ, np.zeros(n, np.uint32),
                      temperature_c=np.full(n, 25.0), log=log)


@pytest.fixture
def written(tmp_path: Path) -> Path:
    """A two-unit run written from documents, read live by a SWMR reader between flushes."""
    path = tmp_path / "run.h5"
    writer = RunFileWriter(path, flush_interval_s=0.5)
    writer(RunStart("uid1", utc_now(), ("unit1", "unit2"), 10.0, str(path),
                    RunMetadata(profile="P", profile_version="3", operator="ann", lot="L1",
                                station_host="bench", software_version="0.1.0")))
    for uid, serial in (("unit1", "A1"), ("unit2", "B2")):
        d = _description(serial, temperature=True)
        writer(Descriptor(uid, f"sim+serial://{serial}", d, data_keys(d), utc_now(),
                          "simulated device clock, warp x1", 1.0))
    writer(_batch("unit1", 0, 0, 300))
    writer(_batch("unit2", 0, 0, 200))
    writer.flush()
    with h5py.File(path, "r", swmr=True) as live:  # a reader while the writer is open
        assert live["units/unit1/committed"][0] == 300
        gap = (LogEntry("gap", 5.0, 1, 12, 299, "counter+elapsed"),)
        writer(_batch("unit1", 1, 312, 100, gap))
        writer.flush()
        for name in ("committed", "rate", "counter"):
            live[f"units/unit1/{name}"].refresh()
        assert live["units/unit1/committed"][0] == 400
        assert live["units/unit1/counter"][399] == 411
    writer(RunStop(utc_now(), "duration"))
    assert writer.stopped
    return path


def test_every_dataset_has_units_and_the_run_its_metadata(written: Path) -> None:
    missing = []
    with h5py.File(written, "r") as f:
        def visit(name: str, obj: object) -> None:
            if isinstance(obj, h5py.Dataset) and "units" not in obj.attrs:
                missing.append(name)
        f.visititems(visit)
        assert missing == ["run_state"] or missing == []
        for key in ("profile", "operator", "lot", "station_host", "software_version",
                    "start_utc", "stop_utc", "stop_reason", "run_uid"):
            assert key in f.attrs, key
        g = f["units/unit1"]
        assert g["rate"].attrs["units"] == "deg/s" and g["temperature"].attrs["units"] == "degC"
        assert g["receive_time"].attrs["units"] == "s" and g.attrs["sample_rate_hz"] == RATE_HZ
        assert g["rate"].maxshape == (None, 3) and g["rate"].chunks[0] >= 256
        assert "device_time" not in g  # the protocol has none: no empty dataset
        assert json.loads(g["events"].attrs["units"])["time_s"] == "s"


def test_reader_returns_the_run_with_its_gap_counts(written: Path) -> None:
    run = read_run(written)
    assert not run.interrupted and run.stop_reason == "duration" and run.metadata.operator == "ann"
    u1, u2 = run.units
    assert (u1.serial_number, u1.record.n_samples, u2.record.n_samples) == ("A1", 400, 200)
    assert u1.n_gaps == 1 and u1.missing_samples == 12
    # the gap's samples are missing on the unit's time grid, not joined over
    np.testing.assert_array_equal(u1.record.sample_index[298:302], [298, 299, 312, 313])
    assert u1.record.missing_samples == 12 and u2.record.sample_index is None
    assert "counter+elapsed" in u1.events[0].detail
    assert u1.record.temperature_c is not None and u1.record.rate_deg_s[-1, 2] == 0.5
    assert read_run_record(written, "B2").n_samples == 200  # by serial number
    assert read_record(written, unit="unit2").axis_names == ("x", "y", "z")


def test_analyze_reads_a_unit_an_axis_and_a_time_slice_of_a_run(
        written: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["analyze", str(written), "--unit", "unit1", "--axis", "y", "--start-s", "0.5",
                 "--stop-s", "3.5", "--warmup-s", "1.0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["axes"][0]["name"] == "y"
    # 1.0 .. 3.5 s of true time at 100 Hz, less the 12 samples of the gap after counter 299
    assert out["axes"][0]["n_samples"] == 238
    assert out["axes"][0]["gaps"] == {"count": 1, "missing_s": pytest.approx(0.12),
                                      "share": pytest.approx(12 / 250)}
    assert out["selection"] == {"unit": "unit1", "axis": "y", "start_s": 1.0, "stop_s": 3.5,
                                "warmup_s": 1.0, "warmup_from": "--warmup-s"}
    assert main(["analyze", str(written), "--unit", "nope"]) == 2
    assert "no unit 'nope'" in capsys.readouterr().err


def test_lookup3_matches_jenkins_reference_values() -> None:
    # Bob Jenkins, lookup3.c, driver5()
    assert lookup3(b"") == 0xDEADBEEF
    assert lookup3(b"", 0xDEADBEEF) == 0xBD5B7DDE
    assert lookup3(b"Four score and seven years ago") == 0x17770551
    assert lookup3(b"Four score and seven years ago", 1) == 0xCD628161


DISK_URL = "sim+serial://STIM300?protocol=xbus&rate=500&seed={seed}"


@pytest.fixture(scope="module")
def full_disk_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple]:
    """Two recorders whose disk fills mid-run (their file-size limit is lowered to what
    they have written plus 60 kB): one with the default reserve (stops before the end of
    the space), one with none (writes until a write fails with EFBIG)."""
    runs = {}
    for name, extra in (("reserve", []), ("no reserve", ["--reserve-mb", "0"])):
        folder = tmp_path_factory.mktemp(name.replace(" ", "-"))
        url = DISK_URL.format(seed=len(runs) + 3)
        proc = start_recorder("--unit", url, "--duration", "1h", "--out", str(folder),
                              "--quiet", "--json-summary", *extra)
        runs[name] = (proc, folder, url)
    out = {}
    try:
        for name, (proc, folder, url) in runs.items():
            path = wait_for_samples(folder, 200)
            with h5py.File(path, "r", swmr=True) as f:
                before = int(f["units/unit1/committed"][0])
            limit = path.stat().st_size + 60_000
            resource.prlimit(proc.pid, resource.RLIMIT_FSIZE, (limit, limit))
            t0 = time.monotonic()
            stdout, stderr = proc.communicate(timeout=60)
            out[name] = (proc.returncode, stdout, stderr, path, url, before,
                         time.monotonic() - t0, limit)
    finally:
        for proc, _, _ in runs.values():
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    return out


@pytest.mark.parametrize("name", ["reserve", "no reserve"])
@pytest.mark.slow
def test_a_full_disk_stops_the_run_with_its_data_intact_and_the_reason_recorded(
        full_disk_runs: dict[str, tuple], name: str) -> None:
    code, stdout, stderr, path, url, before, stop_after_s, limit = full_disk_runs[name]
    assert code == EXIT_RUN_FAULT, stderr  # stopped on its own, reporting the fault
    message = [line for line in stderr.splitlines() if not line.startswith("recording ")]
    assert len(message) == 1 and "disk full" in message[0], stderr  # one line, no traceback
    assert stop_after_s < 30.0
    assert path.stat().st_size <= limit
    run = read_run(path)
    assert run.interrupted
    if name == "reserve":  # stopped before the space ran out: closed, reason in the file
        assert run.stop_reason.startswith("disk full: disk nearly full"), run.stop_reason
        h5py.File(path, "r").close()
    else:  # a write failed: the reason is reported, the file is left for recover
        assert "disk full" in stderr and f"station recover {path}" in stderr
        assert read_run(path).stop_reason == "disk full: file size limit reached"
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["recover", str(path)]) == 0
        with h5py.File(path, "r") as f:
            assert int(f["units/unit1/committed"][0]) == f["units/unit1/rate"].shape[0]
    n = check_unit_against_signal(path, "unit1", url)  # everything committed is intact
    assert n >= before
    print(f"{name}: limit {limit} B, stopped {stop_after_s:.2f} s later with {n} samples "
          f"intact ({before} when the limit was set): {run.stop_reason[:60]}")
    obj = summaries(stdout)[0]
    assert obj["samples_recorded"] == n
    # the books: what was sent is recorded, declared missing, or counted as not written
    unwritten = int(stderr.split("not written: unit1 ")[1].split(")")[0]) if (
        "not written" in stderr) else 0
    assert obj["samples_recorded"] + obj["samples_missing_declared"] + unwritten == \
        obj["samples_sent"], (obj, stderr)


def test_davar_reads_a_run_file(written: Path) -> None:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["davar", str(written), "--window-s", "1.0", "--json"]) == 0
    assert len(json.loads(buf.getvalue())["axes"]) == 3


def test_a_second_reader_in_the_process_reads_the_same_samples(tmp_path: Path) -> None:
    """Two readers of one run file in one process (the TUI's live view beside a spec sheet,
    two tasks of one Dask worker): HDF5 rebuilds a dataset refreshed while another handle
    is open on it only partly, and its reads then fail ("can't insert duplicate key") or,
    in a file of the latest format, return other rows. A closed file and one a killed
    recorder left open for writing (read in SWMR mode) each read the same with the first
    reader holding every dataset open."""
    from station.storage.hdf5 import open_run_file
    from tests.test_damaged_runs import _write_run

    closed, held, killed = tmp_path / "closed.h5", tmp_path / "held.h5", tmp_path / "killed.h5"
    _write_run(closed, close=True)
    writer = _write_run(held, close=False)
    killed.write_bytes(held.read_bytes())
    writer(RunStop(utc_now(), "duration"))
    for path in (closed, killed):
        alone = read_run(path)
        with open_run_file(path) as first:
            holding = [first[f"units/{u}/{name}"] for u in ("unit1", "unit2")
                       for name in first[f"units/{u}"]]
            again = read_run(path)
            assert len(holding) == 16 and all(h.shape[0] > 0 for h in holding)
        assert alone.interrupted == (path == killed)
        for a, b in zip(alone.units, again.units, strict=True):
            assert a.record.n_samples == 6000 and len(a.events) == 6
            np.testing.assert_array_equal(a.record.rate_deg_s, b.record.rate_deg_s)
            np.testing.assert_array_equal(a.record.sample_index, b.record.sample_index)
            np.testing.assert_array_equal(a.record.temperature_c, b.record.temperature_c)
            assert a.events == b.events
