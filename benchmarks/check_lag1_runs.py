"""The lag-1 noise identification read in runs against the whole decimated series.

``python benchmarks/check_lag1_runs.py [--samples N] [--seeds S]`` simulates records of each
power-law noise (white and flicker angle, white and flicker rate, white rate plus a random
walk, and a mixture of white angle, white rate and flicker rate), identifies the type at
every tau of a 100-point log grid where the series holds more than
:data:`analysis.allan.noise_id.ACF_MAX_POINTS` decimated points, once from the
:data:`~analysis.allan.noise_id.ACF_PIECES` runs :func:`analysis.allan.noise_id.lag1_alpha`
reads and once from the whole series, and prints how many (record, tau) cells differ.
"""

from __future__ import annotations

import argparse

import numpy as np

from analysis.allan.estimators import cumulative_angle
from analysis.allan.noise_id import (
    ACF_MAX_POINTS,
    _alpha_from_lag1,
    lag1_alpha,
    lag1_autocorrelation,
)


def power_law(n: int, alpha: float, rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise of n samples with spectrum ~ f^alpha (FFT shaping)."""
    f = np.fft.rfftfreq(n)
    shape = np.zeros_like(f)
    shape[1:] = f[1:] ** (alpha / 2)
    return np.fft.irfft(np.fft.rfft(rng.standard_normal(n)) * shape, n)


def whole_series_alpha(theta: np.ndarray, m: int, d_max: int = 2) -> int:
    """The type from the whole decimated series (what :func:`lag1_alpha` read before runs)."""
    y = theta[::m]

    def lag1(d: int) -> tuple[float, int]:
        z = np.diff(y, n=d)
        return lag1_autocorrelation(z), len(z)

    return _alpha_from_lag1(lag1, d_max)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--samples", type=int, default=600_000)
    p.add_argument("--seeds", type=int, default=3)
    args = p.parse_args(argv)
    n = args.samples
    m_grid = np.unique(np.rint(np.geomspace(1, n // 9, 100))).astype(np.int64)
    m_runs = m_grid[n // m_grid + 1 > ACF_MAX_POINTS]
    cells = differ = 0
    for seed in range(args.seeds):
        rng = np.random.default_rng(seed)
        records = {
            "white rate": rng.standard_normal(n),
            "white + random-walk rate": rng.standard_normal(n)
            + np.cumsum(rng.standard_normal(n)) * 3e-3,
            "flicker rate": power_law(n, -1, rng),
            "white angle": np.diff(rng.standard_normal(n + 1)),
            "flicker angle": power_law(n, 1, rng),
            "mixture": np.diff(rng.standard_normal(n + 1)) * 3 + rng.standard_normal(n) * 0.05
            + power_law(n, -1, rng) * 0.5,
        }
        for name, rate in records.items():
            theta = cumulative_angle(rate, 1.0)[:, 0]
            runs = [lag1_alpha(theta, int(m)) for m in m_runs]
            whole = [whole_series_alpha(theta, int(m)) for m in m_runs]
            bad = [int(m) for m, a, b in zip(m_runs, runs, whole, strict=True) if a != b]
            cells += len(m_runs)
            differ += len(bad)
            print(f"seed {seed} {name}: types {sorted(set(whole))}, differ at m {bad}", flush=True)
    print(f"lag-1 in runs against the whole series: {differ} of {cells} cells differ "
          f"(N={n}, taus read in runs: m <= {int(m_runs.max()) if len(m_runs) else 0})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
