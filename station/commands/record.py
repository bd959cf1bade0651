"""``station record``: record one or several gyros at once into one HDF5 run file.

Example::

    station record --profile VG951 --unit sim+serial://VG951?warp=100 \\
        --unit sim+can://STIM300?rate=500 --duration 12h --out runs/

Stops at the duration (on each unit's own time base), on Ctrl-C or on SIGTERM, with
the file closed and the stop reason recorded. ``--json-summary`` ends by printing one
JSON object per unit: ``{"unit", "samples_recorded", "samples_missing_declared",
"samples_missing_low", "samples_missing_high", "samples_sent", "gaps", "crc_errors",
"reconnects", "file"}`` (``samples_sent``: for a simulated unit the simulator's own count
of generated samples, null for hardware; it lies within ``samples_recorded`` plus the low
and the high count of missing samples, which differ only where a counter's wrap count
was not certain). Each unit runs in a process of its own; at the end the CPU time of each
(reading, and its simulator) and of the recorder's process is printed (to stderr with
``--json-summary``; not with ``--quiet``). A full disk stops the run with one message,
exit status 1.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import FrameType
from typing import Protocol

from station.commands import record_sequence
from station.commands.record_sequence import add_sequence_arguments
from station.errors import UsageError
from station.model.documents import RunStop
from station.progress import ProgressLine
from station.recorder import Recorder, RunConfig, parse_duration
from station.unit_process import cpu_cores


def main(argv: list[str] | None = None) -> int:
    """``python -m station.commands.record ARGS``: the recorder alone, without the other
    commands' imports (how a TUI or a test starts a recorder process)."""
    from station.errors import StationError
    from station.logs import configure_logging

    configure_logging()
    parser = argparse.ArgumentParser(prog="station record")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["record", *(sys.argv[1:] if argv is None else argv)])
    try:
        return run(args)
    except StationError as exc:
        print(f"station record: error: {exc}", file=sys.stderr)
        return 2


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``record`` sub-command."""
    p = sub.add_parser("record", help="record gyros into an HDF5 run file",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--profile", default=None,
                   help="product profile (name in profiles/ or a TOML path); optional for "
                        "simulated units")
    p.add_argument("--unit", action="append", default=[], metavar="DEVICE_URL",
                   help="a device URL; repeat for several units (default: the profile's)")
    p.add_argument("--duration", default=None, metavar="D",
                   help="run length: 12h, 1h30m, 90s, or seconds (default: the profile's)")
    p.add_argument("--out", type=Path, default=Path("runs"),
                   help="folder for the run file, or a .h5 path (default ./runs)")
    p.add_argument("--operator", default="", help="who runs the test (run metadata)")
    p.add_argument("--lot", default="", help="production lot (run metadata)")
    p.add_argument("--bench", default=None, metavar="FILE",
                   help="bench file (latitude, axis directions; see docs/bench.md): kept in the "
                        "run file for the bias figures, and simulated units add the Earth rate")
    p.add_argument("--flush-interval", type=float, default=0.5, metavar="S",
                   help="longest time between file flushes, s (<= 1; default 0.5)")
    p.add_argument("--reserve-mb", type=float, default=None, metavar="MB",
                   help="stop cleanly when less than this can still be written "
                        "(default 8 MB + 10 s of data)")
    p.add_argument("--json-summary", action="store_true",
                   help="print one JSON object per unit at the end (and nothing else on stdout)")
    p.add_argument("--quiet", action="store_true", help="no progress line")
    add_sequence_arguments(p)
    p.set_defaults(handler=run)


def config_from_args(args: argparse.Namespace) -> RunConfig:
    """The run configuration the arguments name (the profile is loaded here)."""
    profile = None
    if args.profile is not None:
        from station.model.profiles import load_profile

        profile = load_profile(args.profile)
    urls = list(args.unit)
    if not urls and profile is not None and profile.transport.get("url"):
        urls = [str(profile.transport["url"])]
    if args.duration is not None:
        duration_s = parse_duration(args.duration)
    elif profile is not None:
        duration_s = profile.duration_s
    else:
        raise UsageError("give --duration (e.g. 12h) or a --profile that has one")
    if not 0 < args.flush_interval <= 1.0:
        raise UsageError("--flush-interval must be in (0, 1] s")
    reserve = None if args.reserve_mb is None else int(args.reserve_mb * 1e6)
    bench_json = ""
    if args.bench is not None:
        from station.model.bench import load_bench

        bench = load_bench(args.bench)
        urls, bench_json = [bench.sim_url(u) for u in urls], bench.as_json()
    return RunConfig(tuple(urls), duration_s, args.out, profile=profile,
                     operator=args.operator, lot=args.lot,
                     flush_interval_s=args.flush_interval, reserve_bytes=reserve,
                     bench_json=bench_json)


class Stoppable(Protocol):
    """What Ctrl-C stops cleanly: a recorder, a sequence."""

    def request_stop(self, reason: str) -> None: ...


@contextmanager
def stop_on_signals(recorder: Stoppable) -> Iterator[None]:
    """Turn Ctrl-C and SIGTERM into a clean stop of ``recorder`` while inside."""
    reasons = {signal.SIGINT: "interrupted (Ctrl-C)", signal.SIGTERM: "terminated (SIGTERM)"}

    def handler(signum: int, frame: FrameType | None) -> None:
        recorder.request_stop(reasons[signal.Signals(signum)])

    old = {s: signal.signal(s, handler) for s in reasons}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def json_summary(recorder: Recorder, stop: RunStop) -> list[dict]:
    """The ``--json-summary`` objects: what the file holds (its committed data) per unit."""
    assert recorder.writer is not None
    out = []
    for t in stop.totals:
        c = recorder.writer.committed[t.unit_id]
        out.append({"unit": t.url, "samples_recorded": c.samples,
                    "samples_missing_declared": c.missing,
                    "samples_missing_low": c.missing_low,
                    "samples_missing_high": c.missing_high, "samples_sent": t.samples_sent,
                    "gaps": c.gaps, "crc_errors": c.crc_errors, "reconnects": c.reconnects,
                    "file": str(recorder.path)})
    return out


def cpu_lines(recorder: Recorder, stop: RunStop) -> list[str]:
    """CPU time per unit (its process: reader and simulator) and of the recorder's own
    process (documents, HDF5), as shares of one core over the run's wall time."""
    wall = max(recorder.wall_s, 1e-9)
    lines = [f"CPU over {wall:.1f} s of wall time ({cpu_cores()} cores here):"]
    for t in stop.totals:
        sim = max(0.0, t.cpu_s - t.reader_cpu_s)
        lines.append(f"  {t.unit_id}: {t.cpu_s:.2f} s = {t.cpu_s / wall:.0%} of a core "
                     f"(reading {t.reader_cpu_s:.2f} s, simulator and the rest {sim:.2f} s)")
    lines.append(f"  recorder process (documents, HDF5 writer): {recorder.engine_cpu_s:.2f} s = "
                 f"{recorder.engine_cpu_s / wall:.0%} of a core")
    return lines


def run(args: argparse.Namespace) -> int:
    """Prepare (refusing a bad configuration), record, print the summary."""
    if args.sequence is not None:
        return record_sequence.run(args)
    if args.power or args.chamber:
        raise UsageError("--power and --chamber belong to --sequence NAME")
    config = config_from_args(args)
    subscribers = [] if args.quiet else [ProgressLine(sys.stderr)]
    recorder = Recorder(config, subscribers)
    with stop_on_signals(recorder):
        recorder.prepare()
        print(f"recording {len(recorder.workers)} unit(s) to {recorder.path}", file=sys.stderr)
        stop = recorder.run()
    summary = json_summary(recorder, stop)
    if args.json_summary:
        for obj in summary:
            print(json.dumps(obj))
    else:
        print(f"{recorder.path}: stopped ({stop.reason})")
        for obj in summary:
            sent_text = "" if obj["samples_sent"] is None else f", sent {obj['samples_sent']}"
            bounds = ("" if obj["samples_missing_low"] == obj["samples_missing_high"] else
                      f" (between {obj['samples_missing_low']} and "
                      f"{obj['samples_missing_high']}: wrap counts not certain)")
            print(f"  {obj['unit']}: recorded {obj['samples_recorded']}, declared missing "
                  f"{obj['samples_missing_declared']}{bounds} in {obj['gaps']} gaps"
                  f"{sent_text}, CRC errors {obj['crc_errors']}, reconnects "
                  f"{obj['reconnects']}")
    if not args.quiet:
        print("\n".join(cpu_lines(recorder, stop)),
              file=sys.stderr if args.json_summary else sys.stdout)
    for w in recorder.workers:
        if w.error:
            print(f"station record: {w.unit_id} ended on an error: {w.error}", file=sys.stderr)
    writer = recorder.writer
    failed = writer is not None and writer.failed is not None
    code = 1 if failed or any(w.error for w in recorder.workers) or \
        stop.reason.startswith(("disk full", "write error")) else 0
    if not failed and stop.reason.startswith(("disk full", "write error")):
        print(f"station record: the run stopped early ({stop.reason}); {recorder.path} is "
              f"closed with every sample received: free some space before the next run",
              file=sys.stderr)
    if failed:
        assert writer is not None
        lost = ", ".join(f"{t.unit_id} {writer.uncommitted(t.unit_id)}" for t in stop.totals)
        print(f"station record: {writer.failed}. The run stopped; every sample committed "
              f"before is intact (samples received or declared missing after that, not "
              f"written: {lost}). Free some space, then run `station recover "
              f"{recorder.path}`", file=sys.stderr)
    if writer is not None and writer.close_failed:
        # HDF5 could not close the file (a write failed on the full disk) and would try
        # again, and fail, at exit: leave now, as a killed recorder would (everything
        # committed is intact; `station recover` closes the file).
        if not failed:
            print(f"station record: {stop.reason}; the file could not be closed: run "
                  f"`station recover {recorder.path}` once there is space", file=sys.stderr)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


if __name__ == "__main__":
    sys.exit(main())
