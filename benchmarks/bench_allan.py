"""Speed of the Allan family, side by side with a peer, in one run (run by hand, not in CI).

    python benchmarks/bench_allan.py --quick     # under two minutes
    python benchmarks/bench_allan.py             # the full table of issue 3

One line per case: our median time, the peer's, ``ratio=`` (peer time / our time), the
number of runs behind each median, and the peak traced memory (tracemalloc, an extra
untimed run; memory numba allocates is not seen). The overlapping cases also print the
memory-bandwidth floor, one streaming read of the angle array per tau at the read
bandwidth measured in the same run. "ours" there computes what ``allantools.oadev``
does (ADEV per tau, no confidence interval); the full ``overlapping_allan_variance``
(edf and chi-square interval per tau) is timed once beside it. Times marked ``~`` are extrapolated
from a part of the work (the method's cost is linear in it), for methods that would run
for minutes.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import tracemalloc
from collections.abc import Callable

import allantools
import numpy as np

from analysis.allan import kernels
from analysis.allan.estimators import (
    cluster_allan_variance,
    cumulative_angle,
    log_m,
    overlapping_allan_variance,
    overlapping_sums,
)
from analysis.davar.estimators import davar_plain, davar_recursive, dynamic_allan_variance

#: Zhang 2015, table 3: MATLAB times (s) of DAVAR, fast DAVAR, improved fast DAVAR on a
#: Core 2 Duo at 3 GHz (other hardware: compare ratios between methods, not seconds).
SEED_TABLE3 = {
    1_000: (5.34, 0.73, 0.43),
    10_000: (217.12, 2.36, 0.85),
    100_000: (8970.28, 76.27, 8.27),
}


def median_time(fn: Callable[[], object], *, runs: int, budget_s: float) -> tuple[float, int]:
    """Median wall time of ``fn`` over up to ``runs`` runs (at least one; fewer past
    ``budget_s``)."""
    times: list[float] = []
    start = time.perf_counter()
    while len(times) < runs:
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        if time.perf_counter() - start > budget_s:
            break
    return statistics.median(times), len(times)


def peak_mb(fn: Callable[[], object]) -> float:
    """Peak memory traced while ``fn`` runs, in MB."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def read_bandwidth_gb_s(array: np.ndarray) -> float:
    """Best streaming read bandwidth over ``array`` (GB/s), best of several passes of
    numpy's sum (one core) and, if numba is installed, a parallel sum (all cores)."""
    readers: list[Callable[[np.ndarray], float]] = [np.sum]
    if kernels.have_compiled():
        import numba

        @numba.njit(parallel=True, fastmath=True)
        def total(a):  # pragma: no cover - compiled
            s = 0.0
            for i in numba.prange(a.shape[0]):
                s += a[i]
            return s

        total(array[:1000])
        readers.append(total)
    best = min(median_time(lambda r=r: r(array), runs=1, budget_s=0)[0]
               for r in readers for _ in range(8))
    return array.nbytes / best / 1e9


def overlapping_adev(rate: np.ndarray, fs: float, m: np.ndarray) -> np.ndarray:
    """What ``allantools.oadev`` computes (ADEV per tau, no confidence interval), our way."""
    theta = cumulative_angle(rate, fs)
    sums = overlapping_sums(theta, m)[:, 0]
    return np.sqrt(sums / (2.0 * (m / fs) ** 2 * (len(rate) + 1 - 2 * m)))


def oadev_case(n: int, runs: int, budget_s: float, rng: np.random.Generator, *,
               peer_memory: bool) -> None:
    fs = 100.0
    rate = rng.standard_normal(n)
    m = np.unique(np.rint(np.geomspace(1, n // 9, 100))).astype(np.int64)
    taus = m / fs
    theta = cumulative_angle(rate, fs)
    bandwidth = read_bandwidth_gb_s(np.ascontiguousarray(theta[:, 0]))
    floor = len(m) * theta.nbytes / (bandwidth * 1e9)
    check = overlapping_adev(rate, fs, m) / allantools.oadev(rate, rate=fs, data_type="freq",
                                                             taus=taus)[1] - 1
    ours, n_ours = median_time(lambda: overlapping_adev(rate, fs, m), runs=runs, budget_s=budget_s)
    kern, _ = median_time(lambda: overlapping_sums(theta, m), runs=runs, budget_s=budget_s)
    kern_np, _ = median_time(lambda: kernels.overlapping_sums(theta, m, backend="numpy"),
                             runs=max(1, runs // 2), budget_s=budget_s / 2)
    full, _ = median_time(lambda: overlapping_allan_variance(rate, fs, taus=taus), runs=1,
                          budget_s=0)
    peer, n_peer = median_time(
        lambda: allantools.oadev(rate, rate=fs, data_type="freq", taus=taus),
        runs=runs, budget_s=budget_s)
    mem_ours = peak_mb(lambda: overlapping_adev(rate, fs, m))
    mem_peer = (
        f"{peak_mb(lambda: allantools.oadev(rate, rate=fs, data_type='freq', taus=taus)):.0f}MB"
        if peer_memory
        else "(not measured with --quick)"
    )
    backend = "numba" if kernels.have_compiled() else "numpy"
    print(f"oadev N={n:.0e} taus={len(m)}: ours={ours:.3f}s (n={n_ours}; kernel {backend} "
          f"{kern:.3f}s, numpy fallback kernel {kern_np:.3f}s) allantools={peer:.3f}s (n={n_peer}) "
          f"ratio={peer / ours:.1f} floor={floor:.3f}s (read {bandwidth:.1f} GB/s) "
          f"ours/floor={ours / floor:.2f} kernel/floor={kern / floor:.2f} "
          f"max|ours/allantools-1|={np.abs(check).max():.1e} "
          f"peak ours={mem_ours:.0f}MB allantools={mem_peer} "
          f"| overlapping_allan_variance with edf+CI: {full:.3f}s", flush=True)


def cluster_case(runs: int, budget_s: float, rng: np.random.Generator) -> None:
    n, fs = 144_000, 10.0
    rate = rng.standard_normal(n)
    ours, n_ours = median_time(lambda: cluster_allan_variance(rate, fs, taus="all"),
                               runs=runs, budget_s=budget_s)
    taus = np.arange(1, n // 2 + 1) / fs
    peer, n_peer = median_time(lambda: allantools.adev(rate, rate=fs, data_type="freq", taus=taus),
                               runs=max(1, runs // 2), budget_s=budget_s)
    mem = peak_mb(lambda: cluster_allan_variance(rate, fs, taus="all"))
    print(f"cluster all-m N={n} taus={len(taus)}: ours={ours:.3f}s (n={n_ours}) "
          f"allantools.adev={peer:.3f}s (n={n_peer}) ratio={peer / ours:.1f} peak ours={mem:.0f}MB",
          flush=True)


def linear_time(fn: Callable[[int], object], full_units: int, first_units: int,
                limit_s: float) -> tuple[float, str]:
    """Time of ``fn(full_units)`` for a method whose cost is linear in its units of work.

    Runs ``fn(first_units)``; if the whole job then looks longer than ``limit_s``, runs
    as many units as fit in ``limit_s`` and scales up (marked ``~``), else runs it whole.
    """
    t0 = time.perf_counter()
    fn(first_units)
    first = time.perf_counter() - t0
    if first_units >= full_units:
        return first, ""
    units = full_units if first * full_units / first_units <= limit_s else max(
        first_units, int(first_units * limit_s / max(first, 1e-9)))
    if units > first_units:
        t0 = time.perf_counter()
        fn(units)
        first, first_units = time.perf_counter() - t0, units
    if units >= full_units:
        return first, ""
    return first * full_units / first_units, "~"


def davar_case(n: int, runs: int, budget_s: float, rng: np.random.Generator, *,
               slow_limit_s: float) -> None:
    fs = 1.0
    rate = rng.standard_normal(n)
    window = n // 10
    step = 1 if n in SEED_TABLE3 else window // 10
    kw = dict(window_s=window / fs, step_s=step / fs)
    fast, n_fast = median_time(lambda: dynamic_allan_variance(rate, fs, **kw), runs=runs,
                               budget_s=budget_s)
    n_windows = (n - window) // step + 1
    mem = peak_mb(lambda: dynamic_allan_variance(rate, fs, **kw))
    # recursive: linear in the samples it walks; plain: linear in the windows.
    recursive, rec_mark = linear_time(lambda k: davar_recursive(rate[:k], fs, **kw), n,
                                      min(n, window + 10 * step), slow_limit_s)
    plain, plain_mark = linear_time(
        lambda k: davar_plain(rate[: window + (k - 1) * step], fs, **kw), n_windows, 1, slow_limit_s
    )
    seed = SEED_TABLE3.get(n)
    seed_text = (f" | seed MATLAB: plain={seed[0]}s fast={seed[1]}s improved={seed[2]}s "
                 f"(plain/improved={seed[0] / seed[2]:.0f})" if seed else "")
    print(f"davar N={n:.0e} Nw={window} step={step} windows={n_windows} taus={len(log_m(window))}: "
          f"fast={fast:.3f}s (n={n_fast}) recursive={rec_mark}{recursive:.3f}s "
          f"plain={plain_mark}{plain:.3f}s ratio={plain / fast:.0f} (plain/fast) "
          f"recursive/fast={recursive / fast:.0f} peak fast={mem:.0f}MB{seed_text}", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer runs and sizes: < 2 minutes")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(2015)
    runs, budget = (3, 5.0) if args.quick else (7, 60.0)
    slow_limit = 3.0 if args.quick else 60.0
    backend = (
        "numba " + __import__("numba").__version__ if kernels.have_compiled() else "numpy only"
    )
    print(f"# bench_allan {'--quick' if args.quick else '(full)'}: numpy {np.__version__}, "
          f"allantools {allantools.__version__}, kernels: {backend}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f} (other work on the machine skews every time)",
          flush=True)
    dynamic_allan_variance(rng.standard_normal(2000), 1.0, window_s=200.0)  # compile / load
    overlapping_allan_variance(rng.standard_normal(2000), 1.0)
    for n in (10**6, 10**7):
        oadev_case(n, runs, budget, rng, peer_memory=not args.quick)
    cluster_case(runs, budget, rng)
    for n in (1_000, 10_000, 100_000, 1_000_000) + (() if args.quick else (10_000_000,)):
        davar_case(n, runs, budget, rng, slow_limit_s=slow_limit)
    return 0


if __name__ == "__main__":
    sys.exit(main())
