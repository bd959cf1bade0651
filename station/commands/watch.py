"""``station watch RUN``: follow a run file while the recorder writes it (SWMR reader).

Prints, every ``--interval`` seconds, one line per unit: samples, sample rate, gaps and
missing samples, CRC errors, reconnects, the unit time reached, the newest rate per axis
(deg/s) and the mean of the last second; stops when the run stops (or on Ctrl-C).
``--once`` prints the current state and exits.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from station.commands import COMMAND_HELP
from station.storage.hdf5 import open_run_file, read_unit, run_state, unit_counts, unit_ids


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``watch`` sub-command."""
    p = sub.add_parser("watch", help=COMMAND_HELP["watch"],
                       description=__doc__)
    p.add_argument("run", type=Path, help="the run's .h5 file")
    p.add_argument("--interval", type=float, default=1.0, metavar="S",
                   help="refresh period, s (default 1)")
    p.add_argument("--once", action="store_true", help="print the current state and exit")
    p.set_defaults(handler=run)


def status_lines(path: Path) -> tuple[str, list[str]]:
    """(run state, one line per unit) of a run file, from its committed data."""
    with open_run_file(path) as f:
        state = run_state(f)
        lines = []
        for uid in unit_ids(f):
            c = unit_counts(f, uid)
            rate_hz = float(f["units"][uid].attrs["sample_rate_hz"])
            tail = read_unit(f, uid, start=max(0, c.samples_recorded - max(1, round(rate_hz))))
            if len(tail.counter):
                newest = " ".join(f"{v:+.5g}" for v in tail.rate_deg_s[-1])
                mean = " ".join(f"{v:+.5g}" for v in np.mean(tail.rate_deg_s, axis=0))
                values = f", newest [{newest}] deg/s, last 1 s mean [{mean}] deg/s"
            else:
                values = ""
            lines.append(f"{uid}: {c.samples_recorded} samples @{rate_hz:g} Hz to "
                         f"t={c.last_time_s:.1f} s, gaps {c.gaps} "
                         f"({c.samples_missing_declared} missing), CRC errors {c.crc_errors}, "
                         f"reconnects {c.reconnects}{values}")
    text = (f"stopped {state['stop_utc']}: {state['stop_reason']}" if state["state"] == "stopped"
            else f"recording, last flush {state['last_flush_utc']}")
    return text, lines


def run(args: argparse.Namespace) -> int:
    """Print the run's state until it stops."""
    while True:
        state, lines = status_lines(args.run)
        print(f"{args.run}: {state}")
        for line in lines:
            print("  " + line)
        if args.once or state.startswith("stopped"):
            return 0
        time.sleep(args.interval)
