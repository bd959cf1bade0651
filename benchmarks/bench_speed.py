"""The speed of what users run, each row against its peer in the same run, as ratios.

``python -m benchmarks.bench_speed [--quick] [--rows ROWS]`` prints:

* ``help`` (issue 40 part 1): every subcommand's ``station CMD --help`` in a fresh
  process against ``python -c "import numpy"`` (goal: at most 3x), and whether it imported
  scipy, matplotlib or numba;
* ``commands`` (issue 40 part 2): the imports ``station analyze`` cannot do without
  (:data:`FLOOR`), then ``station analyze`` and ``station grade`` of a simulated
  single-axis run file at 100 Hz, 1 h (and 24 h without ``--quick``), wall time in a fresh
  process against ``import numpy`` (goal for analyze of 1 h: at most 8x), then the share
  of each step from one profiled run (a step's time includes the imports it starts;
  the steps nest, so shares do not add up to 100 %);
* ``library`` (issue 40 part 3): ``overlapping_allan_variance`` with its edf and
  intervals at N = 1e6, 2e6, 1e7 (``--quick``: 1e6, 2e6) and 100 log taus, against its
  own kernel (the overlapping sums alone; goal within 1.3x) and allantools' ``oadev`` on
  the same taus (goals: at least 4x at 2e6, 10x at 1e7), numba already loaded (a Python
  session's later calls);
* ``backends``: the kernels' backends (fast DAVAR and overlapping sums: default, numba,
  numpy), ``station --help``, ``station analyze`` of a 1 h CSV with and without numba,
  and the block-wise against the in-memory path of a 1 kHz run file (peak RSS).

Wall times of fresh processes are the minimum of ``--runs`` runs (after a run that writes
their bytecode, as an installed package has it; see :func:`child_env`), in-process times the
best of three (``library``: of ``--runs`` paired runs, with their median ratio), paired
with their peer (this machine is shared: the header gives the load average, and a busy
machine stretches every time; the minimum is the least disturbed).
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import shutil
import statistics
import subprocess
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


#: Where the children keep their bytecode (a directory of this run, so that nothing is
#: written into the source tree).
PYCACHE = tempfile.mkdtemp(prefix="bench_speed_pycache_")
atexit.register(shutil.rmtree, PYCACHE, True)


def child_env() -> dict[str, str]:
    """The children's environment: bytecode written and read (in :data:`PYCACHE`), as an
    installed package has it (pip compiles it at install). A shell with
    ``PYTHONDONTWRITEBYTECODE`` set would otherwise compile every module of the project from
    source at each start: 0.3 s of CPU of ``station analyze``, measured against ``import
    numpy``, whose bytecode is installed."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = PYCACHE
    return env


def timed_child(code: str) -> tuple[float, float, str]:
    """(wall seconds, CPU seconds (user + system), stdout) of ``python -c code`` in a fresh
    process (:func:`child_env`). On a shared machine the CPU time is the steadier measure:
    other work stretches the wall time of a process waiting for a core, much less its own
    CPU."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-c", code], stdout=out, stderr=err, text=True,
                                env=child_env())
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - start
        if os.waitstatus_to_exitcode(status) != 0:
            err.seek(0)
            raise SystemExit(f"child failed: {err.read()[-2000:]}")
        out.seek(0)
        return seconds, usage.ru_utime + usage.ru_stime, out.read()


def least(code: str, runs: int, peer: str = "import numpy", *, warm: bool = True
          ) -> tuple[float, float, float, float, str]:
    """(wall, CPU) of ``code`` and of ``peer``, each the least over ``runs`` fresh processes
    run in turns, and ``code``'s last stdout; with ``warm``, after one untimed run of each
    (their bytecode written, as an installed package has it)."""
    if warm:
        timed_child(code)
        timed_child(peer)
    walls, cpus, peer_walls, peer_cpus, out = [], [], [], [], ""
    for _ in range(runs):
        wall, cpu, out = timed_child(code)
        walls.append(wall)
        cpus.append(cpu)
        wall, cpu, _ = timed_child(peer)
        peer_walls.append(wall)
        peer_cpus.append(cpu)
    return min(walls), min(cpus), min(peer_walls), min(peer_cpus), out


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


HEAVY = ("scipy", "matplotlib", "numba")

#: Steps of ``station analyze`` and ``station grade`` whose share is printed:
#: label -> (file the function is in, its name), as the profiler names them.
STEPS: dict[str, tuple[str, str]] = {
    "read": ("station/services/records.py", "load_record"),
    "read run": ("station/storage/runs.py", "open_run"),
    "Allan sums": ("analysis/allan/kernels.py", "overlapping_sums"),
    "noise id": ("analysis/allan/noise_id.py", "identify_noise"),
    "edf": ("analysis/allan/confidence.py", "difference_edf_grid"),
    "spikes": ("analysis/allan/outliers.py", "detect_spikes"),
    "tones": ("analysis/figures/tones.py", "find_tones"),
    "fit": ("analysis/fit/least_squares.py", "fit_noise_terms"),
    "ambiguity": ("analysis/figures/ambiguity.py", "resolve_for_rate"),
    "bias or Markov": ("analysis/figures/bias_or_markov.py", "markov_alternative"),
    "spec figures": ("analysis/figures/spec.py", "spec_figures"),
    "imports": ("<frozen importlib._bootstrap>", "_find_and_load"),
}

PROFILED = """
import cProfile, contextlib, io, json, pstats, sys, time
start = time.perf_counter()
profile = cProfile.Profile()
profile.enable()
from station.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main({argv!r})
profile.disable()
total = time.perf_counter() - start
steps = {steps!r}
found = {{}}
for (file, _, name), row in pstats.Stats(profile).stats.items():
    for label, (where, fn) in steps.items():
        if name == fn and file.endswith(where):
            found[label] = found.get(label, 0.0) + row[3]
print(json.dumps({{"total": total, "code": code, "steps": found}}))
"""


def row_help_commands(runs: int) -> list[str]:
    """Each subcommand's ``--help`` against ``import numpy``, run in turns."""
    from station.commands import COMMAND_HELP

    lines = []
    for name in ["", *COMMAND_HELP]:
        argv = [name, "--help"] if name else ["--help"]
        code = (f"import sys\nfrom station.cli import main\ntry:\n    main({argv!r})\n"
                f"except SystemExit:\n    pass\n"
                f"print('loaded:', *(m for m in {HEAVY!r} if m in sys.modules))")
        wall, cpu, npy_wall, npy_cpu, out = least(code, runs)
        loaded = " ".join(out.strip().splitlines()[-1].split()[1:])
        lines.append(f"help station {' '.join(argv)}: wall {wall:.3f}s/{npy_wall:.3f}s="
                     f"{wall / npy_wall:.2f}x cpu {cpu:.3f}s/{npy_cpu:.3f}s={cpu / npy_cpu:.2f}x "
                     f"of import numpy (goal <= 3) heavy: {loaded or 'none'}")
    return lines


#: What ``station analyze`` of a run file imports and cannot do without: the file's reader,
#: the chi-square and digamma functions of the intervals and weights (``scipy.special``) and
#: the bounded least squares of the fits (``scipy.optimize``: ``nnls``, the GMWM's
#: ``least_squares``). scipy 1.17 (the newest for Python 3.11) imports its array-API layer
#: with any subpackage, which touches every attribute of numpy (``numpy.f2py`` and
#: ``numpy.testing`` included): 0.23 s here of ``import scipy.special``'s 0.27 s.
FLOOR = "import numpy, h5py, scipy.special, scipy.optimize"


def row_commands(hours: tuple[float, ...], runs: int, rate_hz: float = 100.0) -> list[str]:
    """The floor (:data:`FLOOR`), then ``station analyze`` and ``station grade`` of
    single-axis run files: wall and CPU against ``import numpy``, and each step's share of
    one profiled run."""
    wall, cpu, npy_wall, npy_cpu, _ = least(FLOOR, runs)
    lines = [f"commands floor ({FLOOR}): wall {wall:.2f}s={wall / npy_wall:.1f}x "
             f"cpu {cpu:.2f}s={cpu / npy_cpu:.1f}x of import numpy"]
    with tempfile.TemporaryDirectory() as tmp:
        profile = bench_memory.write_profile(Path(tmp) / "profile.toml", ("x",), 0.0)
        for h in hours:
            path = Path(tmp) / f"run_{h:g}h.h5"
            n = bench_memory.write_run(path, h, rate_hz, 1)
            for command in ("analyze", "grade"):
                argv = bench_memory.command_argv(command, path, profile, Path(tmp))
                code = (f"import contextlib, io\nfrom station.cli import main\n"
                        f"with contextlib.redirect_stdout(io.StringIO()):\n"
                        f"    main({argv!r})\n")
                # a longer record's commands run the modules the 1 h one warmed
                wall, cpu, npy_wall, npy_cpu, _ = least(code, runs if h <= 1 else 1,
                                                        warm=h == hours[0])
                out = timed_child(PROFILED.format(argv=argv, steps=STEPS))[2]
                doc = json.loads(out.strip().splitlines()[-1])
                total = doc["total"]
                shares = " ".join(
                    f"{label}={100 * doc['steps'][label] / total:.0f}%"
                    for label in STEPS if doc["steps"].get(label, 0.0) >= 0.005 * total)
                goal = " (goal <= 8)" if command == "analyze" and h == 1 else ""
                lines.append(
                    f"commands station {command} {h:g} h x {rate_hz:g} Hz x 1 axis ({n} samples): "
                    f"wall {wall:.2f}s={wall / npy_wall:.1f}x cpu {cpu:.2f}s={cpu / npy_cpu:.1f}x "
                    f"of import numpy{goal}; profiled run {total:.2f}s: {shares}")
    return lines


def row_library(sizes: tuple[int, ...], fs: float = 100.0, turns: int = 3) -> list[str]:
    """``overlapping_allan_variance`` with edf and intervals against its kernel and
    allantools' ``oadev`` on the same taus, numba loaded (best of ``turns`` paired runs,
    and the median of the paired call/kernel ratios)."""
    from analysis import overlapping_allan_variance

    overlapping_allan_variance(np.random.default_rng(0).standard_normal(2_000_000), fs)
    return [_library_case(n, fs, turns) for n in sizes]


def _library_case(n: int, fs: float, turns: int = 3) -> str:
    import allantools

    from analysis import overlapping_allan_variance

    rate = np.random.default_rng(3).standard_normal(n)
    m = np.unique(np.rint(np.geomspace(1, n // 9, 100))).astype(np.int64)
    taus = m / fs
    theta = cumulative_angle(rate, fs)
    best: dict[str, list[float]] = {"call": [], "kernel": [], "allantools": []}
    cpu: dict[str, list[float]] = {"call": [], "kernel": [], "allantools": []}
    fns: dict[str, Callable[[], object]] = {
        "call": lambda: overlapping_allan_variance(rate, fs, taus=taus),
        "kernel": lambda: kernels.overlapping_sums(theta, m),
        "allantools": lambda: allantools.oadev(rate, rate=fs, data_type="freq", taus=taus),
    }
    for turn in range(turns):
        for name, fn in fns.items():
            if name == "allantools" and (n > 5_000_000 or turn >= 3) and turn:
                continue  # 20+ s a call at 1e7: once (and at most three times)
            start, start_cpu = time.perf_counter(), time.process_time()
            fn()
            best[name].append(time.perf_counter() - start)
            cpu[name].append(time.process_time() - start_cpu)
    call, kern, peer = (min(best[k]) for k in ("call", "kernel", "allantools"))
    c_call, c_kern, c_peer = (min(cpu[k]) for k in ("call", "kernel", "allantools"))
    goal = {2_000_000: " (goal >= 4)", 10_000_000: " (goal >= 10)"}.get(n, "")
    paired = np.median(np.array(best["call"]) / np.array(best["kernel"]))
    return (f"library overlapping_allan_variance N={n:.0e} taus={len(m)}: wall call={call:.3f}s "
            f"kernel={kern:.3f}s allantools={peer:.3f}s call/kernel={call / kern:.2f} "
            f"(median of {turns} paired: {paired:.2f}; goal <= 1.3) "
            f"allantools/call={peer / call:.1f}{goal}; cpu call={c_call:.3f}s "
            f"kernel={c_kern:.3f}s allantools={c_peer:.3f}s call/kernel={c_call / c_kern:.2f} "
            f"allantools/call={c_peer / c_call:.1f} (the compiled kernel's CPU counts every "
            f"core it ran on)")


ROWS = ("help", "commands", "library", "backends")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="smaller records, fewer runs")
    p.add_argument(
        "--runs", type=int, default=None, help="runs per row (default 5; 3 quick)"
    )
    p.add_argument("--rows", default=",".join(ROWS[:3]),
                   help=f"comma-separated rows of {', '.join(ROWS)} (default the first three)")
    args = p.parse_args(argv)
    runs = args.runs or (3 if args.quick else 5)
    rows = args.rows.split(",")
    unknown = set(rows) - set(ROWS)
    if unknown:
        p.error(f"unknown rows {sorted(unknown)}; use {', '.join(ROWS)}")
    import numba

    print(
        f"# bench_speed{' --quick' if args.quick else ''}: numpy {np.__version__}, numba "
        f"{numba.__version__}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}, "
        f"least of {runs} runs (fresh processes), best of 3 (in process; library: of "
        f"{max(3, runs)} paired)",
        flush=True,
    )
    if "help" in rows:
        for line in row_help_commands(runs):
            print(line, flush=True)
    if "commands" in rows:
        for line in row_commands((1.0,) if args.quick else (1.0, 24.0), runs):
            print(line, flush=True)
    if "library" in rows:
        sizes = (1_000_000, 2_000_000) if args.quick else (1_000_000, 2_000_000, 10_000_000)
        for line in row_library(sizes, turns=max(3, runs)):
            print(line, flush=True)
    if "backends" in rows:
        print(row_davar(runs), flush=True)
        print(row_oadev(runs, 10_000_000), flush=True)
        print(row_help(runs), flush=True)
        with tempfile.TemporaryDirectory() as tmp:
            print(row_analyze_csv(runs, Path(tmp)), flush=True)
        print(row_analyze_h5(0.25 if args.quick else 1.0), flush=True)
    print(f"# load average at the end {os.getloadavg()[0]:.1f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
