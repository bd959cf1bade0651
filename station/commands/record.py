"""``station record``: record one or several gyros at once into one HDF5 run file.

Example::

    station record --profile VG951 --unit sim+serial://VG951?warp=100 \\
        --unit sim+can://STIM300?rate=500 --duration 12h --out runs/

Stops at the duration (on each unit's own time base), on Ctrl-C or on SIGTERM, with
the file closed and the stop reason recorded. ``--json-summary`` ends by printing one
JSON object per unit: ``{"unit", "samples_recorded", "samples_missing_declared",
"samples_sent", "gaps", "crc_errors", "reconnects", "file"}`` (``samples_sent``: for a
simulated unit the simulator's own count of generated samples, null for hardware).
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

from station.errors import UsageError
from station.model.documents import RunStop
from station.progress import ProgressLine
from station.recorder import Recorder, RunConfig, parse_duration


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


@contextmanager
def stop_on_signals(recorder: Recorder) -> Iterator[None]:
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
                    "samples_missing_declared": c.missing, "samples_sent": t.samples_sent,
                    "gaps": c.gaps, "crc_errors": c.crc_errors, "reconnects": c.reconnects,
                    "file": str(recorder.path)})
    return out


def run(args: argparse.Namespace) -> int:
    """Prepare (refusing a bad configuration), record, print the summary."""
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
            print(f"  {obj['unit']}: recorded {obj['samples_recorded']}, declared missing "
                  f"{obj['samples_missing_declared']} in {obj['gaps']} gaps{sent_text}, "
                  f"CRC errors {obj['crc_errors']}, reconnects {obj['reconnects']}")
    errors = [w for w in recorder.workers if w.error is not None]
    for w in errors:
        print(f"station record: {w.unit_id} ended on an error: {w.error}", file=sys.stderr)
    code = 1 if errors or stop.reason.startswith("disk full") else 0
    if recorder.writer is not None and recorder.writer.close_failed:
        # HDF5 could not close the file (its last flush failed on the full disk) and would
        # crash the interpreter at exit trying again: leave now, as a killed recorder would
        # (everything committed is intact; `station recover` closes the file).
        print(f"station record: {stop.reason}; the file could not be closed: run "
              f"`station recover {recorder.path}` once there is space", file=sys.stderr)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


if __name__ == "__main__":
    sys.exit(main())
