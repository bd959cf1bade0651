"""``simulate``: a simulated gyro run from a noise model or from ARW and bias stability, to a file.

The run is generated and written chunk by chunk (:data:`CHUNK_SAMPLES` samples per axis),
so its length is not bounded by memory. The output is a CSV record (``.csv``,
``.csv.gz``) or a run file in the recorder's HDF5 layout (``.h5``: one unit ``sim``).
"""

from __future__ import annotations

import gzip
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from analysis.models.fog import fog_from_indicators
from analysis.models.simulation import GyroSimulator, SimulatedChunk, n_samples_of
from analysis.models.terms import NoiseModel
from devices.model_files import load_noise_model
from devices.protocols import DeviceDescription
from station.errors import UsageError
from station.model.documents import (
    Descriptor,
    EventBatch,
    RunStart,
    RunStop,
    UnitTotals,
    data_keys,
    utc_now,
)
from station.model.runs import RunMetadata
from station.services.progress import Progress, ProgressSink, ignore_progress
from station.storage.csv_records import write_csv_record
from station.storage.hdf5 import REASON_DURATION
from station.storage.hdf5_writer import RunFileWriter

#: Samples per axis generated and written at a time.
CHUNK_SAMPLES = 1 << 17


@dataclass(frozen=True)
class SimulateRequest:
    """What to simulate (a model, or the two indicators) and where to write it.

    Attributes
    ----------
    out : Path
        ``.csv``, ``.csv.gz`` or ``.h5`` (never overwritten).
    model : str or None
        Noise model TOML file or preset name.
    arw_deg_rt_h, bias_stability_deg_h : float or None
        Instead of a model: ARW (deg/sqrt(h)) and bias stability (deg/h, 1 sigma of
        ``average_s`` averages) of a white-noise-plus-Markov FOG (docs/fog-model.md).
    average_s, correlation_s : float, float or None
        The bias stability's averaging time and the Markov process' correlation time (s;
        default the averaging time).
    duration_s, rate_hz : float
        Run length (s) and sample rate (Hz).
    axes : int
        Number of axes.
    seed : int or None
        Seed of the run (None: fresh entropy).
    """

    out: Path
    model: str | None = None
    arw_deg_rt_h: float | None = None
    bias_stability_deg_h: float | None = None
    average_s: float = 100.0
    correlation_s: float | None = None
    duration_s: float = 3600.0
    rate_hz: float = 10.0
    axes: int = 1
    seed: int | None = None


@dataclass(frozen=True)
class SimulateResult:
    """The file written, how many samples per axis, and the model they were drawn from."""

    out: Path
    n_samples: int
    axes: int
    rate_hz: float
    model: NoiseModel


def noise_model_of(request: SimulateRequest) -> NoiseModel:
    """The model a request asks for.

    Raises
    ------
    UsageError
        If both or neither of the model and the two indicators are given.
    """
    indicators = request.arw_deg_rt_h is not None or request.bias_stability_deg_h is not None
    if request.model and indicators:
        raise UsageError("give either --model or --arw with --bias-stability, not both")
    if request.model:
        return load_noise_model(request.model)
    if request.arw_deg_rt_h is None or request.bias_stability_deg_h is None:
        raise UsageError("give --model MODEL, or both --arw and --bias-stability")
    params = fog_from_indicators(request.arw_deg_rt_h, request.bias_stability_deg_h,
                                 average_s=request.average_s, correlation_s=request.correlation_s)
    return params.noise_model()


def _output_kind(path: Path) -> Literal["csv", "h5"]:
    """``"csv"`` or ``"h5"`` from the file name, or :class:`UsageError`."""
    suffixes = "".join(path.suffixes[-2:]).lower()
    if path.suffix.lower() in (".h5", ".hdf5"):
        return "h5"
    if suffixes.endswith(".csv") or suffixes.endswith(".csv.gz"):
        return "csv"
    raise UsageError(f"{path}: output must be .csv, .csv.gz or .h5")


def _append_rows(path: Path, t_s: np.ndarray, rate: np.ndarray,
                 temperature: np.ndarray | None) -> None:
    """Append data rows in the layout of :func:`write_csv_record` (time, axes, temperature)."""
    columns = [t_s, *rate.T] + ([] if temperature is None else [temperature])
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "at", encoding="utf-8") as fh:
        np.savetxt(fh, np.column_stack(columns), delimiter=",", fmt="%.17g")


def _reported(chunks: Iterator[SimulatedChunk], n_total: int,
              progress: ProgressSink) -> Iterator[SimulatedChunk]:
    """Pass chunks through, telling ``progress`` after each one."""
    for chunk in chunks:
        yield chunk
        done = chunk.start_index + chunk.n_samples
        progress(Progress("simulate", f"{done} of {n_total} samples", done, n_total))


def write_csv_run(path: Path, chunks: Iterator[SimulatedChunk], sample_rate_hz: float,
                  comment: str) -> None:
    """Write chunks as one CSV record: the first with :func:`write_csv_record`, then appended."""
    for chunk in chunks:
        if chunk.start_index == 0:
            write_csv_record(path, chunk.rate_deg_s, sample_rate_hz, comment=comment,
                             temperature_c=chunk.temperature_c)
        else:
            _append_rows(path, chunk.t_s, chunk.rate_deg_s, chunk.temperature_c)


def write_h5_run(path: Path, chunks: Iterator[SimulatedChunk], sim: GyroSimulator, n_total: int,
                 settings: tuple[tuple[str, str], ...]) -> None:
    """Write chunks as a run file of one unit through the recorder's :class:`RunFileWriter`.

    The unit ``sim`` has a device counter (the sample index), device time (the sample's
    start in s) and, when the model has one, the temperature channel; ``settings`` (the
    model, seed, ...) go into the unit's metadata.
    """
    if path.exists():
        raise UsageError(f"{path} exists; a run file is never overwritten")
    unit = "sim"
    axes = (tuple(f"gyro_{c}" for c in "xyz")[: sim.n_axes] if sim.n_axes <= 3
            else tuple(f"axis_{i}" for i in range(sim.n_axes)))
    description = DeviceDescription(
        model=sim.model.name or "simulated", serial_number=f"seed-{sim.seed}",
        protocol="simulation", transport="none", axes=axes, sample_rate_hz=sim.sample_rate_hz,
        has_counter=True, counter_modulus=None, has_device_time=True,
        has_temperature=sim.has_temperature, settings=settings)
    start = utc_now()
    writer = RunFileWriter(path)
    writer(RunStart(uid=uuid.uuid4().hex, start_utc=start, unit_ids=(unit,),
                    duration_s=n_total / sim.sample_rate_hz, file=str(path),
                    metadata=RunMetadata(software_version="station simulate")))
    writer(Descriptor(unit, f"simulation:{description.model}", description,
                      data_keys(description), start, "simulated time (sample index / sample rate)"))
    for seq, chunk in enumerate(chunks):
        counter = chunk.start_index + np.arange(chunk.n_samples, dtype=np.int64)
        writer(EventBatch(unit, seq, chunk.rate_deg_s, counter, chunk.t_s,
                          np.zeros(chunk.n_samples, np.uint32), chunk.t_s, chunk.temperature_c))
        writer.flush()
    writer(RunStop(utc_now(), REASON_DURATION,
                   (UnitTotals(unit, f"simulation:{description.model}", n_total, 0, 0, 0, 0,
                               n_total),)))


def simulate_run(request: SimulateRequest,
                 progress: ProgressSink = ignore_progress) -> SimulateResult:
    """Simulate the run chunk by chunk and write it; ``progress`` hears of every chunk.

    Raises
    ------
    UsageError
        A bad output name, axis count or model choice; an existing run file.
    """
    kind = _output_kind(request.out)
    if request.axes < 1:
        raise UsageError(f"--axes must be >= 1, got {request.axes}")
    model = noise_model_of(request)
    n_total = n_samples_of(request.duration_s, request.rate_hz)
    sim = GyroSimulator(model, request.rate_hz, n_axes=request.axes, seed=request.seed)
    chunks = _reported(sim.chunks(n_total, chunk_samples=CHUNK_SAMPLES), n_total, progress)
    if kind == "h5":
        settings = (("seed", str(request.seed)), ("sample_rate_hz", f"{request.rate_hz:g}"),
                    ("model_toml", model.to_toml()))
        write_h5_run(request.out, chunks, sim, n_total, settings)
    else:
        comment = (f"simulated by station simulate: model {model.name or '(unnamed)'}, seed "
                   f"{request.seed}, {request.rate_hz:g} Hz, {n_total} samples\n"
                   + model.to_toml().rstrip("\n"))
        write_csv_run(request.out, chunks, request.rate_hz, comment)
    return SimulateResult(request.out, n_total, request.axes, request.rate_hz, model)
