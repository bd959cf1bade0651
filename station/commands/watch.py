"""``station watch RUN``: follow a run file while the recorder writes it (SWMR reader).

Prints, every ``--interval`` seconds, one line per unit: samples, sample rate, gaps and
missing samples, CRC errors, reconnects, the unit time reached, the newest rate per axis
and the mean of the last second (in deg/h, like every rate the station prints; rad/s with
``--output-units rad``); stops when the run stops (or on Ctrl-C).
A run whose recorder is gone (no flush past its flush interval plus 2 s, and the
recorder's process, named in the file with its station, not running) is said so, with
what to do (``station recover RUN``), and the watch ends with exit status 3.
``--once`` prints the current state and exits. ``--json`` prints the state as one JSON object
per refresh, one line each (``docs/json.md``): ``{"run", "state", "stop_utc", "stop_reason",
"last_flush_utc", "last_flush_age_s", "recorder_gone", "advice", "units": [{"unit",
"samples_recorded", "sample_rate_hz", "t_s", "gaps", "samples_missing_declared",
"crc_errors", "reconnects", "newest_deg_s", "mean_1s_deg_s", "newest_accel_m_s2"}]}``
(``newest_accel_m_s2``: the newest acceleration per axis of an IMU, m/s^2; null for a
gyro).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from analysis.units import S_PER_H, UnitFamily, unit_family
from station.commands import COMMAND_HELP
from station.commands.arguments import add_output_options, output_family, print_json
from station.services.run_watch import status_json

__all__ = ["register", "run", "status_json", "status_lines"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``watch`` sub-command."""
    p = sub.add_parser("watch", help=COMMAND_HELP["watch"],
                       description=__doc__)
    p.add_argument("run", type=Path, help="the run's .h5 file")
    p.add_argument("--interval", type=float, default=1.0, metavar="S",
                   help="refresh period, s (default 1)")
    p.add_argument("--once", action="store_true", help="print the current state and exit")
    add_output_options(p, json_help="print the state as one JSON object per refresh, one line "
                       "each (units named in the keys: docs/json.md)")
    p.set_defaults(handler=run)


def _rates(values_deg_s: list[float], family: UnitFamily) -> str:
    """Rates given in deg/s, printed in the family's rate unit (deg/h or rad/s)."""
    return " ".join(f"{family.value(v * S_PER_H, 'deg/h'):+.5g}" for v in values_deg_s)


def status_lines(path: Path, family: UnitFamily | None = None) -> tuple[str, list[str]]:
    """(run state, one line per unit) of a run file, from its committed data; the rates in
    ``family``'s rate unit (deg/h by default)."""
    family = family if family is not None else unit_family("deg")
    unit = family.label("deg/h")
    doc = status_json(path)
    lines = []
    for u in doc["units"]:  # type: ignore[attr-defined]
        values = ""
        if u["newest_deg_s"] is not None:
            values = (f", newest [{_rates(u['newest_deg_s'], family)}] {unit}, "
                      f"last 1 s mean [{_rates(u['mean_1s_deg_s'], family)}] {unit}")
        lines.append(f"{u['unit']}: {u['samples_recorded']} samples @{u['sample_rate_hz']:g} Hz to "
                     f"t={u['t_s']:.1f} s, gaps {u['gaps']} "
                     f"({u['samples_missing_declared']} missing), CRC errors {u['crc_errors']}, "
                     f"reconnects {u['reconnects']}{values}")
    text = (f"stopped {doc['stop_utc']}: {doc['stop_reason']}" if doc["state"] == "stopped"
            else f"RECORDER GONE, last flush {doc['last_flush_utc']}: {doc['advice']}"
            if doc["recorder_gone"] else f"recording, last flush {doc['last_flush_utc']}")
    return text, lines


def _exit_status(state: str) -> int | None:
    """How the watch ends on ``state`` (a status line): None while the run goes on."""
    from station.services.record import EXIT_RUN_FAULT  # the recorder: not for --help

    if state.startswith("stopped"):
        return 0
    return EXIT_RUN_FAULT if state.startswith("RECORDER GONE") else None


def run(args: argparse.Namespace) -> int:
    """Print the run's state until it stops."""
    if args.json:
        return run_json(args)
    while True:
        state, lines = status_lines(args.run, output_family(args))
        print(f"{args.run}: {state}")
        for line in lines:
            print("  " + line)
        end = _exit_status(state)
        if end is not None or args.once:
            return end or 0
        time.sleep(args.interval)


def run_json(args: argparse.Namespace) -> int:
    """``--json``: one object per refresh until the run stops (one with ``--once``)."""
    from station.services.record import EXIT_RUN_FAULT

    while True:
        doc = status_json(args.run)
        print_json(doc, output_family(args))
        sys.stdout.flush()
        if doc["recorder_gone"]:
            return EXIT_RUN_FAULT
        if args.once or doc["state"] == "stopped":
            return 0
        time.sleep(args.interval)
