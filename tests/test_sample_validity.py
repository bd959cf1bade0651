"""Sample validity, one convention: ``status`` 0 = the device says good, the device's word as
sent kept beside it (``device_status``); the analysis, the sequence views and the live views
read validity from ``status`` alone; older files without ``device_status`` still read; and a
raw byte dump recorded end to end by ``station record --unit 'replay://...'``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from analysis.allan import blocks
from devices.codecs.base import Reading
from devices.protocols import NO_DEVICE_STATUS, DeviceDescription
from devices.serial_codecs import stream_codec
from station.model.documents import Descriptor, EventBatch, RunStart, data_keys, utc_now
from station.services.run_watch import live_allan, status_json
from station.storage.hdf5 import open_run_file, read_run, read_unit, unit_counts
from station.storage.hdf5_recover import recover_run
from station.storage.hdf5_writer import RunFileWriter
from station.storage.runs import open_run
from station.storage.sequence_files import read_segment_unit
from station.tui.live import RunPoller
from tests.damage_helpers import flip_in_chunks

RATE_HZ = 100.0
N = 400
#: Rows the device flags not valid: the first 20 (gyros starting) and 100 in the middle.
FLAGGED = np.r_[0:20, 200:300]


def _write(path: Path, *, device_status: bool = True) -> None:
    d = DeviceDescription(model="DSP-1750", serial_number="K1", protocol="kvh1750",
                          transport="serial", axes=("x", "y", "z"), sample_rate_hz=RATE_HZ,
                          has_counter=True, counter_modulus=128, has_device_time=False,
                          has_temperature=True)
    writer = RunFileWriter(path, flush_interval_s=0.5)
    writer(RunStart("uid", utc_now(), ("unit1",), 10.0, str(path)))
    writer(Descriptor("unit1", "replay://k.bin?protocol=kvh1750", d, data_keys(d), utc_now(),
                      "replayed", 1.0))
    counter = np.arange(N, dtype=np.int64)
    status = np.zeros(N, np.uint32)
    status[FLAGGED] = 7  # gyro X, Y, Z not valid
    rate = np.column_stack([np.full(N, 1.0), np.full(N, 2.0), np.full(N, 3.0)])
    rate[FLAGGED] = 500.0  # what a starting unit sends while it says "not valid"
    words = np.where(status == 0, 0x77, 0x70).astype(np.int64)  # KVH: a bit per valid gyro
    half = N // 2
    for seq, rows in enumerate((slice(0, half), slice(half, N))):
        writer(EventBatch("unit1", seq, rate[rows], counter[rows], counter[rows] / RATE_HZ,
                          status[rows], None, np.full(N, 25.0)[rows],
                          device_status=words[rows] if device_status or seq == 0 else None))
    writer.close("duration")


@pytest.fixture
def run_file(tmp_path: Path) -> Path:
    path = tmp_path / "run.h5"
    _write(path)
    return path


def test_the_device_word_is_kept_beside_status(run_file: Path) -> None:
    with open_run_file(run_file) as f:
        unit = read_unit(f, "unit1")
        ds = f["units/unit1/device_status"]
        assert ds.dtype == np.int64 and "as sent" in ds.attrs["description"]
        assert "0 = the device says the sample is good" in f["units/unit1/status"].attrs[
            "description"]
        counts = unit_counts(f, "unit1")
    assert unit.device_status is not None
    assert unit.device_status[FLAGGED].tolist() == [0x70] * len(FLAGGED)
    assert unit.device_status[20:200].tolist() == [0x77] * 180
    assert unit.valid.sum() == N - len(FLAGGED)
    assert counts.samples_recorded == N  # a flagged sample is recorded all the same


def test_a_batch_without_words_writes_minus_one(tmp_path: Path) -> None:
    path = tmp_path / "half.h5"
    _write(path, device_status=False)  # the second batch came with no status word
    with open_run_file(path) as f:
        unit = read_unit(f, "unit1")
    assert unit.device_status is not None
    assert (unit.device_status[N // 2:] == NO_DEVICE_STATUS).all()
    assert (unit.device_status[:20] == 0x70).all()


def test_the_analysis_leaves_flagged_samples_out(run_file: Path) -> None:
    (unit,) = read_run(run_file).units
    record = unit.record
    # the record starts at the first valid sample; the 100 flagged later are missing on its
    # grid as a gap's samples are, and no flagged value is in it
    assert record.n_samples == N - len(FLAGGED)
    assert record.span_samples == N - 20 and record.missing_samples == 100
    assert record.sample_index is not None
    assert record.sample_index[179] == 179 and record.sample_index[180] == 280
    assert np.all(record.rate_deg_s == [1.0, 2.0, 3.0])
    assert record.temperature_c is not None and len(record.temperature_c) == record.n_samples


def test_the_long_record_reader_leaves_them_out_too(run_file: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(blocks, "LONG_SAMPLES", 100)  # read block-wise into scratch memmaps
    short = read_run(run_file).units[0].record
    (unit,) = open_run(run_file).units
    assert unit.record.n_samples == short.n_samples == N - len(FLAGGED)
    assert unit.record.sample_index is not None and short.sample_index is not None
    np.testing.assert_array_equal(unit.record.sample_index, short.sample_index)
    np.testing.assert_array_equal(unit.record.rate_deg_s, short.rate_deg_s)


def test_the_sequence_view_keeps_the_grid_of_every_recorded_sample(run_file: Path) -> None:
    unit = read_segment_unit(run_file, "unit1")
    assert len(unit.receive_time_s) == len(unit.status) == N
    assert unit.record.sample_index is not None and unit.record.sample_index[0] == 20
    assert unit.record.span_samples == N
    gridded = unit.record.gridded(0)
    assert np.isnan(gridded[FLAGGED]).all() and np.all(np.delete(gridded, FLAGGED) == 1.0)


def test_the_live_views_show_valid_samples_only(run_file: Path) -> None:
    doc = status_json(run_file)
    (u,) = doc["units"]  # type: ignore[misc]
    assert u["samples_recorded"] == N
    assert u["newest_deg_s"] == [1.0, 2.0, 3.0] and u["mean_1s_deg_s"] == [1.0, 2.0, 3.0]
    allan = live_allan(run_file, "unit1")
    assert allan["adev_deg_h"][0] and all(v == 0.0 for v in allan["adev_deg_h"][0])
    snap = RunPoller(run_file).poll()
    (means,) = [s for s in snap.rate if s.label == "unit1"]
    assert len(means.y) and np.allclose(means.y, 3600.0)  # 1 deg/s, in deg/h


def test_a_file_without_device_status_still_reads(run_file: Path) -> None:
    with h5py.File(run_file, "r+") as f:  # as written before the word was kept
        del f["units/unit1/device_status"]
    with open_run_file(run_file) as f:
        unit = read_unit(f, "unit1")
    assert unit.device_status is None and len(unit.counter) == N
    assert read_run(run_file).units[0].record.n_samples == N - len(FLAGGED)


def test_an_older_xbus_file_reads_its_word_as_the_device_status(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch
                                                               ) -> None:
    """Before device_status, an Xbus unit's status held its StatusWord (bits that mean
    good): such a file's samples read as valid, as the station then read them."""
    path = tmp_path / "old.h5"
    _write(path)
    with h5py.File(path, "r+") as f:
        g = f["units/unit1"]
        del g["device_status"]
        g.attrs["protocol"] = "xbus"
        g["status"][:] = 0x5  # a StatusWord: self test and filter valid
    with open_run_file(path) as f:
        unit = read_unit(f, "unit1")
    assert unit.valid.all() and unit.device_status is not None
    assert (unit.device_status == 0x5).all()
    assert read_run(path).units[0].record.n_samples == N
    monkeypatch.setattr(blocks, "LONG_SAMPLES", 100)
    assert open_run(path).units[0].record.n_samples == N
    assert len(RunPoller(path).poll().rate[0].y) > 0
    damaged = flip_in_chunks(path, tmp_path / "flipped.h5", [("units/unit1/rate", 1)])
    salvaged = recover_run(damaged, out=tmp_path / "salvage.h5").salvaged_to
    assert salvaged
    with open_run_file(salvaged) as f:
        again = read_unit(f, "unit1")
    assert again.valid.all() and again.device_status is not None
    assert (again.device_status == 0x5).all()


@pytest.mark.parametrize("older", [False, True])
def test_a_salvage_keeps_the_word_or_minus_one(run_file: Path, tmp_path: Path,
                                               older: bool) -> None:
    if older:  # a file recorded before the word was kept
        with h5py.File(run_file, "r+") as f:
            del f["units/unit1/device_status"]
    damaged = flip_in_chunks(run_file, tmp_path / "flipped.h5", [("units/unit1/rate", 1)])
    result = recover_run(damaged, out=tmp_path / "salvage.h5")
    assert result.salvaged_to
    with open_run_file(result.salvaged_to) as f:
        unit = read_unit(f, "unit1")
    assert len(unit.counter) == 256  # the rate chunk of rows 256.. does not read
    assert unit.device_status is not None
    if older:
        assert (unit.device_status == NO_DEVICE_STATUS).all()
    else:
        assert unit.device_status[:20].tolist() == [0x70] * 20
        assert unit.device_status[20:200].tolist() == [0x77] * 180
    assert unit.status[200:256].tolist() == [7] * 56 and not unit.status[20:200].any()


def _xbus_dump(path: Path, n: int) -> None:
    codec, _, _ = stream_codec("xbus", {}, RATE_HZ)
    out = b""
    for i in range(n):
        reading = Reading((0.1, -0.2, 0.3), (60000 + i) % codec.counter_modulus, 0,
                          500.0 + i / RATE_HZ, 25.0, (0.0, 0.0, 9.81))
        out += codec.encode(codec.from_reading(reading))
    path.write_bytes(out)


def test_station_record_replays_a_byte_dump(tmp_path: Path) -> None:
    """The command as an operator types it: every sample of the dump in the run file (its
    16-bit counter wraps inside it), no gap, the run complete at the dump's end."""
    _xbus_dump(tmp_path / "dump.bin", 700)
    out = tmp_path / "run.h5"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    done = subprocess.run(
        [sys.executable, "-m", "station", "record", "--profile", "ADIS16405", "--unit",
         f"replay://{tmp_path}/dump.bin?protocol=xbus&rate=100", "--duration", "1h",
         "--out", str(out), "--json-summary", "--quiet"],
        capture_output=True, text=True, timeout=300, env=env, check=False)
    assert done.returncode == 0, done.stderr
    (summary,) = [json.loads(line) for line in done.stdout.splitlines() if line.strip()]
    assert summary["samples_recorded"] == 700
    assert summary["gaps"] == summary["samples_missing_declared"] == 0
    info = read_run(out)
    assert not info.interrupted
    with open_run_file(out) as f:
        unit = read_unit(f, "unit1")
    assert np.all(np.diff(unit.counter) == 1) and unit.valid.all()
    refused = subprocess.run(
        [sys.executable, "-m", "station", "record", "--profile", "ADIS16405", "--unit",
         f"replay://{tmp_path}/absent.bin?protocol=xbus&rate=100", "--out",
         str(tmp_path / "no.h5")], capture_output=True, text=True, timeout=300, env=env,
        check=False)
    assert refused.returncode == 2
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "cannot read the byte dump" in lines[0], refused.stderr
