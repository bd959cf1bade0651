"""``station analyze FILE``: Allan deviation, five-term fit and spec figures of a record."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from analysis.allan.kinds import DEVIATION_KINDS
from analysis.fit.methods import FIT_METHODS
from station.commands import COMMAND_HELP
from station.commands.arguments import (
    add_bench_argument,
    add_output_options,
    add_record_source,
    output_family,
    print_notes_or_json,
    record_source,
    stderr_progress,
)
from station.commands.conventions import hint_several_runs
from station.commands.terminal import plural
from station.evaluation.analysis_options import DEFAULT_METHOD, GMWM_METHOD, OUTLIER_POLICIES
from station.evaluation.settings import TAU_GRIDS

if TYPE_CHECKING:
    pass


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``analyze`` sub-command."""
    p = sub.add_parser(
        "analyze",
        help=COMMAND_HELP["analyze"],
        description=__doc__,
    )
    add_record_source(p)
    p.add_argument("--estimator", choices=("overlapping", "clusters"), default=None,
                   help="Allan variance the fit and figures use (default overlapping; clusters "
                        "with --deviation adev)")
    p.add_argument(
        "--deviation",
        choices=DEVIATION_KINDS,
        default=None,
        help="deviation shown and listed (JSON tau_s/adev/adev_ci_*): oadev, adev (clusters), "
        "mdev, hdev, ohdev, tdev (an angle), totdev, theo1; default the estimator's "
        "Allan deviation. The fit and figures stay on the Allan variance",
    )
    p.add_argument("--taus", choices=TAU_GRIDS, default="log",
                   help="tau grid: log-spaced to the longest tau with two clusters (default), "
                        "octaves, or every m")
    p.add_argument("--method", choices=(*FIT_METHODS, GMWM_METHOD), default=DEFAULT_METHOD,
                   help=f"fit method (default {DEFAULT_METHOD}); gmwm adds the generalized "
                        f"method of wavelet moments beside the {DEFAULT_METHOD} Allan fit")
    p.add_argument("--terms", default="QNBKR", help="noise terms to fit, a subset of QNBKR "
                                                    "(logwls keeps those the data resolve)")
    p.add_argument("--no-select", dest="select", action="store_false", default=None,
                   help="logwls: fit every term of --terms, resolved or not")
    p.add_argument("--model", default="auto", metavar="MODEL",
                   help="--method gmwm: the model, terms joined by '+' from wn, qn, gm, ar1, bi, "
                        "rw, dr (e.g. 'wn+gm+rw', 'wn+qn+gm+gm+rw'), or auto (default): ranked "
                        "by the WIC")
    p.add_argument("--robust", action="store_true",
                   help="--method gmwm: robust (Huber-type) wavelet variance, for records with "
                        "outliers")
    p.add_argument("--outliers", choices=OUTLIER_POLICIES, default="auto",
                   help="isolated spikes: remove them when few (auto, default), keep, or remove")
    add_bench_argument(p)
    add_output_options(
        p,
        png_help="write the plot: Allan deviation (accelerometer axes beside it in "
        "<stem>_accel.png, in m/s^2, or the --profile's mg or ug); with --method gmwm the "
        "wavelet variance with the GMWM and the Allan fit's curves",
        csv_help="write the curve: per axis and tau the deviation, its interval and the "
        "fitted model, in deg/h (rad/s with --output-units rad); no profile or report needed",
        json_help="print one JSON object instead of a table",
    )
    hint_several_runs(p, "analyze")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Read the record, analyze every axis, print a table or JSON."""
    from station.evaluation.analyze import format_analysis
    from station.services.analyze import AnalyzeRequest, analyze

    result = analyze(AnalyzeRequest(record_source(args), estimator=args.estimator,
                                    deviation=args.deviation, taus=args.taus, method=args.method,
                                    terms=args.terms, select=args.select, gmwm_model=args.model,
                                    robust=args.robust, outliers=args.outliers, bench=args.bench,
                                    png=args.png, csv=args.csv,
                                    output_units=output_family(args)),
                     stderr_progress())
    family = output_family(args)
    if not print_notes_or_json("analyze", result, args):
        record, selection = result.record, result.selection
        print(f"{args.file}: {record.n_samples} samples at {record.sample_rate_hz:g} Hz, "
              f"{plural(len(result.axes), 'axis')}")
        if selection.start_s > 0 or selection.stop_s is not None:
            print(f"analyzed {selection.start_s:g} s .. "
                  f"{'end' if selection.stop_s is None else f'{selection.stop_s:g} s'} "
                  f"(warm-up {selection.warmup_s:g} s from {selection.warmup_from})")
        print(format_analysis(list(result.axes), family))
        if result.png is not None:
            print(f"figure: {result.png}")
        if args.csv is not None:
            print(f"curve: {args.csv}")
    return 0
