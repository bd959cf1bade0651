"""``station record --sequence NAME``: a profile's test sequence on every unit of the fixture.

Example (two simulated units on a simulated fixture, the profile's ``turn_on`` sequence)::

    station record --sequence turn_on --profile VG951 --power sim \\
        --unit "sim+serial://VG951?protocol=xbus&rate=10&warp=100&seed=1" \\
        --unit "sim+serial://VG951?protocol=xbus&rate=10&warp=100&seed=2" --out runs/

Each ``record`` step is a run file of its own (a segment, in ``NAME.segments/`` beside
the sequence file); the sequence file keeps the journal: steps, switch-ons, set points,
chamber readings, interruptions. Stopped (Ctrl-C, SIGTERM) or killed at any step, the
same command resumes it where it was. ``--json-summary`` prints one JSON object per unit:
``{"unit", "unit_id", "file", "sequence", "state", "cycles", "turn_ons", "segments",
"interruptions", "samples_recorded", "samples_missing_declared"}``. Exit status: 0 when
every step ran, 1 when it stopped early or failed (the message says why), 2 for bad
arguments.
"""

from __future__ import annotations

import argparse
import json
import sys

from station.errors import UsageError


def add_sequence_arguments(p: argparse.ArgumentParser) -> None:
    """``--sequence``, ``--power``, ``--chamber``."""
    p.add_argument("--sequence", default=None, metavar="NAME",
                   help="run the profile's [sequence.NAME] (turn-on, warm-up, temperature "
                        "tests) instead of one recording")
    p.add_argument("--power", action="append", default=[], metavar="URL",
                   help="with --sequence: each unit's supply switch, in unit order "
                        "(modbus+tcp://HOST:PORT/UNIT?coil=N), or 'sim' for a simulated "
                        "fixture wired to simulated units")
    p.add_argument("--chamber", default=None, metavar="URL",
                   help="with --sequence: the temperature chamber "
                        "(modbus+tcp://HOST:PORT/UNIT?setpoint=0&measured=0), or 'sim'")


def run(args: argparse.Namespace) -> int:
    """Prepare (refusing what the sequence cannot run with), run or resume, summarize."""
    from station.recording.progress import ProgressLine
    from station.recording.sequence_runner import SequenceError
    from station.services.record import stop_on_signals
    from station.services.sequence import SequenceRequest, prepare_sequence, sequence_summary

    if args.profile is None:
        raise UsageError("--sequence needs --profile (the profile defines the sequence)")
    if args.duration is not None:
        raise UsageError("--sequence takes its durations from the profile's steps; drop "
                         "--duration")
    if getattr(args, "check", False) or getattr(args, "status", None) is not None:
        raise UsageError("--check and --status belong to a single recording, not --sequence")
    power = tuple(args.power)
    if "sim" in power and power != ("sim",):
        raise UsageError("--power sim stands for every unit's switch: give it once")
    request = SequenceRequest(args.sequence, args.profile, tuple(args.unit), power,
                              args.chamber, args.out, args.operator, args.lot, args.bench)

    def subscribers(step: object) -> list:
        return [] if args.quiet else [ProgressLine(sys.stderr, plain_interval_s=10.0)]

    def notify(text: str) -> None:
        if not args.quiet:
            print(f"station record: {text}", file=sys.stderr)

    with prepare_sequence(request, subscribers=subscribers, notify=notify) as prepared:
        run = prepared.runner.run
        verb = "resuming" if prepared.resumed else "running"
        print(f"{verb} sequence {prepared.spec.name} ({len(prepared.spec.steps)} steps) on "
              f"{len(request.units)} unit(s) into {run.path}", file=sys.stderr)
        with stop_on_signals(prepared.runner):
            try:
                run = prepared.execute()
            except SequenceError as exc:
                print(f"station record: the sequence failed: {exc} (journal: {run.path})",
                      file=sys.stderr)
                return 1
    summary = sequence_summary(run)
    if args.json_summary:
        for obj in summary:
            print(json.dumps(obj))
    else:
        print(f"{run.path}: {run.state}")
        for obj in summary:
            print(f"  {obj['unit_id']} ({obj['unit']}): {obj['segments']} segments, "
                  f"{obj['cycles']} cycles, {obj['turn_ons']} turn-ons, recorded "
                  f"{obj['samples_recorded']}, declared missing "
                  f"{obj['samples_missing_declared']}")
    if not run.done:
        print(f"station record: the sequence stopped before its end; run the same command "
              f"again to resume it ({run.path})", file=sys.stderr)
        return 1
    return 0
