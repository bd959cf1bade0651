"""``station davar FILE``: dynamic Allan deviation of a record, warm-up time and stationarity.

Prints a summary (or, with ``--json``, one object
``{"axes": [{"name", "t_s", "tau_s", "adev", "warmup_end_s", "stationary"}]}`` with
``adev`` per window and tau in deg/s) and can draw a heat map of log ADEV over time and tau.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from analysis.davar import DavarResult, dynamic_allan_variance
from analysis.warmup import WarmupVerdict, detect_warmup
from station.commands.analyze import add_record_arguments, load_record
from station.errors import UsageError
from station.model.records import RateRecord


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``davar`` sub-command."""
    p = sub.add_parser("davar", help="dynamic Allan deviation, warm-up time and stationarity",
                       description=__doc__)
    add_record_arguments(p)
    p.add_argument("--window-s", type=float, required=True, metavar="W",
                   help="window length in s (the Allan curve of each window is computed)")
    p.add_argument("--step-s", type=float, default=None, metavar="S",
                   help="step between windows in s (default: a tenth of the window)")
    p.add_argument("--png", type=Path, default=None, metavar="OUT.png",
                   help="write a heat map of log10 ADEV over time and tau")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a summary")
    # the DAVAR finds the warm-up itself: nothing is discarded unless --warmup-s asks
    p.set_defaults(handler=run, warmup_s=0.0)


def run(args: argparse.Namespace) -> int:
    """Read the record, compute its DAVAR and warm-up verdict per axis, print and plot."""
    record, _ = load_record(args)
    if args.window_s * record.sample_rate_hz > record.n_samples:
        raise UsageError(f"--window-s {args.window_s:g} is longer than the record "
                         f"({record.duration_s:g} s)")
    if record.missing_samples:
        print(f"station davar: note: {record.missing_samples} samples are missing in gaps; the "
              f"DAVAR joins the stretches between them (window times are sample counts)",
              file=sys.stderr)
    result = dynamic_allan_variance(record.rate_deg_s, record.sample_rate_hz,
                                    window_s=args.window_s, step_s=args.step_s)
    verdicts = [detect_warmup(result, axis=i) for i in range(len(record.axis_names))]
    if args.png is not None:
        write_heat_map(args.png, result, verdicts, record)
    if args.json:
        json.dump(as_json(result, verdicts, record), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(format_summary(result, verdicts, record))
        if args.png is not None:
            print(f"heat map: {args.png}")
    return 0


def as_json(result: DavarResult, verdicts: list[WarmupVerdict], record: RateRecord) -> dict:
    """The ``--json`` object: per axis, window centres (s), taus (s), ADEV (deg/s), verdict."""
    axes = []
    for i, (name, verdict) in enumerate(zip(record.axis_names, verdicts, strict=True)):
        one = result.axis(i)
        axes.append({
            "name": name,
            "t_s": one.t_s.tolist(),
            "tau_s": one.tau_s.tolist(),
            "adev": one.adev.tolist(),
            "warmup_end_s": verdict.warmup_end_s,
            "stationary": bool(verdict.stationary),
        })
    return {"axes": axes}


def _verdict_text(verdict: WarmupVerdict) -> str:
    if verdict.stationary:
        return "no warm-up; stationary (every window's Allan curve inside the band of the later ones)"
    if verdict.warmup_end_s is None:
        return "NOT settled: the Allan curve still changes within the last window length"
    return (f"warm-up ends at {verdict.warmup_end_s:g} s ({verdict.warmup_end_s / 3600:.2f} h); "
            f"not stationary over the whole run")


def format_summary(result: DavarResult, verdicts: list[WarmupVerdict], record: RateRecord) -> str:
    """Human-readable summary: windows, taus, ADEV spread over time per axis, verdicts."""
    lines = [
        f"{record.source}: {record.n_samples} samples at {record.sample_rate_hz:g} Hz "
        f"({record.duration_s:g} s)",
        f"window {result.window_s:g} s ({result.window_samples} samples), step {result.step_s:g} s, "
        f"{len(result.t_s)} windows; {len(result.tau_s)} taus from {result.tau_s[0]:g} to "
        f"{result.tau_s[-1]:g} s",
    ]
    picks = sorted({0, len(result.tau_s) // 2, len(result.tau_s) - 1})
    for i, (name, verdict) in enumerate(zip(record.axis_names, verdicts, strict=True)):
        adev = result.axis(i).adev
        lines.append(f"axis {name}:")
        for k in picks:
            col = adev[:, k]
            lines.append(f"  ADEV at tau {result.tau_s[k]:>9.4g} s: min {col.min():.4g}  "
                         f"median {np.median(col):.4g}  max {col.max():.4g} deg/s over time")
        lines.append(f"  {_verdict_text(verdict)}")
    return "\n".join(lines)


def _edges(centres: np.ndarray, *, log: bool) -> np.ndarray:
    x = np.log(centres) if log else np.asarray(centres, dtype=float)
    if len(x) == 1:
        edges = np.array([x[0] - 0.5, x[0] + 0.5])
    else:
        mid = (x[1:] + x[:-1]) / 2
        edges = np.r_[2 * x[0] - mid[0], mid, 2 * x[-1] - mid[-1]]
    return np.exp(edges) if log else edges


def write_heat_map(path: Path, result: DavarResult, verdicts: list[WarmupVerdict],
                   record: RateRecord) -> Path:
    """PNG heat map per axis: time on x, log tau on y, log10 ADEV (deg/s) as colour."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    n_axes = len(record.axis_names)
    fig, axs = plt.subplots(n_axes, 1, figsize=(9, 2.8 * n_axes + 0.6), squeeze=False,
                            sharex=True, constrained_layout=True)
    t_edges = _edges(result.t_s, log=False)
    tau_edges = _edges(result.tau_s, log=True)
    for i, (name, verdict) in enumerate(zip(record.axis_names, verdicts, strict=True)):
        ax = axs[i, 0]
        log_adev = np.log10(np.maximum(result.axis(i).adev, np.finfo(float).tiny))
        mesh = ax.pcolormesh(t_edges, tau_edges, log_adev.T, shading="flat", cmap="viridis")
        ax.set_yscale("log")
        ax.set_ylabel("tau (s)")
        ax.set_title(f"{Path(record.source).name or 'record'}: {name}, window {result.window_s:g} s")
        if verdict.warmup_end_s:
            ax.axvline(verdict.warmup_end_s, color="w", ls="--", lw=1.2,
                       label=f"warm-up end {verdict.warmup_end_s:g} s")
            ax.legend(loc="upper right", fontsize=8)
        fig.colorbar(mesh, ax=ax, label="log10 ADEV (deg/s)")
    axs[-1, 0].set_xlabel("window centre time since start (s)")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
