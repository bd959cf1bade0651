"""Fleet grading: serial (``station grade`` run after run, in this process) against
``station fleet`` on a local Dask cluster, side by side on the same run files.

Writes N runs of U units (white plus flicker rate noise, one axis by default) at R Hz for
D seconds with the real run-file writer, grades them one after the other in this process
(what a loop over ``station grade`` computes, without its start-up), then with the fleet
service on a local cluster of each worker count asked for; checks that every fleet grade
equals the serial one, and prints wall times and their ratios to the serial time, with and
without the cluster's start, and the peak memory (RSS) of each worker. Other work on the
machine skews every ratio: the load average is printed before and after.

Run::

    PYTHONPATH=. python benchmarks/bench_fleet.py                   # 64 x 4 units, 1 h, 100 Hz
    PYTHONPATH=. python benchmarks/bench_fleet.py --runs 8 --seconds 600  # a quick one
    PYTHONPATH=. python benchmarks/bench_fleet.py --workers 1 2 4 8       # scaling (a larger host)
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

from station.evaluation.grading import grade_run
from station.model.profiles import load_profile
from station.services.fleet import LOCAL, FleetRequest, cluster_client, fleet
from station.storage.runs import open_run
from tests.fleet_runs import write_run

PROFILE = """name = "BENCH"
version = "1"
model = "TG-1"

[transport]
url = "sim+serial://GENERIC?protocol=stim300&rate={rate:g}"

[test]
sample_rate_hz = {rate:g}
duration_s = {seconds:g}
warmup_s = 60.0
axes = {axes}

[grading]
rule = "guard-banded"
confidence = 0.95
grades = ["A", "B"]

[figures.arw]
unit = "deg/sqrt(h)"
limits = {{ A = 0.06, B = 0.2 }}

[figures.bias_instability]
unit = "deg/h"
limits = {{ A = 1.0, B = 3.0 }}

[figures.bias_stability_100s]
unit = "deg/h"
limits = {{ A = 1.0, B = 3.0 }}

[figures.bias]
unit = "deg/h"
"""


def _grades(graded: list) -> dict[tuple[str, str], tuple]:
    return {
        (g.run.path, u.unit.unit_id): (
            u.grade,
            tuple((f.name, f.value) for a in u.axes for f in a.figures),
        )
        for g in graded
        for u in g.units
    }


def _warm_up() -> None:
    import station.services.fleet_tasks  # noqa: F401  (the grading stack)


def _worker_rss_mib(client: object) -> list[float]:
    def rss() -> float:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0

    return sorted(client.run(rss).values())  # type: ignore[attr-defined]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=64, help="run files (default 64)")
    parser.add_argument("--units", type=int, default=4, help="units per run (default 4)")
    parser.add_argument(
        "--seconds", type=float, default=3600.0, help="run length, s (default 3600)"
    )
    parser.add_argument("--rate", type=float, default=100.0, help="sample rate, Hz (default 100)")
    parser.add_argument("--axes", type=int, default=1, choices=(1, 2, 3), help="axes per unit")
    parser.add_argument("--workers", type=int, nargs="+", default=[2], help="local cluster sizes")
    parser.add_argument(
        "--dir", type=Path, default=None, help="where the runs go (default a temp dir)"
    )
    args = parser.parse_args()
    axes = ("x", "y", "z")[: args.axes]
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        root = Path(tmp)
        profile = root / "bench.toml"
        profile.write_text(
            PROFILE.format(rate=args.rate, seconds=args.seconds, axes=list(axes)).replace("'", '"')
        )
        t0 = time.monotonic()
        files = [
            write_run(
                root / "runs" / f"run{k:03d}.h5",
                units=args.units,
                duration_s=args.seconds,
                rate_hz=args.rate,
                seed=k + 1,
                profile=profile,
                axes=axes,
            )
            for k in range(args.runs)
        ]
        size = sum(f.stat().st_size for f in files) / 2**20
        print(
            f"{args.runs} runs x {args.units} units x {len(axes)} axis/axes, {args.seconds:g} s at "
            f"{args.rate:g} Hz: {size:.0f} MiB written in {time.monotonic() - t0:.0f} s"
        )
        print(
            f"load average before: {' '.join(f'{x:.1f}' for x in os.getloadavg())} "
            f"({len(os.sched_getaffinity(0))} CPUs)"
        )
        loaded = load_profile(profile)
        t0 = time.monotonic()
        expected: dict[tuple[str, str], tuple] = {}
        for f in files:  # one run in memory at a time, as a loop over station grade
            expected |= _grades([grade_run(open_run(f), loaded)])
        t_serial = time.monotonic() - t0
        print(f"serial: {t_serial:.1f} s ({t_serial / (args.runs * args.units):.2f} s per unit)")
        for n in args.workers:
            t0 = time.monotonic()
            with cluster_client(LOCAL, n) as client:
                client.run(_warm_up)  # each worker imports what it grades with, as this process did
                t_started = time.monotonic()
                result = fleet(
                    FleetRequest(
                        "grade",
                        (str(root / "runs"),),
                        profile=str(profile),
                        scheduler=client.scheduler.address,
                        store=False,
                    )
                )
                t_done = time.monotonic()
                rss = _worker_rss_mib(client)
            same = _grades(list(result.runs)) == expected and not result.failed
            run_s, total_s = t_done - t_started, t_done - t0
            print(
                f"local cluster, {n} worker(s): {run_s:.1f} s grading, {total_s:.1f} s with the "
                f"cluster's start; speed-up x{t_serial / run_s:.2f} "
                f"(x{t_serial / total_s:.2f} with "
                f"the start); same grades and figures as serial: {same}; worker peak RSS "
                f"{', '.join(f'{r:.0f}' for r in rss)} MiB"
            )
        print(f"load average after: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
