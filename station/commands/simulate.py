"""``station simulate``: write a simulated gyro run from a noise model or from two indicators.

``station simulate --model MODEL`` simulates a model file or preset; ``station simulate
--arw A --bias-stability B [--average-s 100] [--correlation-s T] ...`` simulates the
white-noise-plus-Markov FOG derived from a data sheet's ARW (deg/sqrt(h)) and bias
stability (deg/h), see ``docs/fog-model.md``. The output is CSV (``.csv``, ``.csv.gz``:
the analysis core's format) or a run file in the recorder's HDF5 layout (``.h5``: one
unit ``sim``, sample counter, time, and temperature when the model has one). The run is
generated and written chunk by chunk, so its length is not bounded by memory; a progress
line goes to stderr for long runs.

Example::

    station simulate --model VG951 --duration 4h --rate 10 --seed 1 --out run.csv
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from station.commands import COMMAND_HELP
from station.commands.arguments import add_fog_indicators, add_output_options, duration_type
from station.commands.terminal import ProgressLine, plural

if TYPE_CHECKING:
    from station.services.progress import Progress


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` sub-command."""
    p = sub.add_parser(
        "simulate",
        help=COMMAND_HELP["simulate"],
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    source = p.add_argument_group("what to simulate (a model, or the two indicators)")
    source.add_argument("--model", metavar="MODEL",
                        help="noise model TOML file or preset name (e.g. VG951, zhang2015-fog)")
    add_fog_indicators(source, required=False)
    p.add_argument("--duration", type=duration_type, default=3600.0, metavar="DURATION",
                   help="run length, e.g. 4h, 30min, 600s (default 1h)")
    p.add_argument(
        "--rate", type=float, default=10.0, metavar="HZ", help="sample rate in Hz (default 10)"
    )
    p.add_argument("--axes", type=int, default=1, metavar="N", help="number of axes (default 1)")
    p.add_argument(
        "--seed", type=int, default=None, help="seed of the run (default: fresh entropy)"
    )
    add_output_options(
        p,
        json_help='print {"out", "n_samples", "axes", "rate_hz", "model"} as one JSON object',
        quiet_help="print nothing but errors (and --json's object): no progress line, no "
        "summary",
        units=False,
    )
    p.add_argument(
        "--out",
        type=Path,
        required=True,
        metavar="FILE",
        help="output: .csv, .csv.gz, or .h5 (a run file in the recorder's layout)",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Simulate the run chunk by chunk and write it, with a progress line for long runs."""
    from station.services.simulate import CHUNK_SAMPLES, SimulateRequest, simulate_run

    request = SimulateRequest(
        args.out,
        model=args.model,
        arw_deg_rt_h=args.arw,
        bias_stability_deg_h=args.bias_stability,
        average_s=args.average_s,
        correlation_s=args.correlation_s,
        duration_s=args.duration,
        rate_hz=args.rate,
        axes=args.axes,
        seed=args.seed,
    )

    line = ProgressLine("simulate", quiet=args.quiet)

    def progress(step: Progress) -> None:
        if step.total > CHUNK_SAMPLES:  # more than one chunk
            line.update(step.done, step.total)

    result = simulate_run(request, progress)
    if args.json:
        json.dump(
            {
                "out": str(result.out),
                "n_samples": result.n_samples,
                "axes": result.axes,
                "rate_hz": result.rate_hz,
                "model": result.model.name,
            },
            sys.stdout,
        )
        sys.stdout.write("\n")
    elif not args.quiet:
        print(
            f"wrote {plural(result.n_samples, 'sample')} x {plural(result.axes, 'axis')} at "
            f"{result.rate_hz:g} Hz to {result.out}",
            file=sys.stderr,
        )
    return 0
