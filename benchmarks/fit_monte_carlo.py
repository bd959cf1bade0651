"""Monte Carlo of the default five-term fit (``logwls`` with term selection) over pairs and
triples of the IEEE terms.

For each case, simulated records (the station's streaming simulator: Q white angle, N
white rate, B a Gauss-Markov bank flat to 0.07 %, K rate random walk, R a deterministic
ramp) are analysed as ``station analyze`` does
(overlapping Allan variance on the log grid, or ``--grid long``: log-spaced up to N/2,
two clusters) and fitted with every term as a candidate. The table prints, per case:
how often the fitted model holds exactly the true terms; per true term its mean error,
the spread over seeds, the mean standard error and the share of seeds whose
``value +- stderr`` holds the truth (68 % when honest); per absent term how often it was
invented. A true term counts as *resolved* when a fit of the true model to the exact
expected curve gives its variance coefficient a standard error under a third of itself
(the record resolves it at 3 sigma); the 15 % mean-error rule applies to those.

    python -m benchmarks.fit_monte_carlo --seeds 40
    python -m benchmarks.fit_monte_carlo --seeds 40 --grid long
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from analysis.allan.estimators import log_m, overlapping_allan_variance
from analysis.fit.least_squares import (
    BETA_FACTOR,
    COEFFICIENT_NAMES,
    TERMS,
    TO_DATASHEET,
    fit_noise_terms,
    theoretical_avar,
)
from analysis.fit.uncertainty import value_covariance
from analysis.models.simulation import simulate
from analysis.models.terms import (
    AngleRandomWalk,
    BiasInstability,
    NoiseModel,
    Quantization,
    RateRamp,
    RateRandomWalk,
)

TERM_CLASS = {"Q": Quantization, "N": AngleRandomWalk, "B": BiasInstability, "K": RateRandomWalk,
              "R": RateRamp}

#: name: (true coefficients in data-sheet units, hours, sample rate in Hz)
CASES: dict[str, tuple[dict[str, float], float, float]] = {
    "Q+N (MEMS, 1 h at 100 Hz)": ({"Q": 20.0, "N": 0.5}, 1.0, 100.0),
    "N+B (4 h)": ({"N": 0.1, "B": 1.0}, 4.0, 10.0),
    "N+K (6 h, issue 22)": ({"N": 0.1, "K": 1.0}, 6.0, 10.0),
    "N+K (24 h)": ({"N": 0.1, "K": 1.0}, 24.0, 10.0),
    "N+R (6 h)": ({"N": 0.1, "R": 4.0}, 6.0, 10.0),
    "B+K (12 h)": ({"B": 0.5, "K": 2.0}, 12.0, 10.0),
    "Q+N+B (VG951, 4 h)": ({"Q": 7.555e-2, "N": 7.636e-3, "B": 1.246e-1}, 4.0, 10.0),
    "N+B+K (24 h)": ({"N": 0.05, "B": 0.3, "K": 0.3}, 24.0, 10.0),
    "Q+N+K (8 h at 50 Hz)": ({"Q": 20.0, "N": 0.5, "K": 10.0}, 8.0, 50.0),
    "N+B+R (24 h)": ({"N": 0.1, "B": 1.0, "R": 1.7}, 24.0, 10.0),
}


def simulate_terms(true: dict[str, float], n: int, fs: float, seed: int) -> np.ndarray:
    """A rate record (deg/s) holding the terms of ``true`` (data-sheet units), from the
    station's streaming simulator (its bias instability is flat to 0.07 % from 1/fs on)."""
    model = NoiseModel(tuple(TERM_CLASS[t](**{COEFFICIENT_NAMES[t]: v}) for t, v in true.items()))
    return simulate(model, n / fs, fs, seed=seed).rate_deg_s[:, 0]


def tau_grid(n: int, fs: float, grid: str) -> np.ndarray:
    """The analysis grid: station analyze's log grid, or log-spaced up to N/2 (``long``)."""
    if grid == "long":
        return np.unique(np.rint(np.geomspace(1, n // 2, 110)).astype(np.int64)) / fs
    return log_m(n) / fs


def resolved_terms(true: dict[str, float], n: int, fs: float, grid: str) -> str:
    """Terms whose variance coefficient a fit of the true model to the exact curve gets to
    better than a third of itself (the record resolves them at 3 sigma)."""
    exact = overlapping_allan_variance(np.zeros(n), fs, taus=tau_grid(n, fs, grid))
    avar = theoretical_avar(true, exact.tau_s)
    beta = np.array([BETA_FACTOR[t] * (true.get(t, 0.0) / TO_DATASHEET[t]) ** 2 for t in TERMS])
    edf = 2.0 / value_covariance(exact, beta).relative_variance
    curve = dataclasses.replace(exact, avar=avar, ci_low=avar, ci_high=avar, edf=edf)
    terms = "".join(t for t in TERMS if t in true)
    fit = fit_noise_terms(curve, method="logwls", terms=terms, select=False)
    out = ""
    for t in terms:
        beta = BETA_FACTOR[t] * (true[t] / TO_DATASHEET[t]) ** 2
        se_coef = fit.stderr[t]
        # delta method back to beta: se_beta = 2 sqrt(c beta) se_coef (in base units)
        se_beta = 2.0 * math.sqrt(BETA_FACTOR[t] * beta) * se_coef / TO_DATASHEET[t]
        if se_beta < beta / 3.0:
            out += t
    return out


def one_seed(
    task: tuple[str, int, str],
) -> tuple[str, dict[str, float | None], dict[str, float | None], str]:
    name, seed, grid = task
    true, hours, fs = CASES[name]
    n = int(round(hours * 3600 * fs))
    y = simulate_terms(true, n, fs, seed)
    allan = overlapping_allan_variance(y, fs, taus=tau_grid(n, fs, grid))
    fit = fit_noise_terms(allan, method="logwls")
    return name, fit.values, fit.stderr, fit.terms


def summarize(name: str, rows: list, resolved: str) -> list[str]:
    true = CASES[name][0]
    exact = "".join(t for t in TERMS if t in true)
    models: dict[str, int] = {}
    for r in rows:
        models[r[3]] = models.get(r[3], 0) + 1
    top = ", ".join(f"{m or '-'} {c}" for m, c in sorted(models.items(), key=lambda kv: -kv[1])[:3])
    lines = [f"{name}: {len(rows)} seeds, true model {exact} chosen in "
             f"{100 * models.get(exact, 0) / len(rows):.0f} % (models: {top})"]
    for t in TERMS:
        v = np.array([np.nan if r[1][t] is None else r[1][t] for r in rows], dtype=float)
        e = np.array([np.nan if r[2][t] is None else r[2][t] for r in rows], dtype=float)
        if t in true:
            err = 100.0 * (np.nanmean(v) / true[t] - 1.0)
            cover = 100.0 * np.mean(np.abs(v - true[t]) <= e)
            flag = "resolved" if t in resolved else "not resolved at 3 sigma"
            lines.append(
                f"  {t}: true {true[t]:.4g}  mean error {err:+6.1f} %  spread {np.nanstd(v):.3g}  "
                f"mean se {np.nanmean(e):.3g}  1-sigma coverage {cover:3.0f} %  "
                f"reported 0 in {100 * np.mean(v == 0):3.0f} %  ({flag})"
            )
        else:
            invented = 100.0 * np.mean(v > 0)
            if invented:
                lines.append(f"  {t}: absent, invented in {invented:.0f} % of seeds")
    return lines


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=40)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--grid", choices=("log", "long"), default="log")
    p.add_argument(
        "--cases", default=None, help="comma-separated case numbers (1-based); default all"
    )
    args = p.parse_args(argv)
    names = list(CASES)
    if args.cases:
        names = [names[int(i) - 1] for i in args.cases.split(",")]
    start = time.monotonic()
    tasks = [(name, seed, args.grid) for name in names for seed in range(args.seeds)]
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(one_seed, tasks, chunksize=2))
    print(f"# fit_monte_carlo: logwls with term selection, {args.seeds} seeds per case, "
          f"{args.grid} grid, {time.monotonic() - start:.0f} s")
    for name in names:
        true, hours, fs = CASES[name]
        resolved = resolved_terms(true, int(round(hours * 3600 * fs)), fs, args.grid)
        print("\n".join(summarize(name, [r for r in results if r[0] == name], resolved)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
