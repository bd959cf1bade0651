"""An IMU's accelerations in the run file: the accel dataset beside the rate, read back
into RateRecord, kept by a salvage, shown by ``station watch --json``; a gyro-only run
has no accel dataset and reads as before."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from devices.protocols import DeviceDescription
from station.commands.watch import status_json
from station.model.documents import Descriptor, EventBatch, RunStart, RunStop, data_keys, utc_now
from station.model.runs import RunMetadata
from station.storage.hdf5 import read_run
from station.storage.hdf5_salvage import salvage_run
from station.storage.hdf5_writer import RunFileWriter
from tests.test_recorder_helpers import start_recorder

RATE_HZ = 100.0
G = 9.80665


def _description(serial: str, accel_axes: tuple[str, ...]) -> DeviceDescription:
    return DeviceDescription(model="STIM300", serial_number=serial, protocol="stim300",
                             transport="serial", axes=("x", "y", "z"), sample_rate_hz=RATE_HZ,
                             has_counter=True, counter_modulus=256, has_device_time=False,
                             has_temperature=True, accel_axes=accel_axes)


def _batch(unit: str, seq: int, start: int, n: int, imu: bool) -> EventBatch:
    counter = np.arange(start, start + n, dtype=np.int64)
    rate = np.column_stack([counter * 1e-3, -counter * 1e-3, np.full(n, 0.5)])
    accel = np.column_stack([counter * 1e-4, np.zeros(n), np.full(n, G)]) if imu else None
    return EventBatch(unit, seq, rate, counter, counter / RATE_HZ, np.zeros(n, np.uint32),
                      temperature_c=np.full(n, 25.0), accel_m_s2=accel)


def _write(path: Path) -> Path:
    writer = RunFileWriter(path, flush_interval_s=0.5)
    writer(RunStart("uid1", utc_now(), ("imu", "gyro"), 10.0, str(path), RunMetadata()))
    for uid, axes in (("imu", ("accel_x", "accel_y", "accel_z")), ("gyro", ())):
        d = _description(uid, axes)
        writer(Descriptor(uid, f"sim+serial://{uid}", d, data_keys(d), utc_now(),
                          "simulated device clock, warp x1", 1.0))
    writer(_batch("imu", 0, 0, 300, True))
    writer(_batch("gyro", 0, 0, 300, False))
    writer.flush()
    writer(EventBatch.join([_batch("imu", 1, 300, 50, True), _batch("imu", 2, 350, 50, True)]))
    writer(RunStop(utc_now(), "duration"))
    return path


def test_the_accel_dataset_sits_beside_the_rate_and_reads_back(tmp_path: Path) -> None:
    path = _write(tmp_path / "run.h5")
    with h5py.File(path, "r") as f:
        imu, gyro = f["units/imu"], f["units/gyro"]
        ds = imu["accel"]
        assert ds.shape == (400, 3) and ds.dtype == np.float64 and ds.maxshape == (None, 3)
        assert ds.attrs["units"] == "m/s^2"
        assert json.loads(ds.attrs["axes"]) == ["accel_x", "accel_y", "accel_z"]
        assert ds.chunks == imu["rate"].chunks
        assert "accel" not in gyro and "accel_axes" not in gyro.attrs
    run = read_run(path)
    imu_rec, gyro_rec = (u.record for u in run.units)
    assert imu_rec.accel_axis_names == ("accel_x", "accel_y", "accel_z")
    assert imu_rec.accel_m_s2 is not None and imu_rec.accel_m_s2.shape == (400, 3)
    np.testing.assert_array_equal(imu_rec.accel_m_s2[:, 0], np.arange(400) * 1e-4)
    assert gyro_rec.accel_m_s2 is None and gyro_rec.accel_axis_names == ()
    assert gyro_rec.rate_deg_s.shape == (300, 3)
    sliced = imu_rec.slice_time(1.0, 2.0).select("z")
    np.testing.assert_array_equal(sliced.accel_m_s2[:, 0], np.arange(100, 200) * 1e-4)
    units = {u["unit"]: u for u in status_json(path)["units"]}
    assert units["imu"]["newest_accel_m_s2"] == pytest.approx([399e-4, 0.0, G])
    assert units["gyro"]["newest_accel_m_s2"] is None


def test_a_salvage_keeps_the_accel_rows_of_the_rates_it_keeps(tmp_path: Path) -> None:
    path = _write(tmp_path / "run.h5")
    with h5py.File(path, "r+") as f:  # damage one chunk of the accel dataset
        ds = f["units/imu/accel"]
        offset = ds.id.get_chunk_info(0).byte_offset
    with open(path, "r+b") as fh:
        fh.seek(offset + 100)
        byte = fh.read(1)
        fh.seek(offset + 100)
        fh.write(bytes([byte[0] ^ 0xFF]))
    units = {u.unit_id: u for u in salvage_run(path, tmp_path / "out.h5")}
    rec = {u.unit_id: u.record for u in read_run(tmp_path / "out.h5").units}
    chunk = h5py.File(path, "r")["units/imu/accel"].chunks[0]
    assert units["imu"].lost == min(chunk, 400) and units["gyro"].lost == 0
    imu = rec["imu"]
    assert imu.accel_m_s2 is not None and len(imu.accel_m_s2) == len(imu.rate_deg_s) == 400 - chunk
    np.testing.assert_allclose(imu.accel_m_s2[:, 0] * 1e4, imu.rate_deg_s[:, 0] * 1e3, rtol=1e-12)
    assert rec["gyro"].accel_m_s2 is None


@pytest.mark.slow
def test_a_recorded_simulated_stim300_run_holds_its_accelerations(tmp_path: Path) -> None:
    url = ("sim+serial://STIM300?protocol=stim300&counter=datagram&datagram=0xA5&rate=200"
           "&warp=10&seed=5")
    proc = start_recorder("--unit", url, "--duration", "10s", "--out", str(tmp_path), "--quiet")
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    (unit,) = read_run(next(tmp_path.glob("*.h5"))).units
    rec = unit.record
    assert rec.accel_m_s2 is not None and rec.accel_m_s2.shape == rec.rate_deg_s.shape
    assert rec.n_samples > 1000 and rec.accel_axis_names == ("accel_x", "accel_y", "accel_z")
    assert abs(rec.accel_m_s2[:, 2].mean() - G) < 0.01
