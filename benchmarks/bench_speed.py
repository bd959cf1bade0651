"""The default install's speed and memory, row by row, each against its peer in one run.

``python benchmarks/bench_speed.py [--quick]`` prints one line per row:

* ``davar``: fast DAVAR, N = 1e6, window N/10, step Nw/10: the default (``auto``: numpy
  for this much work), numba forced and the numpy fallback, medians of paired runs, with
  the peak memory of each (tracemalloc);
* ``oadev``: overlapping Allan deviation, N = 1e7, 100 log taus: the default against
  numba forced (the goal: within 1.5x) and the numpy fallback;
* ``help``: ``station --help`` in a fresh process against ``python -c "import numpy"``,
  with its peak RSS, and whether scipy, matplotlib or numba were imported;
* ``analyze-csv``: ``station analyze`` of a 1-hour CSV (100 Hz, 3 axes) with numba
  installed against a process where numba cannot be imported;
* ``analyze-h5``: ``station analyze`` of a run file (1 h at 1 kHz, 3 axes; 15 min with
  ``--quick``) the block-wise way (forced: records over 2^16 samples) against the
  in-memory way, peak RSS of each (:mod:`bench_memory`).

Every time is a median of ``--runs`` paired runs (other work on a shared machine skews
single ones); the header gives the versions and the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np

from analysis.allan import kernels
from analysis.allan.estimators import cumulative_angle, log_m
from analysis.davar.estimators import dynamic_allan_variance

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_memory  # noqa: E402  (beside this file)

NO_NUMBA = "import sys; sys.modules['numba'] = None\n"


def peak_mb(fn: Callable[[], object]) -> float:
    """Peak MB of the Python-side (numpy) allocations of one call (tracemalloc; untimed)."""
    tracemalloc.start()
    fn()
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    return peak


def paired(fns: dict[str, Callable[[], object]], runs: int) -> dict[str, tuple[float, float]]:
    """Median seconds of each callable, run in turns, and its peak MB (one more run)."""
    times: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(runs):
        for name, fn in fns.items():
            start = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - start)
    return {k: (statistics.median(v), peak_mb(fns[k])) for k, v in times.items()}


def child(code: str) -> tuple[float, float, str]:
    """(wall seconds, peak RSS MB, stdout) of ``python -c code`` in a fresh process."""
    return bench_memory.run_child(code)


def row_davar(runs: int) -> str:
    rate = np.random.default_rng(0).standard_normal(1_000_000)
    kw = {"window_s": 1e5, "step_s": 1e4}
    dynamic_allan_variance(rate, 1.0, backend="numba", **kw)  # the compiled kernels are loaded
    r = paired({b: (lambda b=b: dynamic_allan_variance(rate, 1.0, backend=b, **kw))
                for b in ("auto", "numba", "numpy")}, runs)
    return (
        f"davar N=1e6 Nw=1e5 step=1e4: default={r['auto'][0]:.3f}s numba={r['numba'][0]:.3f}s "
        f"numpy={r['numpy'][0]:.3f}s numpy/numba={r['numpy'][0] / r['numba'][0]:.1f} goal=0.1s "
        f"numba/goal={r['numba'][0] / 0.1:.2f} peak numba={r['numba'][1]:.0f}MB "
        f"numpy={r['numpy'][1]:.0f}MB"
    )


def row_oadev(runs: int, n: int) -> str:
    theta = cumulative_angle(np.random.default_rng(1).standard_normal(n), 1.0)
    m = log_m(n, n_points=100)
    r = paired(
        {
            b: (lambda b=b: kernels.overlapping_sums(theta, m, backend=b))
            for b in ("auto", "numba", "numpy")
        },
        runs,
    )
    return (
        f"oadev N={n:.0e} taus={len(m)}: default={r['auto'][0]:.3f}s numba={r['numba'][0]:.3f}s "
        f"numpy={r['numpy'][0]:.3f}s default/numba={r['auto'][0] / r['numba'][0]:.2f} "
        f"(goal <= 1.5) "
        f"peak default={r['auto'][1]:.0f}MB"
    )


def row_help(runs: int) -> str:
    code = bench_memory.HWM + (
        "from station.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
        "print('loaded:', *(m for m in ('scipy', 'matplotlib', 'numba') if m in sys.modules))"
    )
    helps, numpys = [], []
    loaded = ""
    for _ in range(runs):
        seconds, peak, out = child(code)
        helps.append(seconds)
        loaded = " ".join(out.strip().splitlines()[-1].split()[1:])
        numpys.append(child("import numpy")[0])
    h, npy = statistics.median(helps), statistics.median(numpys)
    return (
        f"station --help: {h:.3f}s import-numpy={npy:.3f}s ratio={h / npy:.2f} goal=0.3s "
        f"heavy modules imported: {loaded or 'none'} peak={peak:.0f}MB"
    )


def row_analyze_csv(runs: int, tmp: Path) -> str:
    from station.storage.csv_records import write_csv_record

    n = 360_000
    rate = 0.01 * np.random.default_rng(2).standard_normal((n, 3))
    path = tmp / "one_hour.csv"
    write_csv_record(path, rate, 100.0, axis_names=("x", "y", "z"))
    run = f"from station.cli import main\nmain(['analyze', {str(path)!r}, '--json'])\n"
    with_numba, without = [], []
    for _ in range(runs):
        with_numba.append(child(run)[0])
        without.append(child(NO_NUMBA + run)[0])
    a, b = statistics.median(with_numba), statistics.median(without)
    return (
        f"station analyze 1 h CSV (100 Hz, 3 axes): with numba={a:.2f}s without={b:.2f}s "
        f"with/without={a / b:.2f} (goal <= 1)"
    )


def row_analyze_h5(hours: float) -> str:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.h5"
        n = bench_memory.write_run(path, hours, 1000.0, 3)
        argv = ["analyze", str(path), "--json"]
        bounded, t_bounded, _ = bench_memory.measure(argv, 1 << 16)  # block-wise however short
        whole, t_whole, _ = bench_memory.measure(argv, 1 << 40)
    return (
        f"station analyze {hours:g} h x 1 kHz x 3 axes run file: block-wise peak={bounded:.0f}MB "
        f"({t_bounded:.1f}s) in-memory peak={whole:.0f}MB ({t_whole:.1f}s) "
        f"in-memory/block-wise={whole / bounded:.2f}; {n} samples per axis"
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="smaller records, fewer runs")
    p.add_argument(
        "--runs", type=int, default=None, help="paired runs per row (default 5; 3 quick)"
    )
    args = p.parse_args(argv)
    runs = args.runs or (3 if args.quick else 5)
    import numba

    print(
        f"# bench_speed{' --quick' if args.quick else ''}: numpy {np.__version__}, numba "
        f"{numba.__version__}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}, "
        f"medians of {runs} paired runs",
        flush=True,
    )
    print(row_davar(runs), flush=True)
    print(row_oadev(runs, 10_000_000), flush=True)
    print(row_help(runs), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        print(row_analyze_csv(runs, Path(tmp)), flush=True)
    print(row_analyze_h5(0.25 if args.quick else 1.0), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
