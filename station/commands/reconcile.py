"""``station reconcile MEASURED --model MODEL.toml``: where do the model and the measurement disagree?

Compares the measured Allan curve with the model's (theory and a Monte Carlo band of runs
of the same length and tau grid), names the missing effects from the simulation library
(or the terms the data show less of), adds them and shows the gap shrink; see
:mod:`analysis.reconcile`. ``--json`` prints
``{"gap_before", "gap_after", "effects": [{"name", "params", "tau_range_s", ...}],
"model_after": {...TOML tables...}, ...}`` for the first (or the ``--axis``) axis, with
every axis under ``"axes"``; ``--png`` draws the measured curve with its band, the model
before and after, and the effects' contributions.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from analysis.discrepancy import ComparisonCache
from analysis.reconcile import ReconcileOptions, ReconcileResult, reconcile
from devices.model_files import load_noise_model
from station.errors import UsageError
from station.model.records import RateRecord
from station.output.reconcile_report import format_reconcile, plot_reconcile
from station.storage.csv_records import UNIT_TO_DEG_S
from station.storage.runs import open_run


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``reconcile`` sub-command."""
    p = sub.add_parser("reconcile", help="model versus measurement: name the missing effects",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("measured", metavar="MEASURED", help="recorded run (.h5) or rate record (CSV, CSV.gz)")
    p.add_argument("--rate", type=float, default=None, metavar="HZ",
                   help="sample rate in Hz (required when a CSV has no time column)")
    p.add_argument("--units", choices=sorted(UNIT_TO_DEG_S), default="deg/s",
                   help="unit of a CSV's rate columns (default deg/s)")
    p.add_argument("--model", required=True, metavar="MODEL.toml", help="noise model TOML file or preset name")
    p.add_argument("--axis", default=None, help="reconcile only this axis (column name); default every axis")
    p.add_argument("--png", type=Path, default=None, metavar="OUT.png", help="write the figure here")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the text report")
    defaults = ReconcileOptions()
    p.add_argument("--runs", type=int, default=defaults.runs, metavar="N",
                   help=f"Monte Carlo runs per comparison (default {defaults.runs})")
    p.add_argument("--seed", type=int, default=defaults.seed, help="seed of the Monte Carlo runs (default 0)")
    p.add_argument("--alpha", type=float, default=defaults.alpha,
                   help=f"level of the gap test (default {defaults.alpha})")
    p.add_argument("--max-samples", type=int, default=defaults.max_samples, metavar="N",
                   help="decimate longer records by block means to at most N samples "
                        f"(default {defaults.max_samples})")
    p.set_defaults(handler=run)


def _axes(args: argparse.Namespace) -> list[tuple[str, RateRecord]]:
    run_info = open_run(args.measured, sample_rate_hz=args.rate, units=args.units)
    several_units = len(run_info.units) > 1
    out = []
    for unit in run_info.units:
        record = unit.record
        names = [args.axis] if args.axis is not None else list(record.axis_names)
        if args.axis is not None and args.axis not in record.axis_names:
            if several_units:
                continue
            record.select(args.axis)  # raises with the list of axes
        for name in names:
            out.append((f"{unit.unit_id}/{name}" if several_units else name, record.select(name)))
    if not out:
        raise UsageError(f"no axis {args.axis!r} in {args.measured}")
    return out


def run(args: argparse.Namespace) -> int:
    """Reconcile each axis with the model; print the report or the JSON; draw the figure."""
    if args.runs < 4:
        raise UsageError(f"--runs must be at least 4, got {args.runs}")
    model = load_noise_model(args.model)
    options = ReconcileOptions(runs=args.runs, seed=args.seed, alpha=args.alpha, max_samples=args.max_samples)
    cache = ComparisonCache()
    results: list[tuple[str, ReconcileResult]] = []
    for label, record in _axes(args):
        print(f"reconcile: {label} ({record.n_samples} samples) ...", file=sys.stderr, flush=True)
        res = reconcile(record.rate_deg_s[:, 0], record.sample_rate_hz, model,
                        temperature_c=record.temperature_c, options=options, cache=cache)
        results.append((label, res))
    if args.png is not None:
        plot_reconcile(results, args.png)
    if args.json:
        axes = [{"axis": label, **res.as_json()} for label, res in results]
        json.dump({"file": str(args.measured), **axes[0], "axes": axes}, sys.stdout)
        sys.stdout.write("\n")
    else:
        print(f"{args.measured} against {args.model}")
        print("\n\n".join(format_reconcile(res, label=label) for label, res in results))
        if args.png is not None:
            print(f"figure: {args.png}")
    return 0
