"""Peak memory of ``station analyze``, ``grade`` or ``report`` on a run file of a given length.

``python benchmarks/bench_memory.py --hours H --rate-hz R --axes A [--command C]`` writes a
simulated run file of one unit (H hours at R Hz, A axes: white rate noise plus a rate
random walk) with the recorder's writer, a second of samples at a time (bounded memory),
then runs the command in a child process and prints one line::

    peak_rss_mb=... seconds=...

the child's peak resident memory (the VmHWM of its own address space, file pages it maps
included) and its wall time. ``--command`` is ``analyze`` (``station analyze FILE
--json``, the default), ``grade`` (``station grade FILE --json --no-store``) or ``report``
(``station report FILE --format pdf --no-store``), ``davar`` (``station davar FILE --window-s
W --json``, W an hour or a quarter of a shorter run) or ``reconcile`` (``station reconcile
FILE --model mems-typical --json --runs 5 --axis x``); ``--method gmwm`` adds ``--method
gmwm`` to analyze (the GMWM beside the Allan fit) or report (its GMWM page); grade and
report use a profile written beside the run: ADIS16405's figures and limits on the run's
axes, its warm-up cut to a tenth of the run. ``--keep FILE`` keeps the run file (and reuses
it when it exists); ``--long-samples N`` makes records longer than N samples count as long
(the block-wise path, :mod:`analysis.allan.blocks`), so a short run exercises it.
``--compare`` (every command but report) runs the command a second time with every record
read in one piece and appends ``max_rel_diff=...``: the largest relative difference between
the numbers of the two JSON documents.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from devices.protocols import DeviceDescription
from station.model.documents import (
    Descriptor,
    EventBatch,
    LogEntry,
    RunStart,
    RunStop,
    data_keys,
    utc_now,
)
from station.storage.hdf5_writer import RunFileWriter

#: Samples written per batch (and per flush of the writer).
BATCH = 1 << 18
#: Samples each gap of ``--gaps`` loses.
GAP_SAMPLES = 1000

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
import analysis.allan.blocks as blocks
LONG = {long!r}
if LONG is not None:
    blocks.LONG_SAMPLES = LONG
    blocks.BLOCK_SAMPLES = max(1024, LONG // 4)
from station.cli import main
sys.exit(main({argv!r}))
"""

#: What the profile of ``grade`` and ``report`` takes from (its figures and limits).
PROFILE = Path(__file__).resolve().parents[1] / "profiles" / "ADIS16405.toml"
COMMANDS = ("analyze", "grade", "report", "davar", "reconcile")


def write_profile(path: Path, axes: tuple[str, ...], warmup_s: float) -> Path:
    """ADIS16405's profile with ``axes`` and ``warmup_s`` (TOML at ``path``)."""
    text = PROFILE.read_text()
    text = re.sub(r"(?m)^axes = .*$", "axes = " + json.dumps(list(axes)), text)
    text = re.sub(r"(?m)^warmup_s = .*$", f"warmup_s = {warmup_s!r}", text)
    # the run is a gyro's: the accelerometer figures' tables go (a profile that limits an
    # accelerometer figure refuses a record without accelerometers)
    text = re.sub(r"(?ms)^\[figures\.accel_[^\]]*\]\n.*?(?=^\[|\Z)", "", text)
    path.write_text(text)
    return path


def command_argv(command: str, run: Path, profile: Path, out_dir: Path,
                 window_s: float = 3600.0) -> list[str]:
    """``station`` arguments of ``command`` on ``run`` (``window_s``: the DAVAR's window)."""
    if command == "analyze":
        return ["analyze", str(run), "--json"]
    if command == "grade":
        return ["grade", str(run), "--json", "--no-store", "--profile", str(profile)]
    if command == "davar":
        return ["davar", str(run), "--window-s", f"{window_s:g}", "--json"]
    if command == "reconcile":
        return ["reconcile", str(run), "--model", "mems-typical", "--json", "--runs", "5",
                "--axis", "x"]
    return ["report", str(run), "--format", "pdf", "--no-store", "--profile", str(profile),
            "--out", str(out_dir)]


def numbers(doc: object, where: str = "") -> dict[str, float]:
    """Every number of a JSON document by its path (``axes/0/fit/N``)."""
    if isinstance(doc, dict | list):
        items = doc.items() if isinstance(doc, dict) else enumerate(doc)
        return {k: v for key, value in items for k, v in numbers(value, f"{where}/{key}").items()}
    if isinstance(doc, bool) or not isinstance(doc, int | float):
        return {}
    return {where: float(doc)}


def max_relative_difference(a: str, b: str) -> float:
    """Largest relative difference between the numbers of two JSON documents (inf when
    they hold different numbers or NaN in one place only); times of day are left out."""
    na, nb = numbers(json.loads(a)), numbers(json.loads(b))
    if na.keys() != nb.keys():
        return math.inf
    worst = 0.0
    for key, x in na.items():
        y = nb[key]
        if key.endswith(("graded_utc", "seconds")) or x == y or (math.isnan(x) and math.isnan(y)):
            continue
        worst = max(worst, abs(x - y) / max(abs(x), abs(y)))
    return worst


def write_run(path: Path, hours: float, rate_hz: float, n_axes: int, seed: int = 1,
              gaps: int = 0) -> int:
    """Write a simulated one-unit run file; returns its samples per axis (on the time grid).
    ``gaps`` batches spread over the run lose their first :data:`GAP_SAMPLES` samples (a
    gap the recorder counted by the device counter, logged as the recorder logs it)."""
    n = int(round(hours * 3600 * rate_hz))
    n_batches = -(-n // BATCH)
    gapped = {int(k) for k in np.linspace(0, n_batches, gaps + 2)[1:-1]} if gaps else set()
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
        log: tuple[LogEntry, ...] = ()
        if seq in gapped and b - a > GAP_SAMPLES:
            rate, counter = rate[GAP_SAMPLES:], counter[GAP_SAMPLES:]
            log = (LogEntry("gap", a / rate_hz, 1, GAP_SAMPLES, a - 1, "counter"),)
        writer(EventBatch("unit1", seq, rate, counter, counter / rate_hz,
                          np.zeros(len(counter), np.uint32), log=log))
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


def measure(argv: list[str], long_samples: int | None) -> tuple[float, float, str]:
    """(peak RSS in MB, wall seconds, stdout) of ``station ARGV`` in a child."""
    seconds, peak, out = run_child(CHILD.format(long=long_samples, argv=argv))
    return peak, seconds, out


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
    p.add_argument("--gaps", type=int, default=0, metavar="K",
                   help=f"K gaps of {GAP_SAMPLES} samples spread over the run (default 0)")
    p.add_argument("--command", choices=COMMANDS, default="analyze")
    p.add_argument("--method", choices=("gmwm",), default=None,
                   help="analyze or report: add --method gmwm")
    p.add_argument("--compare", action="store_true",
                   help="also run it with records read in one piece; print max_rel_diff")
    args = p.parse_args(argv)
    if not 1 <= args.axes <= 6 or args.hours <= 0 or args.rate_hz <= 0:
        p.error("--hours and --rate-hz must be positive, --axes 1..6")
    if args.method and args.command not in ("analyze", "report"):
        p.error("--method applies to analyze and report")
    if args.compare and args.command == "report":
        p.error("--compare applies to the commands that print JSON, not report")
    with tempfile.TemporaryDirectory() as tmp:
        path = args.keep or Path(tmp) / "run.h5"
        if not path.exists():
            write_run(path, args.hours, args.rate_hz, args.axes, gaps=args.gaps)
        profile = write_profile(Path(tmp) / "profile.toml", tuple("xyzuvw"[: args.axes]),
                                min(300.0, args.hours * 360.0))
        command = command_argv(args.command, path, profile, Path(tmp),
                               window_s=min(3600.0, args.hours * 900.0))
        if args.method:
            command += ["--method", args.method]
        peak, seconds, out = measure(command, args.long_samples)
        line = f"peak_rss_mb={peak:.0f} seconds={seconds:.1f}"
        if args.compare:
            _, _, whole = measure(command, 1 << 62)
            line += f" max_rel_diff={max_relative_difference(out, whole):.3g}"
    print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
