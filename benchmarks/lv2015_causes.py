"""Why our re-run of the WLS paper's Monte Carlo (Lv 2015, tables 1-6) differs from it.

Two differences are measured here, each candidate cause by simulation:

1. Our run-to-run spreads are smaller than the paper's for every method. Candidates: how
   B was simulated (the paper cites, as its ref. [4], a FOG model of white noise plus one
   first-order Gauss-Markov process; we use Kasdin flicker noise), the tau grid (every m
   up to N/2, or N/9), the estimator (cluster or overlapping), the record length. For
   each variant the table prints, per method, the geometric mean over the three gyros and
   the three terms of (paper's spread / ours), and of |mean error| (paper's / ours).
2. The paper's 50-fold WLS gain over OLS on CRG20's B (mean error 0.1 % against 45.1 %).
   ``--studies S`` repeats the 30-run CRG20 study S times with independent seeds and
   prints how the mean error of each method varies from study to study.

    python -m benchmarks.lv2015_causes --runs 30
    python -m benchmarks.lv2015_causes --runs 30 --studies 8
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from station.evaluation.reproduce import PAPER_GYROS, Lv2015Setup, reproduce_lv2015

VARIANTS: dict[str, Lv2015Setup] = {
    "ours: Kasdin flicker B, cluster AVAR, every m to N/2, 4 h": Lv2015Setup(),
    "B as the station's Gauss-Markov bank (flat plateau)": Lv2015Setup(bias_noise="bank"),
    "B as one Gauss-Markov process, T = 10 s": Lv2015Setup(
        bias_noise="markov", markov_correlation_s=10.0
    ),
    "B as one Gauss-Markov process, T = 100 s": Lv2015Setup(
        bias_noise="markov", markov_correlation_s=100.0
    ),
    "B as one Gauss-Markov process, T = 1000 s": Lv2015Setup(
        bias_noise="markov", markov_correlation_s=1000.0
    ),
    "every m up to N/9 only": Lv2015Setup(max_clusters_m=9),
    "overlapping AVAR (every m to N/2)": Lv2015Setup(estimator="overlapping"),
    "1 h records instead of 4 h": Lv2015Setup(duration_s=3600.0),
    "24 min records (1/10 of the samples)": Lv2015Setup(duration_s=1440.0),
    "6 min records (1/40 of the samples)": Lv2015Setup(duration_s=360.0),
}


def ratios(table: dict) -> dict[str, tuple[float, float]]:
    """Per method: geometric means over gyros and terms of paper/our spread and of paper/our
    |mean error| (terms the paper printed '-' for, or with a zero error, left out)."""
    out = {}
    for method in ("ols", "ols40", "wls"):
        spread, error = [], []
        for gyro in table["gyros"]:
            entry = next(m for m in gyro["methods"] if m["method"] == method)
            for term in "QNB":
                ours, paper = entry[term], entry["paper"][term]
                if paper is None or ours["std"] is None:
                    continue
                spread.append(paper["std"] / ours["std"])
                if ours["error_percent"] > 0 and paper["error_percent"] > 0:
                    error.append(paper["error_percent"] / ours["error_percent"])
        out[method] = (math.exp(np.mean(np.log(spread))), math.exp(np.mean(np.log(error))))
    return out


def crg20_b(table: dict) -> str:
    gyro = next(g for g in table["gyros"] if g["name"] == "CRG20")
    parts = []
    for method in ("ols", "wls", "logwls"):
        s = next(m for m in gyro["methods"] if m["method"] == method)["B"]
        parts.append(f"{method} {s['error_percent']:.1f} % (rms {s['rms_error_percent']:.1f} %)")
    return "CRG20 B mean error: " + ", ".join(parts)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=30)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--studies", type=int, default=0, help="repeat the CRG20 study this many times")
    p.add_argument("--variants", default=None, help="comma-separated variant numbers (1-based)")
    args = p.parse_args(argv)
    start = time.monotonic()
    names = list(VARIANTS)
    if args.variants:
        names = [names[int(i) - 1] for i in args.variants.split(",")]
    if args.studies == 0:
        print(
            f"# lv2015_causes: {args.runs} runs per gyro, seed {args.seed}; per method the "
            "geometric "
            f"mean over 3 gyros x 3 terms of paper/ours (spread; |mean error|)"
        )
        for name in names:
            table = reproduce_lv2015(
                args.runs, args.seed, workers=args.workers, setup=VARIANTS[name]
            )
            r = ratios(table)
            cells = "  ".join(f"{m} {r[m][0]:5.1f}x; {r[m][1]:5.1f}x" for m in r)
            print(f"{name:<58} {cells}  | {crg20_b(table)}")
    else:
        print(
            f"# lv2015_causes: CRG20 only, {args.studies} independent studies of {args.runs} runs"
        )
        errors: dict[str, list[float]] = {"ols": [], "ols40": [], "wls": [], "logwls": []}
        for study in range(args.studies):
            table = reproduce_lv2015(
                args.runs, args.seed + 1000 * (study + 1), workers=args.workers, gyros=("CRG20",)
            )
            gyro = table["gyros"][0]
            for m in gyro["methods"]:
                if m["method"] in errors:
                    errors[m["method"]].append(m["B"]["error_percent"])
            print(
                f"study {study + 1}: " + ", ".join(f"{k} {v[-1]:.1f} %" for k, v in errors.items())
            )
        paper = {m: PAPER_GYROS[2].published[m]["B"][1] for m in ("ols", "ols40", "wls")}
        for method, values in errors.items():
            v = np.array(values)
            print(
                f"{method:<7} mean error of B over studies: median {np.median(v):.1f} %, "
                f"range {v.min():.1f}-{v.max():.1f} %"
                + (f" (paper {paper[method]} %)" if method in paper else "")
            )
        ratio = np.array(errors["ols"]) / np.maximum(np.array(errors["wls"]), 1e-9)
        print(
            f"OLS/WLS ratio of mean errors: median {np.median(ratio):.1f}, range {ratio.min():.1f}-"
            f"{ratio.max():.1f} (paper 451)"
        )
    print(f"# {time.monotonic() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
