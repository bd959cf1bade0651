"""Resolution and stuck output against the gyro's noise in LSBs (run by hand, not in CI).

    python -m benchmarks.bench_resolution            # 2 seeds a case, about two minutes
    python -m benchmarks.bench_resolution --seeds 5

Records of a gyro at rest (white rate noise of sigma a sample plus a flicker floor at
the same level over 100 s, 1 h at 10 Hz) are rounded to a STIM300's rate LSB q = 2^-14
deg/s and graded with a profile of loose limits: for each sigma / q, the share of the
samples on the commonest value, the stuck-output review (docs/grading.md, "Resolution"),
the graded figures found under their quantization floor, and the fitted ARW against the
truth (with the rounding's own q^2/12 added: what a resolved record should show).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from analysis.models.noise import flicker_rate_noise, white_rate_noise
from station.evaluation.grading import grade_run
from station.evaluation.resolution import ConstantRecordError
from station.model.profiles import parse_profile
from station.model.records import RateRecord
from station.model.runs import RunInfo, UnitRun

Q = 2.0**-14
FS_HZ = 10.0
N = 36_000
PROFILE = """name = "BENCH"
version = "1"
model = "bench"
[transport]
url = "sim+serial://X?protocol=stim300&rate=10"
[test]
sample_rate_hz = 10.0
duration_s = 3600.0
warmup_s = 0.0
axes = ["x"]
[grading]
grades = ["A"]
[figures.arw_fit]
unit = "deg/sqrt(h)"
limits = { A = 1.0 }
[figures.bias_instability_fit]
unit = "deg/h"
limits = { A = 100.0 }
[figures.bias_stability_100s]
unit = "deg/h"
limits = { A = 100.0 }
[figures.bias]
unit = "deg/h"
limits = { A = 100.0 }
"""


def case(sigma_lsb: float, offset_lsb: float, seed: int) -> tuple[float, bool, int, float]:
    """(mode share, stuck, figures under their floor, fitted ARW / expected) of one record
    whose mean sits ``offset_lsb`` LSB from a step (0: on one, 0.5: between two)."""
    rng = np.random.default_rng(seed)
    sigma = sigma_lsb * Q
    white = white_rate_noise(sigma / math.sqrt(FS_HZ), N, FS_HZ, rng)
    flicker = flicker_rate_noise(sigma / 10.0, N, FS_HZ, rng)
    x = np.round((offset_lsb * Q + white + flicker) / Q) * Q
    unit = UnitRun("u", "bench", "-", RateRecord(x.reshape(-1, 1), FS_HZ, ("x",)),
                   lsb_deg_s=Q)
    try:
        graded = grade_run(RunInfo("bench", (unit,)), parse_profile(PROFILE)).units[0]
    except ConstantRecordError:  # refused: counted as stuck, every figure unresolved
        return 1.0, True, 4, 0.0
    axis = graded.axis("x")
    assert axis.resolution is not None
    arw = axis.figures[[f.name for f in axis.figures].index("arw_fit")].value or 0.0
    expected = 60.0 * math.sqrt((sigma**2 + Q**2 / 12.0) / FS_HZ)
    under = sum(not f.resolved for f in axis.graded_figures)
    return (axis.resolution.census.mode_share, bool(axis.resolution.stuck), under,
            arw / expected)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    args = parser.parse_args()
    print(f"{'sigma/q':>8} {'offset/q':>9} {'mode share':>11} {'stuck':>6} {'under floor':>12} "
          f"{'ARW fit / (sigma^2 + q^2/12)':>29}")
    for sigma_lsb in (0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 1.0, 3.0):
        for offset_lsb in (0.0, 0.5):
            rows = [case(sigma_lsb, offset_lsb, seed) for seed in range(args.seeds)]
            share = np.mean([r[0] for r in rows])
            stuck = sum(r[1] for r in rows)
            under = sum(r[2] for r in rows)
            ratio = np.mean([r[3] for r in rows])
            print(f"{sigma_lsb:8.2f} {offset_lsb:9.1f} {share:11.3f} {stuck:>3}/{len(rows):<2} "
                  f"{under:>6}/{4 * len(rows):<5} {ratio:29.3f}")

if __name__ == "__main__":
    main()
