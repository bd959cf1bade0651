"""``station serve`` under a line's load: C clients at once over a mixed set of pages while
gradings are stored, on loopback only (run by hand, not in CI).

Fills an SQLite results database with U graded units in L lots (one graded simulated
record, each copy given its own serial, lot, test date and ARW), starts ``station serve``
on 127.0.0.1 (a free port) as its own process, then runs C client threads, each asking N
pages in turn from the mix below, while this process stores a new grading every S seconds
(each one a new database state: the statistics and charts are computed again). Prints the
p50, p90, p99 and maximum latency of every page kind and of all requests together, the
answers other than 200, the gradings stored during the load, and the load average before
and after (other work on the machine skews every figure).

Every request has a time limit (``--timeout``) and the clients stop after N requests each,
so a run is bounded: at most C x N requests. ``--code DIR`` serves with another copy of the
station's code (``git archive COMMIT | tar -x -C DIR``: the figures before a change).

Run::

    PYTHONPATH=. python benchmarks/bench_serve.py                       # 32 clients x 12
    PYTHONPATH=. python benchmarks/bench_serve.py --clients 8 --requests 4   # a quick one
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
from dataclasses import replace
from pathlib import Path

from station.evaluation.grading import RunGrade, grade_run
from station.model.profiles import load_profile
from station.output.results import ResultsDatabase
from station.storage.runs import open_run
from tests.test_grading import make_record, profile_text, write_profile

#: The pages each client asks in turn (kind, path): the overview, a figure's page with its
#: two charts, a unit's page, and their JSON.
PAGES = (
    ("overview", "/"),
    ("api-overview", "/api/overview"),
    ("api-stats", "/api/stats"),
    ("figure", "/figures/arw"),
    ("chart.svg", "/figures/arw/chart.svg"),
    ("trend.svg", "/figures/arw/trend.svg"),
    ("api-figure", "/api/figures/arw"),
    ("unit", "/units/B0001"),
    ("api-unit", "/api/units/B0001"),
    ("figure-L1", "/figures/arw?lot=L1"),
    ("chart-L1", "/figures/arw/chart.svg?lot=L1"),
    ("trend-L1", "/figures/arw/trend.svg?lot=L1"),
)


def unit_copy(graded: RunGrade, i: int, lots: int) -> RunGrade:
    """The graded unit as unit ``i`` of the line: serial ``B%04d``, lot ``L{i % lots}``,
    its own test date and ARW."""
    unit = graded.units[0]
    axis = unit.axes[0]
    arw = 0.03 + 0.002 * (i % 17) + 0.0005 * (i % lots)
    figures = tuple(replace(f, value=arw) if f.name == "arw" else f for f in axis.figures)
    run = replace(graded.run, path=f"{graded.run.path}#{i}",
                  metadata=replace(graded.run.metadata, lot=f"L{i % lots}"),
                  start_utc=f"2026-{1 + i // 28 % 12:02d}-{1 + i % 28:02d}T08:00:00Z",
                  units=(replace(unit.unit, serial_number=f"B{i:04d}"),))
    return replace(graded, run=run, units=(replace(unit, unit=run.units[0],
                                                   axes=(replace(axis, figures=figures),)),))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_for(url: str, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            urllib.request.urlopen(url, timeout=5).read()
            return
        except (OSError, urllib.error.URLError):
            if time.monotonic() > deadline:
                raise
            time.sleep(0.3)


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q / 100 * len(ordered)) - 1))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clients", type=int, default=32)
    parser.add_argument("--requests", type=int, default=12, help="requests per client")
    parser.add_argument("--units", type=int, default=120, help="graded units stored first")
    parser.add_argument("--lots", type=int, default=4)
    parser.add_argument("--store-every", type=float, default=2.0, metavar="S",
                        help="a grading stored every S seconds during the load")
    parser.add_argument("--timeout", type=float, default=180.0, help="per request, s")
    parser.add_argument("--code", type=Path, default=None,
                        help="the station's code to serve with (default: this one)")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        record = make_record(tmp / "unit.csv", n=6_000, seed=5)
        graded = grade_run(open_run(record),
                           load_profile(write_profile(tmp, profile_text(warmup_s=10.0))))
        db = tmp / "line.sqlite"
        with ResultsDatabase(db) as results:
            for i in range(args.units):
                results.store(unit_copy(graded, i, args.lots))
        port = free_port()
        code = str(args.code or Path(__file__).resolve().parents[1])
        server = subprocess.Popen(
            [sys.executable, "-m", "station", "serve", "--db", str(db), "--port", str(port)],
            env={**os.environ, "PYTHONPATH": code}, stderr=subprocess.DEVNULL)
        base = f"http://127.0.0.1:{port}"
        try:
            wait_for(base + "/api/runs", 60.0)
            times: dict[str, list[float]] = {kind: [] for kind, _ in PAGES}
            failures: list[str] = []
            lock = threading.Lock()
            stop = threading.Event()
            stored = [0]

            def store() -> None:
                i = args.units
                with ResultsDatabase(db) as results:
                    while not stop.wait(args.store_every):
                        results.store(unit_copy(graded, i, args.lots))
                        i += 1
                        stored[0] += 1

            def client(k: int) -> None:
                for r in range(args.requests):
                    kind, path = PAGES[(k + r) % len(PAGES)]
                    start = time.perf_counter()
                    try:
                        with urllib.request.urlopen(base + path, timeout=args.timeout) as a:
                            a.read()
                            status = a.status
                    except urllib.error.HTTPError as exc:
                        status = exc.code
                    except OSError as exc:
                        status = 0
                        with lock:
                            failures.append(f"{kind}: {exc}")
                    took = time.perf_counter() - start
                    with lock:
                        times[kind].append(took)
                        if status not in (0, 200):
                            failures.append(f"{kind}: {status}")

            writer = threading.Thread(target=store)
            writer.start()
            clients = [threading.Thread(target=client, args=(k,)) for k in range(args.clients)]
            start = time.perf_counter()
            for t in clients:
                t.start()
            for t in clients:
                t.join()
            wall = time.perf_counter() - start
            stop.set()
            writer.join()
        finally:
            server.terminate()
            server.wait(timeout=30)
    every = [t for ts in times.values() for t in ts]
    print(f"{args.clients} clients x {args.requests} requests = {len(every)} in {wall:.1f} s; "
          f"{stored[0]} gradings stored meanwhile (one every {args.store_every:g} s), "
          f"{args.units} units in {args.lots} lots before")
    print(f"{'page':<14}{'n':>5}{'p50 s':>9}{'p90 s':>9}{'p99 s':>9}{'max s':>9}")
    for kind, ts in [*times.items(), ("all", every)]:
        if ts:
            print(f"{kind:<14}{len(ts):>5}{statistics.median(ts):>9.3f}"
                  f"{percentile(ts, 90):>9.3f}{percentile(ts, 99):>9.3f}{max(ts):>9.3f}")
    print(f"answers other than 200: {len(failures)}"
          + (f" ({'; '.join(failures[:5])})" if failures else ""))
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
