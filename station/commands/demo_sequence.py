"""``station demo --sequence``: a turn-on repeatability test of two simulated gyros.

Two simulated VG951 gyros sit on a simulated fixture (a Modbus relay module on
127.0.0.1 switches each one's supply); the demo profile's ``turn_on`` sequence switches
them on, records their turn-on and warm-up, switches them off and lets them cool, five
times, time-warped (half an hour of test in about half a minute). Every switch-on draws
a new turn-on bias and turn-on time; a warm-up transient decays after each. The
sequence file is graded as ``station grade`` grades it, and each figure is printed beside
the truth the simulation drew.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from analysis.models.power_cycle import PowerCycleModel
from analysis.sequences.cycle_stats import summarize_cycles

#: The simulated units' turn-on behaviour (their truths).
DEMO_POWER = PowerCycleModel(turn_on_s=4.0, turn_on_jitter_s=0.8, turn_on_bias_deg_h=2.0,
                             warmup_deg_h=20.0, warmup_tau_s=30.0)
DEMO_RATE_HZ = 5.0
DEMO_WARP = 100.0
DEMO_BAND_DEG_H = 1.0
DEMO_RECORD_S = 300.0

DEMO_PROFILE = """\
# Written by `station demo --sequence`: the VG951 of Lv 2015 table 3 on a short turn-on test.
name = "VG951-turn-on-demo"
version = "1"
model = "VG951"
description = "Turn-on repeatability demo: 5 switch-ons, 4 min each, time-warped"

[test]
sample_rate_hz = {rate}
duration_s = {record}
warmup_s = 30.0
axes = ["x"]

[grading]
rule = "guard-banded"
confidence = 0.95
grades = ["A", "B"]

[figures.arw_fit]
unit = "deg/sqrt(h)"
limits = {{ A = 0.012, B = 0.025 }}

[figures.bias_instability]
unit = "deg/h"

[sequence.turn_on]
description = "IEEE Std 952 / 1431 turn-on to turn-on repeatability, turn-on and warm-up time"
steps = ["power_on", "record {record:g}s", "power_off", "cool_down 30s", "repeat {cycles}"]
bias_after_s = 150
warmup_band_deg_h = {band}
warmup_average_s = 40

[sequence.turn_on.figures.turn_on_repeatability]
unit = "deg/h"
limits = {{ A = 3.0, B = 6.0 }}

[sequence.turn_on.figures.warmup_time]
unit = "s"
limits = {{ A = 150, B = 300 }}

[sequence.turn_on.figures.turn_on_time]
unit = "s"
limits = {{ A = 8, B = 15 }}
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    """``--sequence`` and ``--cycles`` of ``station demo``."""
    p.add_argument("--sequence", action="store_true",
                   help="run a time-warped turn-on repeatability test of two simulated gyros "
                        "on a simulated fixture instead, and print its figures beside the truths")
    p.add_argument("--cycles", type=int, default=5, metavar="N",
                   help="with --sequence: switch-ons (default 5, the fewest IEEE 952 asks)")


def demo_units(seed: int) -> tuple[str, str]:
    """Device URLs of the two simulated units (their turn-on behaviour in URL keys)."""
    m = DEMO_POWER
    query = (f"protocol=xbus&model=VG951&rate={DEMO_RATE_HZ:g}&warp={DEMO_WARP:g}"
             f"&turn_on_s={m.turn_on_s:g}&turn_on_jitter_s={m.turn_on_jitter_s:g}"
             f"&turn_on_bias_deg_h={m.turn_on_bias_deg_h:g}&warmup_deg_h={m.warmup_deg_h:g}"
             f"&warmup_tau_s={m.warmup_tau_s:g}")
    return (f"sim+serial://VG951?{query}&seed={seed}",
            f"sim+serial://VG951?{query}&seed={seed + 1}")


def _truths(seed: int, cycles: int) -> dict[str, float]:
    """What the simulation drew for one unit: the spread of its turn-on biases, the mean
    of its turn-on times (to its first sample's end), its warm-up time."""
    # here: the simulated devices import the transports' libraries, not for ``--help``
    from devices.sim.powered import turn_on_draw

    draws = [turn_on_draw(DEMO_POWER, seed, n, 1) for n in range(1, cycles + 1)]
    biases = summarize_cycles([d.bias_deg_h[0] for d in draws])
    ons = summarize_cycles([d.turn_on_s + 1.0 / DEMO_RATE_HZ for d in draws])
    warm = DEMO_POWER.warmup_time_s(DEMO_BAND_DEG_H, record_s=DEMO_RECORD_S,
                                    die_temperature_c=lambda t: np.full_like(t, 25.0))
    return {"turn_on_repeatability_deg_h": biases.std or math.nan,
            "turn_on_time_s": ons.mean or math.nan, "warmup_time_s": warm}


def run(args: argparse.Namespace) -> int:
    """Run the sequence, grade it, print the figures beside the truths."""
    from station.services.grade import GradeRequest, RunSource, grade
    from station.services.sequence import SequenceRequest, prepare_sequence

    if args.cycles < 5:  # the turn-on profile's figures refuse fewer (IEEE Std 952 / 1431)
        from station.errors import UsageError

        raise UsageError(f"--cycles {args.cycles}: a turn-on repeatability needs at least 5 "
                         "switch-ons (IEEE Std 952 and 1431)")
    t0 = time.monotonic()
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    profile = out / "demo-sequence-profile.toml"
    profile.write_text(DEMO_PROFILE.format(rate=DEMO_RATE_HZ, record=DEMO_RECORD_S,
                                           cycles=args.cycles, band=DEMO_BAND_DEG_H),
                       encoding="utf-8")
    path = out / "demo-sequence.h5"
    path.unlink(missing_ok=True)
    shutil.rmtree(out / "demo-sequence.segments", ignore_errors=True)
    units = demo_units(args.seed)
    print(f"turn-on test of two simulated VG951 gyros on a simulated fixture: {args.cycles} "
          f"switch-ons, warp x{DEMO_WARP:g}, into {path} ...", file=sys.stderr)
    request = SequenceRequest("turn_on", str(profile), units, power=("sim",), out=path,
                              operator="station demo")
    with prepare_sequence(request, notify=lambda text: print(f"  {text}", file=sys.stderr)
                          ) as prepared:
        run_ = prepared.execute()
    graded = grade(GradeRequest(RunSource(run_.path), store=False)).graded
    names = (("turn_on_repeatability_deg_h", "turn-on repeatability", "deg/h"),
             ("warmup_time_s", "warm-up time", "s"), ("turn_on_time_s", "turn-on time", "s"))
    for n, unit in enumerate(graded.units):
        seq = unit.sequence
        assert seq is not None
        truth = _truths(args.seed + n, args.cycles)
        print(f"\n{unit.unit.unit_id} ({units[n]})  grade {unit.grade}")
        print(f"  {'figure':<30} {'measured':>10} {'95 % interval':>22} {'truth':>10}")
        for key, label, unit_text in names:
            f = seq.figures[key]
            interval = "-" if f.low is None or f.high is None else f"[{f.low:.3g}, {f.high:.3g}]"
            value = "-" if f.value is None else f"{f.value:.4g}"
            print(f"  {label + ' [' + unit_text + ']':<30} {value:>10} {interval:>22} "
                  f"{truth[key]:>10.4g}")
    print(f"\ntruths: repeatability = the spread of the turn-on biases the units drew (their "
          f"population: {DEMO_POWER.turn_on_bias_deg_h:g} deg/h); turn-on time = the mean of "
          f"the drawn times to the end of the first sample; warm-up time = when "
          f"{DEMO_POWER.warmup_deg_h:g} deg/h exp(-t/{DEMO_POWER.warmup_tau_s:g} s) enters "
          f"+-{DEMO_BAND_DEG_H:g} deg/h of the settled bias")
    print(f"wrote {run_.path} (try: station grade {run_.path}, or station report {run_.path})")
    print(f"done in {time.monotonic() - t0:.1f} s")
    return 0
