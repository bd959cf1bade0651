"""``station demo``: the main job on a simulated gyro, start to finish, in under a minute.

Simulates a static run of a three-axis tactical-grade gyro with known noise terms,
analyzes it exactly as ``station analyze`` would, prints the spec figures beside the
true values, and writes the record (CSV) and the Allan deviation plot (PNG).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from analysis.noise import flicker_rate_noise, white_angle_noise, white_rate_noise
from analysis.units import arw_deg_rt_h_to_deg_rt_s, q_urad_to_deg, rate_deg_h_to_deg_s
from station.analyze import analyze_record, format_analysis
from station.record_files import RateRecord, write_csv_record

#: The demo gyro: a tactical FOG (the VG951 of Lv 2015 table 3) with a 3.6 deg/h bias.
DEMO_TRUE = {"Q": 7.555e-2, "N": 7.636e-3, "B": 1.246e-1}
DEMO_BIAS_DEG_H = 3.6


def simulate_demo_record(duration_s: float, sample_rate_hz: float, seed: int) -> RateRecord:
    """A simulated three-axis static record of the demo gyro (deg/s)."""
    n = int(duration_s * sample_rate_hz)
    rng = np.random.default_rng(seed)
    rate = (DEMO_BIAS_DEG_H / 3600.0
            + white_angle_noise(q_urad_to_deg(DEMO_TRUE["Q"]), n, sample_rate_hz, rng, n_axes=3)
            + white_rate_noise(arw_deg_rt_h_to_deg_rt_s(DEMO_TRUE["N"]), n, sample_rate_hz, rng, n_axes=3)
            + flicker_rate_noise(rate_deg_h_to_deg_s(DEMO_TRUE["B"]), n, sample_rate_hz, rng, n_axes=3))
    return RateRecord(rate, sample_rate_hz, ("gyro_x", "gyro_y", "gyro_z"), "simulated demo gyro")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``demo`` sub-command."""
    p = sub.add_parser("demo", help="simulate a gyro, analyze it, print its spec figures",
                       description=__doc__)
    p.add_argument("--duration", type=float, default=4.0, metavar="HOURS",
                   help="simulated run length in hours (default 4)")
    p.add_argument("--rate", type=float, default=10.0, metavar="HZ", help="sample rate (default 10 Hz)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", type=Path, default=Path("station-demo"),
                   help="folder for the record and the plot (default ./station-demo)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Simulate, analyze, print, write files."""
    t0 = time.monotonic()
    print(f"simulating {args.duration:g} h of a 3-axis gyro at {args.rate:g} Hz "
          f"(true Q {DEMO_TRUE['Q']} urad, N {DEMO_TRUE['N']} deg/sqrt(h), B {DEMO_TRUE['B']} deg/h, "
          f"bias {DEMO_BIAS_DEG_H} deg/h) ...", file=sys.stderr)
    record = simulate_demo_record(args.duration * 3600.0, args.rate, args.seed)
    print(f"analyzing {record.n_samples} samples per axis ...", file=sys.stderr)
    axes = analyze_record(record)
    print(format_analysis(axes))
    print(f"\ntrue values: Q {DEMO_TRUE['Q']} urad, N {DEMO_TRUE['N']} deg/sqrt(h), "
          f"B {DEMO_TRUE['B']} deg/h, bias {DEMO_BIAS_DEG_H} deg/h")
    args.out.mkdir(parents=True, exist_ok=True)
    csv_path = write_csv_record(args.out / "demo-record.csv.gz", record.rate_deg_s, record.sample_rate_hz,
                                axis_names=record.axis_names,
                                comment="simulated demo gyro (station demo), deg/s")
    from station.plots import plot_allan  # matplotlib: imported only when a plot is made

    png_path = plot_allan(axes, args.out / "demo-allan.png", title="station demo: simulated gyro")
    print(f"wrote {csv_path} (try: station analyze {csv_path}) and {png_path}")
    print(f"done in {time.monotonic() - t0:.1f} s")
    return 0
