"""``station reconcile MEASURED --model MODEL.toml``: where do the model and the measurement
disagree?

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

from analysis.reconcile.options import ReconcileOptions
from station.commands import COMMAND_HELP
from station.commands.arguments import (
    add_output_options,
    add_record_source,
    output_family,
    print_notes_or_json,
    record_source,
    stderr_progress,
)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``reconcile`` sub-command."""
    p = sub.add_parser("reconcile", help=COMMAND_HELP["reconcile"],
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_record_source(p, metavar="MEASURED",
                      file_help="recorded run (.h5) or rate record (CSV, CSV.gz)",
                      axis_help="reconcile only this axis (column name); default every axis",
                      unit_default="every unit")
    p.add_argument(
        "--model", required=True, metavar="MODEL.toml", help="noise model TOML file or preset name"
    )
    add_output_options(p, png_help="write the figure here",
                       json_help="print one JSON object instead of the text report")
    defaults = ReconcileOptions()
    p.add_argument(
        "--runs",
        type=int,
        default=defaults.runs,
        metavar="N",
        help=f"Monte Carlo runs per comparison (default {defaults.runs})",
    )
    p.add_argument(
        "--seed", type=int, default=defaults.seed, help="seed of the Monte Carlo runs (default 0)"
    )
    p.add_argument(
        "--alpha",
        type=float,
        default=defaults.alpha,
        help=f"level of the gap test (default {defaults.alpha})",
    )
    p.add_argument(
        "--max-samples",
        type=int,
        default=defaults.max_samples,
        metavar="N",
        help="decimate longer records by block means to at most N samples "
        f"(default {defaults.max_samples})",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Reconcile each axis with the model; print the report or the JSON; draw the figure."""
    from station.output.reconcile_report import format_reconcile
    from station.services.reconcile import ReconcileRequest, reconcile_run

    family = output_family(args)
    answer = reconcile_run(
        ReconcileRequest(
            record_source(args),
            args.model,
            runs=args.runs,
            seed=args.seed,
            alpha=args.alpha,
            max_samples=args.max_samples,
            png=args.png,
            output_units=family,
        ),
        stderr_progress("reconcile: "),
    )
    if not print_notes_or_json("reconcile", answer, args):
        print(f"{args.file} against {args.model}")
        print("\n\n".join(format_reconcile(res, label=label, family=family)
                          for label, res in answer.results))
        if answer.png is not None:
            print(f"figure: {answer.png}")
    return 0
