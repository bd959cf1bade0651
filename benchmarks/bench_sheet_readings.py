"""Whether the sheet's intervals are honest where the record allows several readings
(issue 38): N 0.1 deg/sqrt(h) + B 0.3 deg/h records and N 0.1 + K 1.0 deg/h^1.5 records,
6 h at 10 Hz, as ``benchmarks/bench_ambiguity.py`` builds them.

Each record comes from the station's streaming simulator (:mod:`analysis.models.simulation`)
and is analysed as ``station grade`` does (:func:`station.evaluation.analyze.analyze_record`);
the sheet's reading is :func:`station.evaluation.readings.best_supported` and each figure's
95 % interval :func:`station.evaluation.readings.covering_interval` over the readings the
record allows, as :func:`station.evaluation.grading.grade_figure` prints them. Counted over
the seeds:

* N+B records: K's interval reaches 0; B's interval holds the true B;
* N+K records: K's interval holds the true K; B's interval reaches 0;
* both: how often the sheet prints K > 0 (the fault of the largest-reading sheet).

    python -m benchmarks.bench_sheet_readings                 # 20 of each, seeds 38000-
    python -m benchmarks.bench_sheet_readings --seeds 40 --first 38500
"""

from __future__ import annotations

import argparse
import time

from analysis.fit.least_squares import NoiseCoefficients
from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, BiasInstability, NoiseModel, RateRandomWalk
from station.evaluation.analyze import analyze_record
from station.evaluation.figure_intervals import normal_quantile
from station.evaluation.readings import (
    Reading,
    alternative_readings,
    best_supported,
    covering_interval,
)
from station.model.records import RateRecord

TRUE_N, TRUE_B, TRUE_K, HOURS, RATE_HZ, CONFIDENCE = 0.1, 0.3, 1.0, 6.0, 10.0, 0.95


def sheet_interval(fit: NoiseCoefficients, term: str, z: float
                   ) -> tuple[float, float | None, float | None]:
    """(value, low, high) the sheet prints of ``term`` at the normal quantile ``z`` (``fit``
    the analysis' fit; the sheet's reading is chosen here)."""
    sheet = best_supported(fit)
    value, err = sheet.values[term] or 0.0, sheet.stderr[term]
    printed = (Reading(sheet.terms, value, None, None) if err is None
               else Reading(sheet.terms, value, max(value - z * err, 0.0), value + z * err))
    low, high = covering_interval(printed, alternative_readings(sheet, term, z))
    return value, low, high


def _holds(low: float | None, high: float | None, truth: float) -> bool:
    return low is not None and high is not None and low <= truth <= high


def run(kind: str, first: int, count: int) -> dict[str, int]:
    """Simulate and grade ``count`` records of ``kind`` ("B": N+B, "K": N+K) from seed
    ``first``; print one line each, return the counts."""
    second = BiasInstability(B_deg_h=TRUE_B) if kind == "B" else RateRandomWalk(
        K_deg_h_1_5=TRUE_K)
    model = NoiseModel((AngleRandomWalk(N_deg_rt_h=TRUE_N), second))
    z = normal_quantile(CONFIDENCE)
    counts = {"K reaches 0": 0, "K holds truth": 0, "B reaches 0": 0, "B holds truth": 0,
              "K printed > 0": 0}
    start = time.perf_counter()
    for seed in range(first, first + count):
        rate = simulate(model, HOURS * 3600.0, RATE_HZ, seed=seed).rate_deg_s
        fit = analyze_record(RateRecord(rate, RATE_HZ, ("x",)))[0].fit
        k, b = sheet_interval(fit, "K", z), sheet_interval(fit, "B", z)
        counts["K reaches 0"] += k[1] == 0.0
        counts["K holds truth"] += _holds(k[1], k[2], TRUE_K)
        counts["B reaches 0"] += b[1] == 0.0
        counts["B holds truth"] += _holds(b[1], b[2], TRUE_B)
        counts["K printed > 0"] += k[0] > 0
        print(f"seed {seed}: analysis {fit.terms}, sheet {best_supported(fit).terms}; "
              f"K {k[0]:.3g} [{k[1] or 0:.3g}, {k[2] or 0:.3g}], "
              f"B {b[0]:.3g} [{b[1] or 0:.3g}, {b[2] or 0:.3g}]; alternatives "
              f"{[a.terms for a in fit.alternatives]}", flush=True)
    print(f"N {TRUE_N} + {'B ' + str(TRUE_B) if kind == 'B' else 'K ' + str(TRUE_K)}, "
          f"{HOURS:g} h at {RATE_HZ:g} Hz, seeds {first}-{first + count - 1}, "
          f"{time.perf_counter() - start:.0f} s, {CONFIDENCE:.0%} intervals:")
    for name, n in counts.items():
        print(f"  {name:<16} {n}/{count}")
    return counts


def main() -> None:
    """Simulate, grade and count (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="records of each kind")
    parser.add_argument("--first", type=int, default=38000, help="first seed")
    parser.add_argument("--kind", choices=("B", "K", "both"), default="both")
    args = parser.parse_args()
    for kind in ("B", "K") if args.kind == "both" else (args.kind,):
        run(kind, args.first, args.seeds)
        print()


if __name__ == "__main__":
    main()
