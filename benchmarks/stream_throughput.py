"""Streaming throughput and memory of the simulator, and the 24 h at 1 kHz projection.

Streams ``--minutes`` of a model at ``--rate`` Hz in chunks, reports samples per second,
the peak traced memory (bounded by the chunk, not the run) and the time a 24 h run
would take; ``--minutes 1440 --rate 1000`` runs the whole day.
Run: ``python benchmarks/stream_throughput.py [--model zhang2015-fog] [--minutes 10]``.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from analysis.models.simulation import GyroSimulator
from devices.model_files import load_noise_model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--model", default="zhang2015-fog")
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--axes", type=int, default=1)
    parser.add_argument("--chunk", type=int, default=1 << 16)
    args = parser.parse_args()
    model = load_noise_model(args.model)
    sim = GyroSimulator(model, args.rate, n_axes=args.axes, seed=1)
    n_total = int(args.minutes * 60 * args.rate)
    tracemalloc.start()
    t0 = time.perf_counter()
    checksum = 0.0
    for chunk in sim.chunks(n_total, chunk_samples=args.chunk):
        checksum += float(np.sum(chunk.rate_deg_s))
    elapsed = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    per_s = n_total * args.axes / elapsed
    day = 86400 * args.rate * args.axes / per_s
    print(
        f"model {model.name}: {n_total} samples x {args.axes} axes at {args.rate:g} Hz in "
        f"{elapsed:.1f} s "
        f"({per_s / 1e6:.2f} M sample-axes/s); peak traced memory {peak / 1e6:.1f} MB with chunks "
        "of "
        f"{args.chunk}; a 24 h run at this rate would take {day / 60:.1f} min (checksum "
        f"{checksum:.3g})"
    )


if __name__ == "__main__":
    main()
