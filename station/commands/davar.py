"""``station davar FILE``: dynamic Allan deviation of a record, warm-up time and stationarity.

Prints a summary (or, with ``--json``, one object
``{"axes": [{"name", "t_s", "tau_s", "adev_deg_h", "adev_deg_s", "adev", "warmup_end_s",
"stationary"}]}`` with the ADEV per window and tau; ``adev`` is ``adev_deg_s``, kept for
older readers) and can draw a heat map of log ADEV (deg/h) over time and tau.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

import numpy as np

from analysis.units.conversions import DEG_FAMILY, S_PER_H, UnitFamily
from station.commands import COMMAND_HELP
from station.commands.arguments import (
    add_output_options,
    add_record_source,
    output_family,
    print_notes_or_json,
    record_source,
)

if TYPE_CHECKING:
    from analysis.davar.estimators import DavarResult
    from analysis.davar.warmup import WarmupVerdict
    from station.model.records import RateRecord


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``davar`` sub-command."""
    p = sub.add_parser("davar", help=COMMAND_HELP["davar"],
                       description=__doc__)
    add_record_source(p)
    p.add_argument("--window-s", type=float, required=True, metavar="W",
                   help="window length in s (the Allan curve of each window is computed)")
    p.add_argument("--step-s", type=float, default=None, metavar="S",
                   help="step between windows in s (default: a tenth of the window)")
    add_output_options(
        p,
        png_help="write a heat map of log10 ADEV (deg/h; rad/s with --output-units rad; "
        "m/s^2 for accelerometer axes, --axis accel_x) over "
        "time and tau",
        json_help="print one JSON object instead of a summary",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Read the record, compute its DAVAR and warm-up verdict per axis, print and plot."""
    from station.services.davar import DavarRequest, davar

    family = output_family(args)
    answer = davar(DavarRequest(record_source(args), args.window_s, args.step_s, args.png, family))
    if not print_notes_or_json("davar", answer, args, allow_nan=False):
        print(format_summary(answer.result, list(answer.verdicts), answer.record, family,
                             accel=answer.quantity == "acceleration"))
        if answer.png is not None:
            print(f"heat map: {answer.png}")
    return 0


def _verdict_text(verdict: WarmupVerdict) -> str:
    if verdict.stationary:
        return (
            "no warm-up; stationary (every window's Allan curve inside the band of the later ones)"
        )
    if verdict.warmup_end_s is None:
        return "NOT settled: the Allan curve still changes within the last window length"
    return (f"warm-up ends at {verdict.warmup_end_s:g} s ({verdict.warmup_end_s / 3600:.2f} h); "
            f"not stationary over the whole run")


def format_summary(result: DavarResult, verdicts: list[WarmupVerdict], record: RateRecord,
                   family: UnitFamily = DEG_FAMILY, *, accel: bool = False) -> str:
    """Human-readable summary: windows, taus, ADEV spread over time (in ``family``; m/s^2
    for accelerometer axes, ``accel``) per axis, verdicts."""
    factor, unit = (1.0, "m/s^2") if accel else (S_PER_H * family.factor("deg/h"),
                                                  family.label("deg/h"))
    lines = [
        f"{record.source}: {record.n_samples} samples at {record.sample_rate_hz:g} Hz "
        f"({record.duration_s:g} s)",
        f"window {result.window_s:g} s ({result.window_samples} samples), step {result.step_s:g} "
        "s, "
        f"{len(result.t_s)} windows; {len(result.tau_s)} taus from {result.tau_s[0]:g} to "
        f"{result.tau_s[-1]:g} s",
    ]
    picks = sorted({0, len(result.tau_s) // 2, len(result.tau_s) - 1})
    for i, (name, verdict) in enumerate(zip(record.axis_names, verdicts, strict=True)):
        adev = result.axis(i).adev * factor
        lines.append(f"axis {name}:")
        for k in picks:
            col = adev[:, k]
            lines.append(f"  ADEV at tau {result.tau_s[k]:>9.4g} s: min {col.min():.4g}  "
                         f"median {np.median(col):.4g}  max {col.max():.4g} "
                         f"{unit} over time")
        lines.append(f"  {_verdict_text(verdict)}")
    return "\n".join(lines)
