"""Monte Carlo verification of the FOG model from two indicators (docs/fog-model.md).

For each typical condition, 100 runs are simulated and their ARW and bias stability are
measured as a data sheet would state them; the table gives the requested value, the
mean and spread of the measured ones, and the exact expectation and spread of a record
of that length (F7-F9). Run: ``python benchmarks/fog_monte_carlo.py [--runs 100]``.
"""

from __future__ import annotations

import argparse
import time

from analysis.models.fog import (
    bias_stability_statistics,
    fog_from_indicators,
    measure_arw,
    measure_bias_stability,
)
from analysis.models.simulation import GyroSimulator

#: (label, ARW deg/sqrt(h), bias stability deg/h, averaging s, T s or None, Hz, record s)
CONDITIONS = [
    ("navigation FOG, 100 s", 0.001, 0.007, 100.0, None, 10.0, 8 * 3600.0),
    ("navigation FOG, 10 s", 0.001, 0.02, 10.0, None, 10.0, 3600.0),
    ("VG951-like, 10 s", 0.0076, 0.3, 10.0, None, 10.0, 3600.0),
    ("VG951-like, 100 s, T 30 s", 0.0076, 0.1, 100.0, 30.0, 10.0, 8 * 3600.0),
    ("low-grade FOG, 10 s, T 3 s", 0.05, 3.0, 10.0, 3.0, 100.0, 1800.0),
    ("low-grade FOG, 100 s, T 1000 s", 0.05, 1.0, 100.0, 1000.0, 10.0, 24 * 3600.0),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=2014)
    args = parser.parse_args()
    header = (
        f"{'condition':32} {'ARW req':>9} {'ARW mean':>9} {'(sd)':>9} {'BS req':>8} {'BS mean':>8} "
        f"{'(sd)':>8} {'BS theory':>9} {'(sd)':>8} {'mean err':>8} {'sd ratio':>8} {'s':>5}"
    )
    print(header)
    for label, arw, bs, avg, corr, fs, duration in CONDITIONS:
        t0 = time.perf_counter()
        params = fog_from_indicators(arw, bs, average_s=avg, correlation_s=corr)
        sim = GyroSimulator(params.noise_model(), fs, n_axes=args.runs, seed=args.seed)
        rate = sim.read(int(duration * fs)).rate_deg_s
        got_bs = measure_bias_stability(rate, fs, average_s=avg)
        got_arw = measure_arw(rate, fs)
        stats = bias_stability_statistics(params, duration, fs)
        print(f"{label:32} {arw:9.4g} {got_arw.mean():9.4g} {got_arw.std(ddof=1):9.2g} {bs:8.4g} "
              f"{got_bs.mean():8.4g} {got_bs.std(ddof=1):8.2g} {stats.mean_deg_h:9.4g} "
              f"{stats.std_deg_h:8.2g} {100 * (got_bs.mean() / bs - 1):7.2f}% "
              f"{got_bs.std(ddof=1) / stats.std_deg_h:8.3f} {time.perf_counter() - t0:5.1f}")


if __name__ == "__main__":
    main()
