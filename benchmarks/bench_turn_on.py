"""Monte Carlo of the turn-on figures: warm-up time and repeatability against set truths.

Prints, per case, the mean error of the warm-up time as a share of its truth and of its
scatter, the coverage of the turn-on repeatability's chi-square interval, and the same
for the plain "last average outside the band" rule the refined crossing replaces (it is
late by the noise's largest excursion).

    python -m benchmarks.bench_turn_on --runs 200
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from analysis.models.power_cycle import PowerCycleModel
from analysis.sequences.turn_on import (
    cycle_bias,
    sliding_means,
    turn_on_repeatability,
    warmup_curve,
)
from analysis.units.conversions import S_PER_H

#: (amplitude deg/h, tau s, average s, rate Hz, record s, noise of an average / band)
CASES = ((20.0, 60.0, 10.0, 10.0, 600.0, 0.1), (20.0, 60.0, 10.0, 10.0, 600.0, 0.2),
         (20.0, 30.0, 40.0, 5.0, 240.0, 0.1), (-30.0, 40.0, 30.0, 5.0, 400.0, 0.1),
         (20.0, 20.0, 20.0, 5.0, 240.0, 0.15))
BAND = 1.0


def _record(m: PowerCycleModel, fs: float, n: int, noise_avg: float, average_s: float,
            rng: np.random.Generator) -> np.ndarray:
    t0 = 2.0 + np.arange(n) / fs
    per_sample = noise_avg * math.sqrt(average_s * fs)
    return (m.transient_deg_h(t0, 1 / fs) + 3.0 + per_sample * rng.standard_normal(n)) / S_PER_H


def _last_outside(x: np.ndarray, fs: float, average_s: float) -> float:
    """The plain rule: the centre of the first average after the last one outside."""
    window = int(average_s * fs)
    starts, means = sliding_means(x, window, max(1, window // 4))
    t = 2.0 + (starts + window / 2) / fs
    ref = np.nanmean(x[len(x) // 2:]) * S_PER_H
    out = np.flatnonzero(np.abs(means * S_PER_H - ref) > BAND)
    return float(t[min(out[-1] + 1, len(t) - 1)]) if out.size else 2.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f"warm-up time into +-{BAND:g} deg/h, {args.runs} records per case")
    print(f"{'A deg/h':>8} {'tau s':>6} {'avg s':>6} {'noise/band':>10} {'truth s':>8} "
          f"{'err/truth':>10} {'err/sd':>7} {'plain err/truth':>16}")
    for a, tau, avg, fs, rec, noise in CASES:
        m = PowerCycleModel(warmup_deg_h=a, warmup_tau_s=tau)
        n = int(rec * fs)
        truth = m.warmup_time_s(BAND, record_s=2.0 + n / fs,
                                die_temperature_c=lambda t: np.full_like(t, 25.0))
        refined, plain = [], []
        for _ in range(args.runs):
            x = _record(m, fs, n, noise * BAND, avg, rng)
            w = warmup_curve(x, fs, first_s=2.0, band_deg_h=BAND, average_s=avg)
            refined.append(np.nan if w.warmup_time_s is None else w.warmup_time_s)
            plain.append(_last_outside(x, fs, avg))
        r, p = np.array(refined), np.array(plain)
        err = np.nanmean(r) - truth
        print(f"{a:>8g} {tau:>6g} {avg:>6g} {noise:>10g} {truth:>8.1f} {err / truth:>+10.3f} "
              f"{err / np.nanstd(r):>+7.2f} {(np.mean(p) - truth) / truth:>+16.3f}")
    print("\nturn-on repeatability: 6 switch-ons, biases drawn with sigma 1 deg/h, each "
          "cycle's own noise 0.05 deg/h")
    for level in (0.68, 0.95):
        hits = 0
        for _ in range(args.runs):
            biases = []
            for b in rng.standard_normal(6):
                x = (b + 0.05 * math.sqrt(600) * rng.standard_normal(600)) / S_PER_H
                biases.append(cycle_bias(x, 1.0, first_s=0.0, after_s=0.0))
            rep = turn_on_repeatability(biases, level)
            truth = math.hypot(1.0, 0.05)
            hits += rep.ci_low_deg_h <= truth <= rep.ci_high_deg_h  # type: ignore[operator]
        print(f"  {level:.0%} interval covers the truth in {hits / args.runs:.1%} of "
              f"{args.runs} sequences")


if __name__ == "__main__":
    main()
