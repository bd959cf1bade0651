"""The figures a spec sheet prints where the record cannot tell a rate random walk from a
ramp or a bias instability (issue 28): N 0.1 deg/sqrt(h) + K 1.0 deg/h^1.5, 10 Hz, 6 h.

Each record comes from the station's streaming simulator (:mod:`analysis.models.simulation`, as
``station simulate`` writes it) and is analysed as ``station analyze --json`` does
(:func:`station.evaluation.analyze.analyze_record`). Printed per estimator, over the seeds:
K's mean, how many of the ``value +- stderr`` intervals hold the truth, the mean standard
error over the spread between seeds (1 when honest), how often K is 0; and N's.

* ``sheet``: the figure the spec sheet prints (``station grade``, its PDF, HTML and JSON):
  the K of the reading the record supports best
  (:func:`station.evaluation.readings.best_supported`), its error the half-width that
  covers every reading the record allows (issue 38; ``benchmarks/bench_sheet_readings.py``
  counts those intervals at 95 %);
* ``printed``: the K of the printed reading (``fit.values`` of ``station analyze --json``);
* ``selected``: the term selection's reading alone;
* ``gmwm wn+rw``: the GMWM in the true model form (``--method gmwm --model wn+rw``).

    python -m benchmarks.bench_ambiguity            # seeds 28000-28019 (no test uses them)
    python -m benchmarks.bench_ambiguity --seeds 40 --first 28100
    python -m benchmarks.bench_ambiguity --sets 28400 28600 28800   # each set, then pooled
    python -m benchmarks.bench_ambiguity --no-gmwm --sets $(seq 81000 20 81580)  # 30 sets

With several sets, each set's rows are printed, then the rows pooled over all seeds and how
many sets meet the issue's goals for K: a set of 20 holds an honest 1-sigma interval's
truth 11-18 times in about 92 % of sets (binomial, p = 0.68), so the pooled coverage and
se/spread, and the share of sets meeting the goals, are the figures to judge by.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from analysis.fit.least_squares import NoiseCoefficients
from analysis.gmwm.selection import gmwm_analysis
from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, NoiseModel, RateRandomWalk
from station.evaluation.analyze import analyze_record
from station.evaluation.readings import (
    Reading,
    alternative_readings,
    best_supported,
    covering_interval,
)
from station.model.records import RateRecord

TRUE_N, TRUE_K, HOURS, RATE_HZ = 0.1, 1.0, 6.0, 10.0


def _row(name: str, values: list[float], errors: list[float], truth: float) -> str:
    v, e = np.array(values), np.array(errors)
    spread = float(np.std(v, ddof=1))
    cover = int(np.sum(np.abs(v - truth) <= e))
    return (f"{name:<22} mean {v.mean():.4g} ({v.mean() / truth - 1:+.1%})  sd {spread:.3g}  "
            f"within 1 se {cover}/{len(v)}  se/sd {e.mean() / spread:.2f}  "
            f"zero {int(np.sum(v == 0))}/{len(v)}")


Rows = dict[str, tuple[list[float], list[float]]]


def sheet_figure(fit: NoiseCoefficients, term: str) -> tuple[float, float]:
    """The value the spec sheet prints for ``term`` (the reading the record supports best,
    :func:`station.evaluation.readings.best_supported`) and, as a 1-sigma error, the
    larger distance from it to an end of its interval covering every reading (as
    :func:`station.evaluation.grading.grade_figure` prints it at one sigma)."""
    sheet = best_supported(fit)
    value, err = sheet.values[term] or 0.0, sheet.stderr[term] or 0.0
    printed = Reading(sheet.terms, value, max(value - err, 0.0), value + err)
    low, high = covering_interval(printed, alternative_readings(sheet, term, 1.0))
    if low is None or high is None:
        return value, float("nan")
    return value, max(high - value, value - low)


def _run_set(model: NoiseModel, first: int, count: int, gmwm: bool = True) -> Rows:
    """Simulate and analyse seeds ``first`` .. ``first + count - 1``; print one line each
    (``gmwm``: also the GMWM in the true model form)."""
    got: Rows = {}
    ambiguous = 0
    start = time.perf_counter()
    for seed in range(first, first + count):
        rate = simulate(model, HOURS * 3600.0, RATE_HZ, seed=seed).rate_deg_s
        axis = analyze_record(RateRecord(rate, RATE_HZ, ("x",)))[0]
        fit = axis.fit
        # the selection's reading: the alternative it preferred, where the sheet took K's
        selected = next((a.fit for a in fit.alternatives
                         if a.gauss_markov is None and a.criterion_delta is not None
                         and a.criterion_delta <= 0 and "K" not in a.fit.terms), fit)
        ambiguous += bool(fit.alternatives)
        sheet_k, sheet_n = sheet_figure(fit, "K"), sheet_figure(fit, "N")
        rows: list[tuple[str, float | None, float | None]] = [
            ("sheet K", *sheet_k),
            ("printed K", fit.values["K"], fit.stderr["K"]),
            ("selected K", selected.values["K"], selected.stderr["K"]),
            ("sheet N", *sheet_n),
            ("printed N", fit.values["N"], fit.stderr["N"]),
            ("selected N", selected.values["N"], selected.stderr["N"]),
        ]
        if gmwm:
            g = gmwm_analysis(rate[:, 0], RATE_HZ, model="wn+rw").best
            rows += [("gmwm wn+rw K", g.values["rw_deg_h_rt_h"], g.stderr["rw_deg_h_rt_h"]),
                     ("gmwm wn+rw N", g.values["wn_deg_rt_h"], g.stderr["wn_deg_rt_h"])]
        for name, value, err in rows:
            values, errors = got.setdefault(name, ([], []))
            values.append(float(value or 0.0))
            errors.append(float(err) if err is not None else float("nan"))
        print(f"seed {seed}: terms {fit.terms}, K {fit.values['K']:.3g} +- "
              f"{fit.stderr['K'] or float('nan'):.2g}, sheet K {sheet_k[0]:.3g} +- "
              f"{sheet_k[1]:.2g}; alternatives "
              f"{[a.fit.terms for a in fit.alternatives]}", flush=True)
    print(f"\nN {TRUE_N} deg/sqrt(h) + K {TRUE_K} deg/h^1.5, {HOURS:g} h at {RATE_HZ:g} Hz, "
          f"seeds {first}-{first + count - 1}, "
          f"{time.perf_counter() - start:.0f} s; ambiguous in {ambiguous}/{count}")
    _print_rows(got)
    return got


def meets_goals(values: list[float], errors: list[float], truth: float = TRUE_K) -> bool:
    """The issue's goals for a set of 20: mean within 15 % of the truth, the truth within
    1 se in 11-18, the mean standard error 0.5-2 times the spread between seeds."""
    v, e = np.array(values), np.array(errors)
    ratio = float(np.nanmean(e) / np.std(v, ddof=1))
    cover = int(np.sum(np.abs(v - truth) <= e))
    return abs(v.mean() / truth - 1.0) <= 0.15 and 11 <= cover <= 18 and 0.5 <= ratio <= 2.0


def _print_rows(got: Rows) -> None:
    for name, (values, errors) in got.items():
        truth = TRUE_K if name.endswith("K") else TRUE_N
        print(_row(name, values, errors, truth))


def main() -> None:
    """Simulate, analyse and print the figures (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="seeds per set (default 20)")
    parser.add_argument("--first", type=int, default=28000, help="first seed of one set")
    parser.add_argument("--sets", type=int, nargs="+",
                        help="first seed of each of several sets (instead of --first)")
    parser.add_argument("--no-gmwm", action="store_true",
                        help="leave out the GMWM in the true model form (faster)")
    args = parser.parse_args()
    model = NoiseModel((AngleRandomWalk(N_deg_rt_h=TRUE_N), RateRandomWalk(K_deg_h_1_5=TRUE_K)))
    pooled: Rows = {}
    met: dict[str, list[int]] = {}
    for first in args.sets or [args.first]:
        for name, (values, errors) in _run_set(model, first, args.seeds,
                                               gmwm=not args.no_gmwm).items():
            into = pooled.setdefault(name, ([], []))
            into[0].extend(values)
            into[1].extend(errors)
            if name.endswith("K") and not meets_goals(values, errors):
                met.setdefault(name, []).append(first)
    if args.sets and len(args.sets) > 1:
        print(f"\npooled over {len(args.sets)} sets ({len(args.sets) * args.seeds} seeds)")
        _print_rows(pooled)
        print(f"\nsets meeting the goals for K (mean within 15 %, 11-18 within 1 se, "
              f"se/spread 0.5-2), of {len(args.sets)}:")
        for name in pooled:
            if name.endswith("K"):
                missed = met.get(name, [])
                print(f"{name:<22} {len(args.sets) - len(missed)}"
                      + (f" (missed: sets {', '.join(map(str, missed))})" if missed else ""))


if __name__ == "__main__":
    main()
