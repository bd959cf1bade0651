"""``station simulate``: write a simulated gyro run from a noise model or from two indicators.

``station simulate --model MODEL.toml --duration 4h --rate 10 --seed 1 --out run.csv``
simulates a model file or preset; ``station simulate --arw A --bias-stability B
[--average-s 100] [--correlation-s T] ...`` simulates the white-noise-plus-Markov FOG
derived from a data sheet's ARW (deg/sqrt(h)) and bias stability (deg/h), see
``docs/fog-model.md``. The output is CSV (``.csv``, ``.csv.gz``: the analysis core's
format) or a run file in the recorder's HDF5 layout (``.h5``: one unit ``sim``, sample
counter, time, and temperature when the model has one). The run is generated and
written chunk by chunk, so its length is not bounded by memory; a progress line goes to
stderr for long runs.
"""

from __future__ import annotations

import argparse
import gzip
import re
import sys
import uuid
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from analysis.fog import fog_from_indicators
from analysis.models import NoiseModel
from analysis.simulate import GyroSimulator, SimulatedChunk, n_samples_of
from devices.model_files import load_noise_model
from devices.protocols import DeviceDescription
from station.errors import UsageError
from station.hdf5 import REASON_DURATION, RunFileWriter
from station.model.documents import (
    Descriptor,
    EventBatch,
    RunStart,
    RunStop,
    UnitTotals,
    data_keys,
    utc_now,
)
from station.storage.csv_records import write_csv_record

#: Seconds per unit of a duration suffix.
DURATION_UNITS = {"": 1.0, "s": 1.0, "min": 60.0, "m": 60.0, "h": 3600.0, "d": 86400.0}
#: Samples per axis generated and written at a time.
CHUNK_SAMPLES = 1 << 17


def parse_duration(text: str) -> float:
    """A duration in s from ``"90"``, ``"90s"``, ``"30min"``, ``"4h"`` or ``"1d"``.

    Raises
    ------
    argparse.ArgumentTypeError
        If the text is not a positive number with one of those units.
    """
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-z]*)\s*", text)
    if not match or match.group(2) not in DURATION_UNITS or float(match.group(1)) <= 0:
        raise argparse.ArgumentTypeError(
            f"duration {text!r} is not a positive number with a unit s, min, h or d (e.g. 4h)"
        )
    return float(match.group(1)) * DURATION_UNITS[match.group(2)]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` sub-command."""
    p = sub.add_parser("simulate", help="write a simulated gyro run (model file or ARW + bias stability)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    source = p.add_argument_group("what to simulate (a model, or the two indicators)")
    source.add_argument("--model", metavar="MODEL",
                        help="noise model TOML file or preset name (e.g. VG951, zhang2015-fog)")
    source.add_argument("--arw", type=float, metavar="DEG_RT_H",
                        help="angle random walk in deg/sqrt(h)")
    source.add_argument("--bias-stability", type=float, metavar="DEG_H",
                        help="bias stability in deg/h (1 sigma of --average-s averages)")
    source.add_argument("--average-s", type=float, default=100.0, metavar="S",
                        help="averaging time of the bias stability in s (default 100)")
    source.add_argument("--correlation-s", type=float, metavar="S",
                        help="correlation time of the Markov process in s (default: --average-s)")
    p.add_argument("--duration", type=parse_duration, default=3600.0, metavar="DURATION",
                   help="run length, e.g. 4h, 30min, 600s (default 1h)")
    p.add_argument("--rate", type=float, default=10.0, metavar="HZ", help="sample rate in Hz (default 10)")
    p.add_argument("--axes", type=int, default=1, metavar="N", help="number of axes (default 1)")
    p.add_argument("--seed", type=int, default=None, help="seed of the run (default: fresh entropy)")
    p.add_argument("--out", type=Path, required=True, metavar="FILE",
                   help="output: .csv, .csv.gz, or .h5 (a run file in the recorder's layout)")
    p.set_defaults(handler=run)


def model_from_args(args: argparse.Namespace) -> NoiseModel:
    """The model a ``simulate`` command line asks for.

    Raises
    ------
    UsageError
        If both or neither of ``--model`` and ``--arw``/``--bias-stability`` are given.
    """
    indicators = args.arw is not None or args.bias_stability is not None
    if args.model and indicators:
        raise UsageError("give either --model or --arw with --bias-stability, not both")
    if args.model:
        return load_noise_model(args.model)
    if args.arw is None or args.bias_stability is None:
        raise UsageError("give --model MODEL, or both --arw and --bias-stability")
    params = fog_from_indicators(args.arw, args.bias_stability, average_s=args.average_s,
                                 correlation_s=args.correlation_s)
    return params.noise_model()


def _output_kind(path: Path) -> str:
    """``"csv"`` or ``"h5"`` from the file name, or :class:`UsageError`."""
    suffixes = "".join(path.suffixes[-2:]).lower()
    if path.suffix.lower() in (".h5", ".hdf5"):
        return "h5"
    if suffixes.endswith(".csv") or suffixes.endswith(".csv.gz"):
        return "csv"
    raise UsageError(f"{path}: output must be .csv, .csv.gz or .h5")


def _append_rows(path: Path, t_s: np.ndarray, rate: np.ndarray, temperature: np.ndarray | None) -> None:
    """Append data rows in the layout of :func:`write_csv_record` (time, axes, temperature)."""
    columns = [t_s, *rate.T] + ([] if temperature is None else [temperature])
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "at", encoding="utf-8") as fh:
        np.savetxt(fh, np.column_stack(columns), delimiter=",", fmt="%.17g")


def _progress(chunks: Iterator[SimulatedChunk], n_total: int) -> Iterator[SimulatedChunk]:
    """Pass chunks through, printing a progress line on stderr when there is more than one."""
    show = n_total > CHUNK_SAMPLES
    for chunk in chunks:
        yield chunk
        if show:
            done = chunk.start_index + chunk.n_samples
            print(f"\rsimulate: {100.0 * done / n_total:5.1f} % ({done} of {n_total} samples)",
                  end="", file=sys.stderr, flush=True)
    if show:
        print(file=sys.stderr)


def write_csv_run(path: Path, chunks: Iterator[SimulatedChunk], sample_rate_hz: float, comment: str) -> None:
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
    description = DeviceDescription(
        model=sim.model.name or "simulated", serial_number=f"seed-{sim.seed}", protocol="simulation",
        transport="none", axes=tuple(f"gyro_{c}" for c in "xyz")[: sim.n_axes]
        if sim.n_axes <= 3 else tuple(f"axis_{i}" for i in range(sim.n_axes)),
        sample_rate_hz=sim.sample_rate_hz, has_counter=True, counter_modulus=None,
        has_device_time=True, has_temperature=sim.has_temperature, settings=settings)
    start = utc_now()
    writer = RunFileWriter(path)
    writer(RunStart(uid=uuid.uuid4().hex, start_utc=start, unit_ids=(unit,),
                    duration_s=n_total / sim.sample_rate_hz, file=str(path),
                    software_version="station simulate"))
    writer(Descriptor(unit, f"simulation:{description.model}", description, data_keys(description),
                      start, "simulated time (sample index / sample rate)"))
    for seq, chunk in enumerate(chunks):
        counter = chunk.start_index + np.arange(chunk.n_samples, dtype=np.int64)
        writer(EventBatch(unit, seq, chunk.rate_deg_s, counter, chunk.t_s,
                          np.zeros(chunk.n_samples, np.uint32), chunk.t_s, chunk.temperature_c))
        writer.flush()
    writer(RunStop(utc_now(), REASON_DURATION,
                   (UnitTotals(unit, f"simulation:{description.model}", n_total, 0, 0, 0, 0, n_total),)))


def run(args: argparse.Namespace) -> int:
    """Simulate the run chunk by chunk and write it."""
    kind = _output_kind(args.out)
    if args.axes < 1:
        raise UsageError(f"--axes must be >= 1, got {args.axes}")
    model = model_from_args(args)
    n_total = n_samples_of(args.duration, args.rate)
    sim = GyroSimulator(model, args.rate, n_axes=args.axes, seed=args.seed)
    chunks = _progress(sim.chunks(n_total, chunk_samples=CHUNK_SAMPLES), n_total)
    if kind == "h5":
        settings = (("seed", str(args.seed)), ("sample_rate_hz", f"{args.rate:g}"),
                    ("model_toml", model.to_toml()))
        write_h5_run(args.out, chunks, sim, n_total, settings)
    else:
        comment = (f"simulated by station simulate: model {model.name or '(unnamed)'}, seed {args.seed}, "
                   f"{args.rate:g} Hz, {n_total} samples\n" + model.to_toml().rstrip("\n"))
        write_csv_run(args.out, chunks, args.rate, comment)
    print(f"wrote {n_total} samples x {args.axes} axes at {args.rate:g} Hz to {args.out}", file=sys.stderr)
    return 0
