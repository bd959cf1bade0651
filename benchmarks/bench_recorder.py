"""Recorder throughput: 4 simulated units at 2 kHz x 3 axes over their real transports.

Records a fixed number of samples per unit (STIM300, KVH DSP-1750 and Xsens Xbus on
ptys, a raw-CAN node on python-can's virtual bus) with the real recorder into an HDF5 run
file, and reports the samples per second achieved, the samples dropped (sent by the
simulators but neither recorded nor declared missing: must be 0; no faults are injected,
so nothing should be declared missing either), whether the recorder kept pace with real
time, and where the CPU went, per thread group: the recorder's unit threads (adapter
reads and frame decoding), its engine thread (documents, HDF5 writes and flushes), and
the simulators (frame encoding; in a real bench they are the gyros, not the station).

Run::

    python benchmarks/bench_recorder.py                 # 4 x 2 kHz, 20000 samples each
    python benchmarks/bench_recorder.py --warp 2        # twice real time: the headroom
"""

from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path

from station.recorder import Recorder, RunConfig

PROTOCOLS = ("serial/stim300", "serial/kvh1750", "serial/xbus", "can/shared")
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def unit_urls(rate_hz: float, warp: float) -> tuple[str, ...]:
    """Device URLs of the four benchmark units."""
    q = f"rate={rate_hz:g}&warp={warp:g}"
    return (f"sim+serial://STIM300?protocol=stim300&{q}&seed=1",
            f"sim+serial://DSP-1750?protocol=kvh1750&{q}&seed=2",
            f"sim+serial://MTI-630?protocol=xbus&{q}&seed=3",
            f"sim+can://STIM300?layout=shared&{q}&seed=4")


class ThreadCpu:
    """Samples every thread's CPU time (s, from /proc) by thread name until stopped."""

    def __init__(self, period_s: float = 0.2) -> None:
        self.period_s = period_s
        self.cpu_s: dict[int, float] = {}
        self.names: dict[int, str] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="bench-sampler", daemon=True)

    def _sample(self) -> None:
        for t in threading.enumerate():
            if t.native_id is None:
                continue
            try:
                with open(f"/proc/self/task/{t.native_id}/stat", encoding="ascii") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            self.cpu_s[t.native_id] = (int(fields[11]) + int(fields[12])) / CLOCK_TICKS
            self.names[t.native_id] = t.name

    def _run(self) -> None:
        while not self._stop.wait(self.period_s):
            self._sample()

    def __enter__(self) -> ThreadCpu:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def by_group(self) -> dict[str, float]:
        """CPU seconds per thread group (last sample of each thread)."""
        groups: dict[str, float] = defaultdict(float)
        for tid, cpu in self.cpu_s.items():
            name = self.names[tid]
            group = ("recorder unit threads" if name.startswith("recorder-") else
                     "recorder engine (main thread)" if name == "MainThread" else
                     "simulators" if name in ("pty-gyro", "can-gyro") else "other")
            groups[group] += cpu
        return dict(groups)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=20_000, help="samples per unit")
    parser.add_argument("--rate", type=float, default=2000.0, help="sample rate, Hz")
    parser.add_argument("--warp", type=float, default=1.0, help="time-warp factor")
    args = parser.parse_args()
    duration_s = args.samples / args.rate
    with tempfile.TemporaryDirectory() as tmp:
        recorder = Recorder(RunConfig(unit_urls(args.rate, args.warp), duration_s,
                                      Path(tmp) / "bench.h5"))
        recorder.prepare()
        cpu0, t0 = time.process_time(), time.monotonic()
        with ThreadCpu() as threads:
            stop = recorder.run()
        wall_s, cpu_s = time.monotonic() - t0, time.process_time() - cpu0
        size = recorder.path.stat().st_size
    recorded = sum(t.samples_recorded for t in stop.totals)
    sent = sum(t.samples_sent or 0 for t in stop.totals)
    missing = sum(t.samples_missing_declared for t in stop.totals)
    print(f"{len(stop.totals)} units x {args.rate:g} Hz x 3 axes, warp x{args.warp:g}, "
          f"{args.samples} samples each ({duration_s:g} s simulated, ideal "
          f"{duration_s / args.warp:.2f} s wall); stop: {stop.reason}")
    for proto, t in zip(PROTOCOLS, stop.totals, strict=True):
        print(f"  {proto:15s} recorded {t.samples_recorded:7d}  declared missing "
              f"{t.samples_missing_declared:5d}  sent {t.samples_sent:7d}  dropped "
              f"{(t.samples_sent or 0) - t.samples_recorded - t.samples_missing_declared:3d}")
    print(f"recorded {recorded} samples in {wall_s:.2f} s wall: {recorded / wall_s:,.0f} "
          f"samples/s ({recorded * 3 / wall_s:,.0f} values/s), target "
          f"{len(stop.totals) * args.rate * args.warp:,.0f} samples/s")
    print(f"dropped {sent - recorded - missing} (sent {sent}, declared missing {missing}); "
          f"file {size / 1e6:.1f} MB")
    print(f"process CPU {cpu_s:.2f} s = {cpu_s / wall_s:.0%} of one core "
          f"({cpu_s / wall_s / (os.cpu_count() or 1):.0%} of {os.cpu_count()} cores)")
    for group, seconds in sorted(threads.by_group().items(), key=lambda kv: -kv[1]):
        print(f"  {group:32s} {seconds:6.2f} s CPU = {seconds / wall_s:5.0%} of one core")


if __name__ == "__main__":
    main()
