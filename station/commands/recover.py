"""``station recover FILE``: close a run file whose recorder was killed or crashed.

Keeps every sample and log entry committed at the recorder's last flush, trims what was
written after it, clears the file's open-for-write flags (so any HDF5 tool opens it
again without SWMR) and records the run as interrupted. A file still being recorded is
refused (``--force`` overrides); a file closed properly is left as it is. A damaged file
(cut short, bits flipped) is left as it is too: what still reads is salvaged into a new
run file (``--out``, default NAME.recovered.h5), read chunk by chunk: a damaged chunk
costs only its own samples, declared as a gap (docs/hdf5-layout.md). The result is read
back whole before anything is reported; a file nothing can be salvaged from is an error
(exit 2) and nothing is written.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

from station.commands import COMMAND_HELP
from station.storage.hdf5 import REASON_RECOVERED
from station.storage.hdf5_recover import recover_run


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``recover`` sub-command."""
    p = sub.add_parser("recover", help=COMMAND_HELP["recover"],
                       description=__doc__)
    p.add_argument("file", type=Path, help="the run's .h5 file")
    p.add_argument("--force", action="store_true",
                   help="recover even if a recorder on this host seems to be writing it")
    p.add_argument("--out", type=Path, default=None,
                   help="where the salvage of a damaged file goes (default "
                        "NAME.recovered.h5 beside it)")
    p.add_argument("--json", action="store_true",
                   help='print {"path", "already_closed", "kept", "trimmed", "stop_utc", '
                        '"stop_reason", "salvaged_to", "damage", "notes", "lost"} as one JSON '
                        'object')
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Recover the file and say what was kept."""
    result = recover_run(args.file, force=args.force, out=args.out)
    if args.json:
        json.dump(asdict(result), sys.stdout)
        sys.stdout.write("\n")
        return 0
    if result.salvaged_to:
        print(f"{result.path}: damaged ({result.damage}); left as it is")
        print(f"salvaged into {result.salvaged_to} (run marked: {result.stop_reason}):")
        for uid, kept in result.kept.items():
            note = f"; {result.notes[uid]}" if uid in result.notes else ""
            print(f"  {uid}: {kept} samples kept{note}")
        return 0
    if result.already_closed:
        print(f"{result.path}: closed properly already (stopped {result.stop_utc}: "
              f"{result.stop_reason}); nothing to do")
        return 0
    if result.stop_reason == REASON_RECOVERED:
        print(f"{result.path}: recovered; run marked interrupted at {result.stop_utc} "
              f"(last flush)")
    else:
        print(f"{result.path}: repaired (its recorder stopped at {result.stop_utc}: "
              f"{result.stop_reason}, but could not close the file)")
    for uid, kept in result.kept.items():
        print(f"  {uid}: {kept} samples kept, {result.trimmed[uid]} written after the last "
              f"flush dropped")
    return 0
