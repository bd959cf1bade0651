"""Imperfect records, measured side by side in one run (run by hand, not in CI).

    python benchmarks/bench_records.py --quick     # about two minutes
    python benchmarks/bench_records.py             # more records per case

Three parts, each printing ratios:

* gaps: time of the gap-aware overlapping Allan deviation (``missing="gap"``: 200 gaps,
  2 % of the samples; confidence intervals included) over the gap-free one on the same
  length and taus, and allantools' ``gradev`` (its gap-resistant ADEV on NaN phase, no
  edf of its own) over ours on the same gapped record;
* false alarms: records per noise type (white, flicker, rate random walk, quantization,
  LSB-quantized white, a mix) in which the spike detector flags anything, against the
  1 % it is designed for (``observed/design``);
* detection: the share of one- and two-sample spikes of a given size (in sigmas of white
  noise) that are found, each spike alone in its record.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import allantools
import numpy as np

from analysis.allan.outliers import FALSE_ALARM, detect_spikes
from analysis.allan.variance import allan_variance
from analysis.models.simulation import simulate
from analysis.models.terms import (
    AngleRandomWalk,
    BiasInstability,
    NoiseModel,
    Quantization,
    RateRandomWalk,
)

FS_HZ = 100.0
MODELS = {
    "white": (AngleRandomWalk(N_deg_rt_h=0.5),),
    "flicker": (BiasInstability(B_deg_h=5.0),),
    "rrw": (RateRandomWalk(K_deg_h_1_5=50.0),),
    "quantization": (Quantization(Q_urad=50.0),),
    "mix": (Quantization(Q_urad=5.0), AngleRandomWalk(N_deg_rt_h=0.5), BiasInstability(B_deg_h=5.0),
            RateRandomWalk(K_deg_h_1_5=5.0)),
}


def _median_time(fn, runs: int) -> float:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def bench_gaps(n: int, runs: int) -> None:
    rng = np.random.default_rng(1)
    x = rng.standard_normal(n)
    y = x.copy()
    starts = np.sort(rng.choice(n - 1000, 200, replace=False))
    for s in starts:
        y[s:s + n // 10_000] = np.nan
    taus = allan_variance(y, FS_HZ, missing="gap").tau_s
    plain = _median_time(lambda: allan_variance(x, FS_HZ, taus=taus), runs)
    gapped = _median_time(lambda: allan_variance(y, FS_HZ, missing="gap"), runs)
    phase = np.concatenate([[0.0], np.cumsum(np.nan_to_num(y)) / FS_HZ])
    phase[1:][np.isnan(y)] = np.nan
    peer = _median_time(
        lambda: allantools.gradev(phase, rate=FS_HZ, data_type="phase", taus=taus), 1
    )
    print(f"gaps N={n:.0e} taus={len(taus)} missing={np.isnan(y).mean():.1%}: plain={plain:.3f}s "
          f"gapped={gapped:.3f}s gapped/plain={gapped / plain:.2f} allantools.gradev={peer:.3f}s "
          f"gradev/gapped={peer / gapped:.1f}")


def _record(kind: str, n: int, seed: int) -> np.ndarray:
    if kind == "lsb":
        rng = np.random.default_rng(seed)
        return 0.05 * np.round(0.4 * rng.standard_normal(n) + 0.3)
    return simulate(NoiseModel(terms=MODELS[kind]), n / FS_HZ, FS_HZ, seed=seed).rate_deg_s[:, 0]


def bench_false_alarms(n: int, records: int) -> None:
    for kind in (*MODELS, "lsb"):
        alarms = sum(
            detect_spikes(_record(kind, n, 1000 + seed)).count > 0 for seed in range(records)
        )
        rate = alarms / records
        print(f"false alarms {kind:>12}: {alarms} of {records} records of {n} samples "
              f"(observed/design={rate / FALSE_ALARM:.2f}, design {FALSE_ALARM:.0%})")


def bench_detection(n: int, records: int) -> None:
    for length in (1, 2):
        cells = []
        for size in (6, 7, 8, 10, 12, 14, 16, 20):
            found = 0
            for seed in range(records):
                rng = np.random.default_rng(seed)
                x = rng.standard_normal(n)
                k = int(rng.integers(100, n - 100))
                x[k:k + length] += rng.choice([-1, 1]) * size
                found += any(
                    sp.index == k and sp.n_samples == length for sp in detect_spikes(x).spikes
                )
            cells.append(f"{size}:{found / records:.2f}")
        print(
            f"detection of {length}-sample spikes, N={n}, size in sigma:found  " + "  ".join(cells)
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    print(f"# bench_records{' --quick' if args.quick else ''}: {os.cpu_count()} cores, "
          f"load average {load:.1f} (other work on the machine skews every time)")
    bench_gaps(1_000_000, 3)
    if not args.quick:
        bench_gaps(10_000_000, 1)
    bench_false_alarms(20_000, 100 if args.quick else 400)
    bench_detection(20_000, 50 if args.quick else 200)


if __name__ == "__main__":
    main()
