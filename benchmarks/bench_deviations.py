"""The Allan family beside the Allan deviation: cost, and whether the intervals are right.

    python benchmarks/bench_deviations.py --quick   # a few minutes
    python benchmarks/bench_deviations.py           # the numbers docs/allan.md quotes

Three parts, each printing ratios measured side by side in this run:

* cost: each deviation of ``analysis.allan.deviations`` on one record of N samples (default
  1e6, white rate plus a little rate random walk), its default log grid, with intervals;
  seconds and the ratio to the overlapping Allan deviation's time;
* coverage: the share of (seed, tau) cells whose +-1 sigma interval holds the true
  value, per deviation, on white rate noise (the truth is known exactly: the Allan
  variance for Allan, Hadamard, total and Theo1; the box-weighted sum for modified/time);
* flicker angle noise: the empirical edf ``2 E[v]^2 / Var[v]`` of the total and the
  overlapping Allan variance over many seeds of flicker phase noise (1/f angle, made in
  the frequency domain), beside our computed edf and NIST SP 1065's "simple" flicker-PM
  formula that Stable32 gives the total variance.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from analysis.allan.confidence import difference_edf_grid
from analysis.allan.deviations import DEVIATION_KINDS, deviation
from analysis.models.noise import white_rate_noise


def cost(n: int) -> None:
    rng = np.random.default_rng(0)
    y = rng.standard_normal(n) + np.cumsum(rng.standard_normal(n)) * 1e-3
    base = None
    print(f"cost: N = {n:.0e} samples, default log grid, intervals included")
    for kind in DEVIATION_KINDS:
        t0 = time.perf_counter()
        r = deviation(y, 100.0, kind=kind)
        dt = time.perf_counter() - t0
        base = base or dt
        print(
            f"  {kind:6s} {len(r.m):4d} taus up to m = {r.m[-1]:>8d}: {dt:7.1f} s  ratio to oadev "
            f"{dt / base:5.1f}"
            + (f"  ({'; '.join(r.notes)})" if r.notes else "")
        )


def _truth(kind: str, m: np.ndarray, tau_s: np.ndarray, s: float, fs: float) -> np.ndarray:
    """Expected variance for white rate noise of std s at fs; Theo1 matches the Allan
    variance at its own tau, 0.75 m / fs (white rate noise is where it has no bias)."""
    tau = m / fs
    if kind not in ("mdev", "tdev"):
        return s**2 / fs / tau_s
    out = []
    for mi in m:
        tri = np.minimum(np.arange(2 * mi - 1) + 1, 2 * mi - 1 - np.arange(2 * mi - 1)).astype(
            float
        )
        g = np.zeros(3 * mi - 1)
        g[mi:] += tri
        g[: 2 * mi - 1] -= tri
        out.append((s / fs) ** 2 * np.sum(g * g) / (2 * mi**2 * (mi / fs) ** 2))
    value = np.array(out)
    return value * tau**2 / 3 if kind == "tdev" else value


def coverage(seeds: int) -> None:
    s, fs, n = 0.3, 50.0, 4096
    print(f"coverage: white rate noise, {n} samples, octave taus, {seeds} seeds (nominal 0.683)")
    for kind in DEVIATION_KINDS:
        hits = []
        for seed in range(seeds):
            y = white_rate_noise(s / np.sqrt(fs), n, fs, np.random.default_rng(seed))
            r = deviation(y, fs, kind=kind, taus="octave")
            m = r.m
            truth = _truth(kind, m, r.tau_s, s, fs)
            hits.append((r.ci_low <= truth) & (truth <= r.ci_high))
        per_tau = np.mean(hits, axis=0)
        print(
            f"  {kind:6s} overall {np.mean(hits):.3f}  per tau min {per_tau.min():.2f} max "
            f"{per_tau.max():.2f}"
        )


def _flicker_phase(rng: np.random.Generator, n: int) -> np.ndarray:
    size = 4 * n
    f = np.fft.rfftfreq(size)
    amp = np.zeros_like(f)
    amp[1:] = f[1:] ** -0.5
    spec = amp * (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f)))
    return np.fft.irfft(spec, size)[: n + 1]


def flicker_angle(seeds: int) -> None:
    n = 16384
    m = np.array([16, 64, 256, 1024, 2048])
    tot, oav = [], []
    for seed in range(seeds):
        y = np.diff(_flicker_phase(np.random.default_rng(seed), n))
        tot.append(deviation(y, 1.0, kind="totdev", taus=m).variance)
        oav.append(deviation(y, 1.0, kind="oadev", taus=m).variance)
    tot_a, oav_a = np.array(tot), np.array(oav)
    emp_t = 2 * tot_a.mean(0) ** 2 / tot_a.var(0, ddof=1)
    emp_o = 2 * oav_a.mean(0) ** 2 / oav_a.var(0, ddof=1)
    ours = difference_edf_grid(n, m, np.ones((len(m), 1), dtype=np.int64))[:, 0]
    simple = np.exp(np.sqrt(np.log(n / (2 * m)) * np.log((2 * m + 1) * n / 4)))
    print(f"flicker angle noise: {n} samples, {seeds} seeds; edf")
    print(
        f"  {'m':>6} {'total (MC)':>11} {'oAllan (MC)':>12} {'ours':>8} {'SP1065 simple':>14}  "
        "simple/total(MC)"
    )
    for i, mi in enumerate(m):
        print(
            f"  {mi:6d} {emp_t[i]:11.0f} {emp_o[i]:12.0f} {ours[i]:8.0f} {simple[i]:14.0f}  "
            f"{simple[i] / emp_t[i]:.2f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="N = 1e5, fewer seeds")
    args = parser.parse_args()
    cost(100_000 if args.quick else 1_000_000)
    coverage(60 if args.quick else 300)
    flicker_angle(100 if args.quick else 400)


if __name__ == "__main__":
    main()
