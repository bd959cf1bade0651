"""A raw-CAN unit recorded from python-can's in-process ``virtual`` bus and from a node in
another process on the ``udp_multicast`` bus, side by side in one run.

For each bus the real recorder records the same number of samples from one simulated
node (shared layout, no faults) and the benchmark reports, as ratios of the two buses:
the recorder process's CPU per sample (with the virtual bus the simulated node's thread
runs in that process too; on udp_multicast it runs in its own, as a gyro on a bench
does), wall time per sample, and that recorded + declared missing == sent (must hold on
both). Times vary with the machine; compare the ratios.

Run::

    python benchmarks/bench_can_bus.py                      # 2 kHz, 20000 samples
    python benchmarks/bench_can_bus.py --rate 1000 --samples 10000
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path

from station.recording.recorder import Recorder, RunConfig


def _self_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def record(bus: str, rate_hz: float, n_samples: int, folder: Path) -> dict[str, float]:
    """Record ``n_samples`` from one node on ``bus``; returns counts, CPU and wall s."""
    url = f"sim+can://STIM300?layout=shared&interface={bus}&rate={rate_hz:g}&seed=4"
    recorder = Recorder(RunConfig((url,), n_samples / rate_hz, folder / f"{bus}.h5"))
    recorder.prepare()  # opens the unit (and starts a node process) before timing
    cpu0, wall0 = _self_cpu_s(), time.perf_counter()
    stop = recorder.run()
    cpu, wall = _self_cpu_s() - cpu0, time.perf_counter() - wall0
    totals = stop.totals[0]
    return {"recorded": totals.samples_recorded, "missing": totals.samples_missing_declared,
            "sent": totals.samples_sent or 0, "cpu_s": cpu, "wall_s": wall}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rate", type=float, default=2000.0, help="sample rate, Hz")
    parser.add_argument("--samples", type=int, default=20000, help="samples per bus")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        runs = {bus: record(bus, args.rate, args.samples, Path(tmp))
                for bus in ("virtual", "udp_multicast")}
    print(f"one raw-CAN node, {args.rate:g} Hz, {args.samples} samples per bus")
    print(f"{'bus':<14} {'recorded':>9} {'missing':>8} {'sent':>8} {'accounted':>9} "
          f"{'rec. CPU/sample':>16} {'wall/sample':>12}")
    base = runs["virtual"]
    for bus, r in runs.items():
        n = max(r["recorded"], 1)
        accounted = "yes" if r["recorded"] + r["missing"] == r["sent"] else "NO"
        print(
            f"{bus:<14} {r['recorded']:>9.0f} {r['missing']:>8.0f} {r['sent']:>8.0f} "
            f"{accounted:>9} "
            f"{(r['cpu_s'] / n) / (base['cpu_s'] / max(base['recorded'], 1)):>15.2f}x "
            f"{(r['wall_s'] / n) / (base['wall_s'] / max(base['recorded'], 1)):>11.2f}x"
        )
    print("(ratios to the virtual bus; recorder-process CPU excludes the node's own process)")


if __name__ == "__main__":
    main()
