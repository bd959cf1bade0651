"""Recorder throughput: N simulated units at 2 kHz x 3 axes over their real transports.

Records with the real recorder (every unit in a process of its own) into an HDF5 run
file: by default 16 units, 4 each of STIM300, KVH DSP-1750 and Xsens Xbus on ptys and
raw CAN on python-can's virtual bus, for 60 s at warp 1. Prints per unit the samples
recorded, declared missing (with their bounds), sent by its simulator (every nominal
sample of the run: a simulator that cannot run in time loses samples, as a starved
gyro would, and they must be declared), whether its books balance, and the CPU its
process used (reading, and its simulator); then the recorder process's CPU and the
machine's load average before and after (other work on the machine skews everything).

Run::

    python benchmarks/bench_recorder.py                       # 16 x 2 kHz, 60 s
    python benchmarks/bench_recorder.py --units 4 --seconds 10
    python benchmarks/bench_recorder.py --starts 10           # 16 x 2 kHz started 10 times

``--starts N`` records nothing: it starts the units N times in a row as a run starts
them (each unit's process opens its device, the units start, every unit must send a
first sample within the first-sample timeout), releases them, and prints per start
whether every unit started, how long it took, and the load average, then how many of
the N starts started.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from station.errors import RunConfigurationError
from station.recording.recorder import Recorder, RunConfig

KINDS = ("serial/stim300", "serial/kvh1750", "serial/xbus", "can/shared")


def unit_urls(n: int, rate_hz: float, warp: float) -> tuple[tuple[str, str], ...]:
    """(kind, device URL) of ``n`` benchmark units, the four kinds in turn."""
    q = f"rate={rate_hz:g}&warp={warp:g}"
    urls = {"serial/stim300": "sim+serial://STIM300?protocol=stim300&{q}&seed={s}",
            "serial/kvh1750": "sim+serial://DSP-1750?protocol=kvh1750&{q}&seed={s}",
            "serial/xbus": "sim+serial://MTI-630?protocol=xbus&{q}&seed={s}",
            "can/shared": "sim+can://STIM300?layout=shared&{q}&seed={s}"}
    return tuple((KINDS[i % 4], urls[KINDS[i % 4]].format(q=q, s=i + 1)) for i in range(n))


def starts(units: tuple[tuple[str, str], ...], n: int, seconds: float, rate_hz: float) -> int:
    """Start ``units`` ``n`` times in a row (nothing recorded); print each start and
    return how many started (every unit sent its first sample in time)."""
    started = 0
    config = RunConfig(tuple(url for _, url in units), seconds, Path(tempfile.gettempdir()))
    for i in range(n):
        load0, t0 = os.getloadavg(), time.monotonic()
        try:
            Recorder(config).check_units()
        except RunConfigurationError as exc:
            problems = exc.problems
        else:
            problems = []
        started += not problems
        load1 = os.getloadavg()
        print(f"start {i + 1:2d}: {'started' if not problems else 'FAILED':8s} "
              f"{time.monotonic() - t0:5.1f} s; load average {load0[0]:.1f} before, "
              f"{load1[0]:.1f} after", flush=True)
        for problem in problems:
            print(f"    {problem}")
    print(f"{len(units)} units x {rate_hz:g} Hz: "
          f"started {started} of {n} times ({os.cpu_count()} cores; load average "
          f"{os.getloadavg()[0]:.1f} now)")
    return started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--units", type=int, default=16, help="units (4 kinds in turn)")
    parser.add_argument("--seconds", type=float, default=60.0, help="run length, s")
    parser.add_argument("--rate", type=float, default=2000.0, help="sample rate, Hz")
    parser.add_argument("--warp", type=float, default=1.0, help="time-warp factor")
    parser.add_argument("--starts", type=int, default=0,
                        help="start the units this many times in a row, record nothing")
    args = parser.parse_args()
    units = unit_urls(args.units, args.rate, args.warp)
    if args.starts:
        starts(units, args.starts, args.seconds, args.rate)
        return
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        recorder = Recorder(RunConfig(tuple(url for _, url in units), args.seconds,
                                      Path(tmp) / "bench.h5"))
        t0 = time.monotonic()
        recorder.prepare()
        t_prepare = time.monotonic() - t0
        stop = recorder.run()
        size = recorder.path.stat().st_size
    load1 = os.getloadavg()
    wall = recorder.wall_s
    print(
        f"{len(units)} units x {args.rate:g} Hz x 3 axes, warp x{args.warp:g}, {args.seconds:g} s "
        f"({os.cpu_count()} cores; load average {load0[0]:.1f} before, {load1[0]:.1f} after); "
        f"prepare {t_prepare:.1f} s, run {wall:.1f} s wall; stop: {stop.reason}"
    )
    print(f"{'unit':8s}{'kind':16s}{'recorded':>9s}{'missing [low, high]':>24s}{'sent':>8s}"
          f"{'nominal':>9s}{'books':>7s}{'CPU s':>7s}{'core':>6s}{'reader s':>9s}")
    nominal = int(args.seconds * args.rate)
    balanced = 0
    for (kind, _), t in zip(units, stop.totals, strict=True):
        sent = t.samples_sent or 0
        ok = t.samples_recorded + t.samples_missing_low <= sent <= (
            t.samples_recorded + t.samples_missing_high)
        balanced += ok
        bounds = f"{t.samples_missing_declared} [{t.samples_missing_low}, {t.samples_missing_high}]"
        print(f"{t.unit_id:8s}{kind:16s}{t.samples_recorded:9d}{bounds:>24s}{sent:8d}"
              f"{nominal:9d}{'ok' if ok else 'OFF':>7s}{t.cpu_s:7.2f}{t.cpu_s / wall:6.0%}"
              f"{t.reader_cpu_s:9.2f}")
    recorded = sum(t.samples_recorded for t in stop.totals)
    sent = sum(t.samples_sent or 0 for t in stop.totals)
    cpu = sum(t.cpu_s for t in stop.totals)
    print(f"books balanced: {balanced} of {len(units)} units; recorded {recorded} of {sent} sent "
          f"({recorded / max(sent, 1):.1%}), {recorded / wall:,.0f} samples/s; file "
          f"{size / 1e6:.1f} MB")
    print(f"CPU: units {cpu:.1f} s = {cpu / wall:.2f} cores ({cpu / len(units) / wall:.0%} of a "
          f"core per unit), recorder process {recorder.engine_cpu_s:.1f} s = "
          f"{recorder.engine_cpu_s / wall:.0%} of a core")


if __name__ == "__main__":
    main()
