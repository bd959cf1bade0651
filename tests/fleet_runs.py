"""Synthetic recorder run files for the fleet tests and benchmark: N units of white plus
flicker rate noise (ARW and bias instability), written through the real run-file writer."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from analysis.models.noise import flicker_rate_noise, white_rate_noise
from analysis.units.conversions import arw_deg_rt_h_to_deg_rt_s, rate_deg_h_to_deg_s
from devices.protocols import DeviceDescription
from station.model.documents import Descriptor, EventBatch, RunStart, RunStop, data_keys
from station.model.profiles import load_profile
from station.model.runs import RunMetadata
from station.storage.hdf5_writer import RunFileWriter

#: Rows written per batch (bounds the writer's memory on long runs).
BATCH = 100_000


def write_run(
    path: Path,
    *,
    units: int = 2,
    duration_s: float = 600.0,
    rate_hz: float = 10.0,
    seed: int = 1,
    profile: Path | None = None,
    lot: str = "LOT-1",
    model: str = "TG-1",
    start_utc: str = "2026-05-04T08:00:00Z",
    arw_deg_rt_h: float = 0.05,
    bi_deg_h: float = 0.5,
    axes: tuple[str, ...] = ("x",),
) -> Path:
    """A closed run file of ``units`` units (serials ``SN-<seed>-<i>``), each a little noisier
    than the one before; ``profile`` is recorded as the run's profile (name, version, hash,
    path)."""
    p = load_profile(profile) if profile is not None else None
    ids = tuple(f"unit{i + 1}" for i in range(units))
    path.parent.mkdir(parents=True, exist_ok=True)
    writer = RunFileWriter(path, flush_interval_s=1.0)
    metadata = RunMetadata(
        profile=p.name if p else "",
        profile_version=p.version if p else "",
        profile_sha256=p.sha256 if p else "",
        profile_path=str(profile or ""),
        operator="ann",
        lot=lot,
        station_host="bench-1",
        software_version="0.1.0",
    )
    writer(RunStart(f"uid-{seed}", start_utc, ids, duration_s, str(path), metadata))
    n = int(duration_s * rate_hz)
    rng = np.random.default_rng(seed)
    for i, uid in enumerate(ids):  # every unit's descriptor first
        d = DeviceDescription(
            model=model,
            serial_number=f"SN-{seed}-{i + 1}",
            protocol="stim300",
            transport="serial",
            axes=axes,
            sample_rate_hz=rate_hz,
            has_counter=True,
            counter_modulus=2**32,
            has_device_time=False,
            has_temperature=False,
            settings=(),
        )
        writer(
            Descriptor(
                uid,
                f"sim+serial://{model}?seed={seed}",
                d,
                data_keys(d),
                start_utc,
                "simulated device clock, warp x1",
                1.0,
            )
        )
    for i, uid in enumerate(ids):
        scale = 1.0 + 0.15 * i
        rate = (
            0.001
            + white_rate_noise(
                arw_deg_rt_h_to_deg_rt_s(arw_deg_rt_h * scale), n, rate_hz, rng, n_axes=len(axes)
            )
            + flicker_rate_noise(
                rate_deg_h_to_deg_s(bi_deg_h * scale), n, rate_hz, rng, n_axes=len(axes)
            )
        ).reshape(n, len(axes))
        for seq, start in enumerate(range(0, n, BATCH)):
            chunk = rate[start : start + BATCH]
            counter = np.arange(start, start + len(chunk), dtype=np.int64)
            writer(
                EventBatch(
                    uid, seq, chunk, counter, counter / rate_hz, np.zeros(len(chunk), np.uint32)
                )
            )
            writer.flush()
    writer(RunStop(start_utc, "duration"))
    return path
