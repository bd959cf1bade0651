"""``station demo``: the main job on simulated IMUs, start to finish, in under a minute.

Records a time-warped run of two simulated IMUs (tactical-grade gyros of the VG951 noise
model of Lv 2015 table 3, beside three accelerometers each, with gravity on z) over their
real transports (two Xsens Xbus streams, each on its own pseudo-terminal, a real tty for
pyserial) into an HDF5 run file, exactly as ``station record`` would, then analyzes each
unit as ``station analyze`` would, prints the spec figures of both halves (gyros, then
accelerometers: velocity random walk, bias instability, acceleration random walk) beside
the true values, and writes the record (CSV, both halves) and the Allan deviation plots
(PNG: the gyros in deg/h, the accelerometers in m/s^2).
``--json`` prints what it found as one JSON object instead (``docs/json.md``).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import quote

import numpy as np

from analysis.models.noise import flicker_rate_noise, white_angle_noise, white_rate_noise
from analysis.units.conversions import arw_deg_rt_h_to_deg_rt_s, q_urad_to_deg, rate_deg_h_to_deg_s
from station.commands import COMMAND_HELP, demo_sequence
from station.commands.arguments import add_output_options, output_family, print_json
from station.errors import UsageError
from station.model.records import RateRecord
from station.model.runs import RunMetadata
from station.storage.csv_records import write_csv_record

if TYPE_CHECKING:
    from station.evaluation.analyze import AxisAnalysis

#: The demo gyro: a tactical FOG (the VG951 of Lv 2015 table 3) with a 3.6 deg/h bias.
DEMO_TRUE = {"Q": 7.555e-2, "N": 7.636e-3, "B": 1.246e-1}
DEMO_BIAS_DEG_H = 3.6
#: Wall-clock time the recording of one simulated hour takes, s (the time warp follows).
DEMO_WALL_S_PER_H = 40.0
#: The shortest recording, wall s (a demo shorter than 90 simulated s slows its warp to it).
DEMO_MIN_WALL_S = 1.0


def simulate_demo_record(duration_s: float, sample_rate_hz: float, seed: int) -> RateRecord:
    """A simulated three-axis static record of the demo gyro (deg/s), without devices."""
    n = int(duration_s * sample_rate_hz)
    rng = np.random.default_rng(seed)
    rate = (
        DEMO_BIAS_DEG_H / 3600.0
        + white_angle_noise(q_urad_to_deg(DEMO_TRUE["Q"]), n, sample_rate_hz, rng, n_axes=3)
        + white_rate_noise(
            arw_deg_rt_h_to_deg_rt_s(DEMO_TRUE["N"]), n, sample_rate_hz, rng, n_axes=3
        )
        + flicker_rate_noise(rate_deg_h_to_deg_s(DEMO_TRUE["B"]), n, sample_rate_hz, rng, n_axes=3)
    )
    return RateRecord(rate, sample_rate_hz, ("gyro_x", "gyro_y", "gyro_z"), "simulated demo gyro")


def demo_model() -> str:
    """The noise model the simulated units draw from: the VG951 model file, else the preset."""
    from station.model.profiles import PROFILE_DIR

    path = PROFILE_DIR / "models" / "VG951.toml"
    return str(path) if path.is_file() else "VG951"


def demo_accel_true() -> dict[str, float]:
    """The accelerometer truths of the simulated units (their model's ``[accelerometer]``
    table, else the generic accelerometer): ``vrw_m_s_rt_h`` (m/s/sqrt(h)),
    ``bias_instability_ug`` (ug), ``accel_rw_m_s_h1_5`` (m/s/h^1.5)."""
    from devices.sim.signal import accel_model

    model = accel_model(demo_model())
    return {"vrw_m_s_rt_h": model.vrw_m_s_rt_h, "bias_instability_ug": model.bias_instability_ug,
            "accel_rw_m_s_h1_5": model.accel_rw_m_s_h1_5}


def demo_urls(duration_s: float, rate_hz: float, seed: int) -> tuple[str, str]:
    """Device URLs of the two simulated units, warped to record ``duration_s`` (s) in about
    1..20 s of wall time (half an hour in 20 s: warp 90; a short demo at the same warp, not
    slowed to fill a fixed wall time)."""
    wall_s = min(max(duration_s / 3600.0 * DEMO_WALL_S_PER_H, DEMO_MIN_WALL_S), 20.0)
    warp = max(1.0, duration_s / wall_s)
    query = f"model={quote(demo_model())}&rate={rate_hz:g}&warp={warp:g}"
    return (f"sim+serial://VG951?protocol=xbus&{query}&seed={seed}",
            f"sim+serial://VG951?protocol=xbus&{query}&seed={seed + 1}")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``demo`` sub-command."""
    p = sub.add_parser("demo", help=COMMAND_HELP["demo"],
                       description=__doc__)
    p.add_argument("--duration", type=float, default=0.5, metavar="HOURS",
                   help="simulated run length in hours (default 0.5; recorded in about 20 s)")
    p.add_argument(
        "--rate", type=float, default=10.0, metavar="HZ", help="sample rate (default 10 Hz)"
    )
    p.add_argument(
        "--seed",
        type=int,
        default=1,
        help="seed of the simulated gyros (default 1: the same demo every time)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="folder for the run file, the record and the plot, kept there (default: a "
        "temporary folder, removed at the end unless --keep)",
    )
    p.add_argument("--keep", action="store_true",
                   help="keep the temporary folder (without --out) and say where it is")
    demo_sequence.add_arguments(p)
    add_output_options(p, json_help='print {"run", "units": [{"unit", "samples_recorded", ..., '
                       '"axes": [AXIS as station analyze]}], "true", "files"} as one JSON object '
                       "(docs/json.md)")
    p.set_defaults(handler=run)


def record_demo_run(args: argparse.Namespace, path: Path) -> list[dict[str, object]]:
    """Record the two simulated units into ``path`` with the real recorder."""
    from station.recording.progress import ProgressLine
    from station.recording.recorder import Recorder, RunConfig

    urls = demo_urls(args.duration * 3600.0, args.rate, args.seed)
    recorder = Recorder(
        RunConfig(urls, args.duration * 3600.0, path,
                  metadata=RunMetadata(operator="station demo")),
        [ProgressLine(sys.stderr, plain_interval_s=5.0)],
    )
    recorder.prepare()
    stop = recorder.run()
    for t in stop.totals:
        if not args.json:
            print(
                f"{t.unit_id}: {t.samples_recorded} samples recorded, "
                f"{t.samples_missing_declared} declared missing in {t.gaps} gaps, "
                f"simulator sent {t.samples_sent}"
            )
    return [{"unit": t.unit_id, "samples_recorded": t.samples_recorded,
             "samples_missing_declared": t.samples_missing_declared, "gaps": t.gaps,
             "samples_sent": t.samples_sent} for t in stop.totals]


@contextlib.contextmanager
def demo_folder(out: Path | None, *, keep: bool) -> Iterator[Path]:
    """``out`` (created; kept), or a new temporary folder removed at the end unless
    ``keep``; where it is, and whether it was removed, goes to stderr."""
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        yield out
        return
    folder = Path(tempfile.mkdtemp(prefix="station-demo-"))
    print(f"station demo: writing into the temporary folder {folder}", file=sys.stderr)
    try:
        yield folder
    finally:
        if keep:
            print(f"station demo: kept {folder}", file=sys.stderr)
        else:
            shutil.rmtree(folder, ignore_errors=True)
            print(f"station demo: removed {folder} (--keep keeps it; --out DIR writes there)",
                  file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    """Record, analyze, print, plot (into ``--out`` or a temporary folder)."""
    if args.sequence and args.json:
        raise UsageError("--json is not available with --sequence (its figures are "
                         "printed as a table; station grade RUN --json gives them)")
    with demo_folder(args.out, keep=args.keep) as folder:
        return _run(argparse.Namespace(**{**vars(args), "out": folder}))


def _run(args: argparse.Namespace) -> int:
    if args.sequence:
        return demo_sequence.run(args)
    from station.evaluation.analyze import analyze_record, format_analysis
    from station.storage.hdf5 import read_run_record

    t0 = time.monotonic()
    path = args.out / "demo-run.h5"
    path.unlink(missing_ok=True)
    print(
        f"recording {args.duration:g} h (simulated, time-warped) of two IMUs (3-axis VG951 "
        f"gyros, 3 accelerometers) at "
        f"{args.rate:g} Hz over two Xbus serial links into {path} ...",
        file=sys.stderr,
    )
    totals = {t["unit"]: t for t in record_demo_run(args, path)}
    plotted: list[AxisAnalysis] = []
    plotted_accel: list[AxisAnalysis] = []
    family = output_family(args)
    for unit in ("unit1", "unit2"):
        record = read_run_record(path, unit)
        print(f"\n{unit}: analyzing {record.n_samples} samples per axis ...", file=sys.stderr)
        axes = analyze_record(record)
        totals.setdefault(unit, {"unit": unit})["axes"] = [a.as_json() for a in axes]
        if not args.json:
            print(f"{unit} ({record.source})")
            print(format_analysis(axes, family))
        plotted.append(dataclasses.replace(axes[0], name=f"{unit} {axes[0].name}"))
        plotted_accel.extend(dataclasses.replace(a, name=f"{unit} {a.name}")
                             for a in axes if a.accel is not None and a.name == "accel_x")
        if unit == "unit1":
            csv_path = write_csv_record(
                args.out / "demo-record.csv.gz",
                record.rate_deg_s,
                record.sample_rate_hz,
                axis_names=record.axis_names,
                comment=f"station demo, {record.source}, gyros deg/s, accelerometers m/s^2",
                temperature_c=record.temperature_c,
                accel_m_s2=record.accel_m_s2,
                accel_axis_names=record.accel_axis_names,
            )
    true = {"Q": ("urad", "Q_urad"), "N": ("deg/sqrt(h)", "N_deg_rt_h"), "B": ("deg/h", "B_deg_h")}
    if not args.json:
        print(f"\ntrue values (model {Path(demo_model()).name}): " + ", ".join(
            f"{term} {family.value(DEMO_TRUE[term], unit):.4g} {family.label(unit)}"
            for term, (unit, _) in true.items()))
        accel_true = demo_accel_true()
        print("true accelerometer values: velocity random walk "
              f"{accel_true['vrw_m_s_rt_h']:.4g} m/s/sqrt(h), bias instability "
              f"{accel_true['bias_instability_ug']:.4g} ug, acceleration random walk "
              f"{accel_true['accel_rw_m_s_h1_5']:.4g} m/s/h^1.5")
    from station.output.plots import plot_allan  # matplotlib: imported only when a plot is made

    png_path = plot_allan(
        plotted,
        args.out / "demo-allan.png",
        title="station demo: two simulated VG951 gyros, axis x",
    )
    files = {"run": str(path), "record": str(csv_path), "png": str(png_path)}
    if plotted_accel:
        files["accel_png"] = str(plot_allan(
            plotted_accel, args.out / "demo-allan-accel.png",
            title="station demo: the two simulated units' accelerometers, axis accel_x"))
    if args.json:
        print_json({"run": str(path), "model": demo_model(), "units": list(totals.values()),
                    "true": {key: DEMO_TRUE[term] for term, (_, key) in true.items()}
                    | {"bias_deg_h": DEMO_BIAS_DEG_H, "accel": demo_accel_true()},
                    "files": files},
                   family)
        return 0
    print(f"wrote {path} (try: station analyze {path} --unit unit2), {csv_path} and "
          + " and ".join(v for k, v in files.items() if k.endswith("png")))
    print(f"done in {time.monotonic() - t0:.1f} s")
    return 0
