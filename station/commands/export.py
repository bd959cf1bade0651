"""``station export RUN_OR_RECORD --format FORMAT``: a unit's noise parameters for another tool.

Formats: ``kalibr`` (imu.yaml), ``openvins`` (kalibr_imu_chain.yaml), ``matlab``
(gyroparams, a .m script or, with --out NAME.json, JSON), ``gnss-ins-sim`` (its IMU error
dictionary), ``allan-variance-ros`` (its imu.yaml), ``json`` (every figure in deg and rad
units). Units and formulas: docs/units.md. The file is written whole or not at all
(a temporary file renamed); ``--out -`` prints it instead.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from station.commands import COMMAND_HELP
from station.commands.arguments import (
    add_bench_argument,
    add_output_options,
    add_record_source,
    print_notes_or_json,
    record_source,
    stderr_progress,
)
from station.evaluation.noise_parameters import EXPORT_METHODS
from station.output.export_formats import FORMATS


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``export`` sub-command."""
    p = sub.add_parser(
        "export",
        help=COMMAND_HELP["export"],
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        allow_abbrev=False,
    )
    add_record_source(p)
    p.add_argument(
        "--format",
        required=True,
        choices=tuple(FORMATS),
        help="the tool whose file to write: "
        + "; ".join(f"{k}: {v.description}" for k, v in FORMATS.items()),
    )
    p.add_argument(
        "--method",
        choices=EXPORT_METHODS,
        default=EXPORT_METHODS[0],
        help="logwls (default): the Allan fit and the IEEE 952 read-offs; gmwm: the "
        "GMWM's model (white noise, random walk, Gauss-Markov terms: gnss-ins-sim's "
        "gyro_b_corr)",
    )
    p.add_argument(
        "--model",
        default="auto",
        metavar="MODEL",
        help="--method gmwm: the model, terms joined by '+' (e.g. 'wn+gm+rw'), or auto "
        "(default): ranked by the WIC, as station analyze --method gmwm",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="FILE",
        help="where to write ('-': standard output; default <record>[_<unit>]_<tool's "
        "file name> in the current folder)",
    )
    p.add_argument(
        "--rostopic",
        default="/imu0",
        metavar="TOPIC",
        help="kalibr, openvins, allan-variance-ros: the IMU topic written (default /imu0)",
    )
    add_bench_argument(p)
    add_output_options(
        p,
        json_help="print what was written as one JSON object (figures of every axis in "
        "both unit families; with --output-units rad in the rad family only)",
        quiet_help="no progress line on a terminal",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Export the noise parameters; say where they went (or print the file, or the JSON)."""
    from station.services.export import ExportRequest, export_noise
    result = export_noise(
        ExportRequest(
            record_source(args),
            args.format,
            out=args.out,
            method=args.method,
            gmwm_model=args.model,
            rostopic=args.rostopic,
            bench=args.bench,
        ),
        stderr_progress(quiet=args.quiet, terminal_only=True),
    )
    if print_notes_or_json("export", result, args):
        return 0
    if result.out is None:
        sys.stdout.write(result.text)
    else:
        print(f"{FORMATS[args.format].description} written to {result.out}")
    return 0
