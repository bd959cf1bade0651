"""``station record``: record one or several gyros at once into one HDF5 run file.

Example::

    station record --profile VG951 --unit 'sim+serial://VG951?rate=10&warp=100' \\
        --unit 'sim+can://STIM300?rate=10&warp=100' --duration 12h --out runs/

Stops at the duration (on each unit's own time base), on Ctrl-C or on SIGTERM, with
the file closed and the stop reason recorded. ``--json-summary`` ends by printing one
JSON object per unit: ``{"unit", "samples_recorded", "samples_missing_declared",
"samples_missing_low", "samples_missing_high", "samples_sent", "gaps", "crc_errors",
"reconnects", "file"}`` (``samples_sent``: for a simulated unit the simulator's own count
of generated samples, null for hardware; it lies within ``samples_recorded`` plus the low
and the high count of missing samples, which differ only where a counter's wrap count
was not certain). Each unit runs in a process of its own; at the end the CPU time of each
(reading, and its simulator) and of the recorder's process is printed (to stderr and
before the summary with ``--json-summary``, so that the summary ends the output even with
stderr merged into stdout; not with ``--quiet``). A fault that stops the run early (a full
disk or a failed write, the output folder or file removed, a unit's device or its
process lost) ends with one line saying what happened, what the file kept (each unit's
samples up to its last flush, the file, and ``station recover FILE`` if it needs
closing) and exit status 3; input refused before anything is recorded is exit status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
from pathlib import Path

from station.commands import COMMAND_HELP, record_sequence
from station.commands.record_sequence import add_sequence_arguments
from station.recording.progress import ProgressLine


def main(argv: list[str] | None = None) -> int:
    """``python -m station.commands.record ARGS``: the recorder alone, without the other
    commands' imports (how a TUI or a test starts a recorder process)."""
    from station.errors import StationError
    from station.logs import configure_logging
    from station.recording.unit_process import start_unit_server

    configure_logging()
    parser = argparse.ArgumentParser(prog="station record")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["record", *(sys.argv[1:] if argv is None else argv)])
    start_unit_server()  # (its imports overlap the recorder's)
    try:
        return run(args)
    except StationError as exc:
        print(f"station record: error: {exc}", file=sys.stderr)
        return 2


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``record`` sub-command."""
    p = sub.add_parser("record", help=COMMAND_HELP["record"],
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
    p.add_argument("--status", type=Path, default=None, metavar="FILE",
                   help="keep the recorder's state in this JSON file: recording (and the run "
                        "file), or refused with each unit's problem (how the TUI follows a "
                        "recorder it started)")
    p.add_argument("--check", action="store_true",
                   help="only check the units: open each, check it against the profile, wait "
                        "for its first sample, release it; write nothing and print the status "
                        "as JSON (exit status 2 if a unit fails)")
    p.add_argument("--quiet", action="store_true", help="no progress line")
    add_sequence_arguments(p)
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Prepare (refusing a bad configuration), record, print the summary."""
    if args.sequence is not None:
        return record_sequence.run(args)
    if args.power or args.chamber:
        from station.errors import UsageError

        raise UsageError("--power and --chamber belong to --sequence NAME")
    from station.services.record import RecordRequest, check_units, record, write_status

    request = RecordRequest(tuple(args.unit), args.duration, args.out, args.profile,
                            args.operator, args.lot, args.bench, args.flush_interval,
                            args.reserve_mb)
    if args.check:
        status = check_units(request)
        write_status(args.status, status)
        print(json.dumps(status.as_json()))
        return 0 if status.state == "checked" else 2

    def started(path: Path, n_units: int) -> None:
        print(f"recording {n_units} unit(s) to {path}", file=sys.stderr)

    subscribers = [] if args.quiet else [ProgressLine(sys.stderr)]
    outcome = record(request, subscribers, status=args.status, on_start=started)
    if args.json_summary:
        if not args.quiet:  # before the summary, which ends the output, stderr merged or not
            print("\n".join(outcome.cpu_lines()), file=sys.stderr, flush=True)
        for unit in outcome.units:
            print(json.dumps(dataclasses.asdict(unit)))
        sys.stdout.flush()
    else:
        from station.model.wording import plural

        print(f"{outcome.path}: stopped ({outcome.stop.reason})")
        for u in outcome.units:
            sent_text = "" if u.samples_sent is None else f", sent {u.samples_sent}"
            bounds = ("" if u.samples_missing_low == u.samples_missing_high else
                      f" (between {u.samples_missing_low} and {u.samples_missing_high}: wrap "
                      f"counts not certain)")
            print(f"  {u.unit}: recorded {u.samples_recorded}, declared missing "
                  f"{u.samples_missing_declared}{bounds} in {plural(u.gaps, 'gap')}"
                  f"{sent_text}, CRC errors {u.crc_errors}, reconnects {u.reconnects}")
        if not args.quiet:
            print("\n".join(outcome.cpu_lines()))
    message = outcome.fault_message()
    if message:
        print(f"station record: {message}", file=sys.stderr)
    if outcome.close_failed:
        # HDF5 could not close the file (a write failed on the full disk) and would try
        # again, and fail, at exit: leave now, as a killed recorder would (everything
        # committed is intact; `station recover` closes the file).
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(outcome.exit_status)
    return outcome.exit_status


if __name__ == "__main__":
    sys.exit(main())
