"""Peak memory of ``station analyze`` on a run file of a given length.

``python benchmarks/bench_memory.py --hours H --rate-hz R --axes A`` writes a simulated run
file of one unit (H hours at R Hz, A axes: white rate noise plus a rate random walk) with
the recorder's writer, a second of samples at a time (bounded memory), then runs
``station analyze FILE --json`` in a child process and prints one line::

    peak_rss_mb=... seconds=...

the child's peak resident memory (the VmHWM of its own address space, file pages it maps
included) and its wall time. ``--keep FILE`` keeps the run file (and reuses it when it
exists); ``--long-samples N`` makes records longer than N samples count as long (the
block-wise path, :mod:`analysis.blocks`), so a short run exercises it.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from devices.protocols import DeviceDescription
from station.model.documents import Descriptor, EventBatch, RunStart, RunStop, data_keys, utc_now
from station.storage.hdf5_writer import RunFileWriter

#: Samples written per batch (and per flush of the writer).
BATCH = 1 << 18

#: Printed by a child at exit: its own peak RSS (VmHWM of its address space). A child's
#: ru_maxrss also counts the parent's peak where the child was forked (or vforked) from it.
HWM = """
import atexit, sys
def _hwm():
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                sys.stderr.write("\\nVmHWM_kB=" + line.split()[1] + "\\n")
    except OSError:
        pass
atexit.register(_hwm)
"""

CHILD = HWM + """
import analysis.blocks as blocks
if {long!r} is not None:
    blocks.LONG_SAMPLES = {long!r}
    blocks.BLOCK_SAMPLES = max(1024, {long!r} // 4)
from station.cli import main
sys.exit(main(["analyze", {path!r}, "--json"]))
"""


def write_run(path: Path, hours: float, rate_hz: float, n_axes: int, seed: int = 1) -> int:
    """Write a simulated one-unit run file; returns its samples per axis."""
    n = int(round(hours * 3600 * rate_hz))
    axes = tuple("xyzuvw"[:n_axes])
    desc = DeviceDescription(
        model="SIM",
        serial_number="MEM1",
        protocol="stim300",
        transport="serial",
        axes=axes,
        sample_rate_hz=rate_hz,
        has_counter=True,
        counter_modulus=None,
        has_device_time=False,
        has_temperature=False,
        settings=(),
    )
    writer = RunFileWriter(path, flush_interval_s=1.0, sync=False)
    writer(RunStart("bench-memory", utc_now(), ("unit1",), hours * 3600, str(path)))
    writer(
        Descriptor("unit1", "sim+serial://MEM1", desc, data_keys(desc), utc_now(), "simulated", 1.0)
    )
    rng = np.random.default_rng(seed)
    walk = np.zeros(n_axes)
    for seq, a in enumerate(range(0, n, BATCH)):
        b = min(a + BATCH, n)
        steps = rng.standard_normal((b - a, n_axes)) * 1e-6
        drift = walk + np.cumsum(steps, axis=0)
        walk = drift[-1]
        rate = 0.002 + 0.01 * rng.standard_normal((b - a, n_axes)) + drift
        counter = np.arange(a, b, dtype=np.int64)
        writer(
            EventBatch("unit1", seq, rate, counter, counter / rate_hz, np.zeros(b - a, np.uint32))
        )
        writer.flush()
    writer(RunStop(utc_now(), "duration"))
    return n


def run_child(code: str) -> tuple[float, float, str]:
    """(wall seconds, peak RSS in MB, stdout) of ``python -c code`` in a fresh process; the
    peak is that child's own (its VmHWM, printed at exit by :data:`HWM` when ``code``
    starts with it; else its ``ru_maxrss``), file pages it maps included.

    Raises
    ------
    SystemExit
        The child failed (its stderr's end in the message).
    """
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-c", code], stdout=out, stderr=err, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        errors = err.read()
        if proc.returncode != 0:
            raise SystemExit(f"child failed ({proc.returncode}): {errors[-2000:]}")
        hwm = re.findall(r"VmHWM_kB=(\d+)", errors)
        peak_kb = int(hwm[-1]) if hwm else usage.ru_maxrss
        return seconds, peak_kb / 1024.0, out.read()


def measure(path: Path, long_samples: int | None) -> tuple[float, float]:
    """(peak RSS in MB, wall seconds) of ``station analyze FILE --json`` in a child."""
    seconds, peak, _ = run_child(CHILD.format(long=long_samples, path=str(path)))
    return peak, seconds


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--hours", type=float, required=True)
    p.add_argument("--rate-hz", type=float, required=True)
    p.add_argument("--axes", type=int, required=True)
    p.add_argument(
        "--keep",
        type=Path,
        default=None,
        metavar="FILE",
        help="keep the run file here (reused when it exists)",
    )
    p.add_argument(
        "--long-samples",
        type=int,
        default=None,
        metavar="N",
        help="records longer than N samples take the block-wise path",
    )
    args = p.parse_args(argv)
    if not 1 <= args.axes <= 6 or args.hours <= 0 or args.rate_hz <= 0:
        p.error("--hours and --rate-hz must be positive, --axes 1..6")
    with tempfile.TemporaryDirectory() as tmp:
        path = args.keep or Path(tmp) / "run.h5"
        if not path.exists():
            write_run(path, args.hours, args.rate_hz, args.axes)
        peak, seconds = measure(path, args.long_samples)
    print(f"peak_rss_mb={peak:.0f} seconds={seconds:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
