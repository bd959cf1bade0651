"""GMWM against the Allan-curve fits, on models with a Gauss-Markov term and on the WLS paper's
gyros.

For each case, ``--runs`` simulated records; each is fitted in the *true model form* by

* ``gmwm``: the efficient GMWM on the dyadic Haar wavelet variance (:mod:`analysis.gmwm`);
* ``wls``: Lv 2015's weighted least squares (rows times the cluster count J) on the cluster
  Allan variance at every m, as the paper runs it;
* ``logwls``: the station's default Allan fit (log Allan variance, edf and octave-share
  weights, 2 % model floor, non-negative variances), on the overlapping Allan variance of
  the log grid for the Gauss-Markov models (as ``station analyze`` runs it) and on the
  cluster values at every m for the paper's gyros (as ``station reproduce lv2015`` does).

For the paper's gyros (Q, N, B) ``wls`` and ``logwls`` are :func:`analysis.fit.fit_noise_terms`
exactly as ``station reproduce lv2015`` runs them. For the Gauss-Markov models the Allan
fits need the Gauss-Markov term, which is not linear in its correlation time: they are
solved here the way the GMWM is (a grid over the correlation time with non-negative least
squares in the variances, then ``least_squares`` over everything), with each method's own
objective; the model Allan variance is twice the GMWM model's wavelet variance, exact at
every ``tau = m / fs``.

Printed: per case and parameter, the relative RMS error of each method over the runs, the
ratio of the GMWM's to the best Allan fit's, and the share of runs whose GMWM +-1 sigma
interval holds the true value (68 % if its standard errors are honest). With ``--timing``,
the GMWM on 2e6 samples of one axis (wavelet variance + fit; a given model and ``auto``),
process CPU and wall time, median of three. Run from the repository root::

    python -m benchmarks.bench_gmwm [--runs 20] [--seed 1] [--workers 2] [--timing]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize, special

from analysis.allan.estimators import (
    AllanResult,
    cluster_allan_variance,
    overlapping_allan_variance,
)
from analysis.fit.least_squares import DEFAULT_MODEL_ERROR, fit_noise_terms, log_tau_share
from analysis.gmwm.estimator import gmwm
from analysis.gmwm.models import GmwmModel
from analysis.gmwm.selection import gmwm_analysis
from analysis.gmwm.wavelet import haar_wavelet_variance
from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, GaussMarkov, NoiseModel, RateRandomWalk
from station.evaluation.reproduce import PAPER_GYROS, SAMPLE_RATE_HZ, simulate_paper_gyro

GM_RATE_HZ, GM_HOURS = 100.0, 6.0
METHODS = ("gmwm", "wls", "logwls")
QNB_KEYS = {"Q": "qn_urad", "N": "wn_deg_rt_h", "B": "bi_deg_h"}


@dataclass(frozen=True)
class Case:
    """A benchmark model: its GMWM form, true data-sheet values and how a record is made."""

    name: str
    model: str
    truth: dict[str, float]
    kind: str  # "gm" (analysis.models.simulation, 6 h at 100 Hz) or a paper gyro's index


def gm_case(sigma_deg_h: float) -> Case:
    return Case(
        f"wn 0.1 + GM {sigma_deg_h:g} deg/h, 100 s + RRW 0.5",
        "wn+gm+rw",
        {
            "wn_deg_rt_h": 0.1,
            "gm_sigma_deg_h": sigma_deg_h,
            "gm_tau_s": 100.0,
            "rw_deg_h_rt_h": 0.5,
        },
        "gm",
    )


CASES = [gm_case(0.5), gm_case(2.0)] + [
    Case(
        f"{g.name} (Lv 2015 {g.table})",
        "wn+qn+bi",
        {QNB_KEYS[t]: v for t, v in g.true.items()},
        str(i),
    )
    for i, g in enumerate(PAPER_GYROS)
]


def record_of(case: Case, seed: int) -> tuple[np.ndarray, float]:
    if case.kind == "gm":
        t = case.truth
        model = NoiseModel(terms=(AngleRandomWalk(N_deg_rt_h=t["wn_deg_rt_h"]),
                                  GaussMarkov(sigma_deg_h=t["gm_sigma_deg_h"], tau_s=t["gm_tau_s"]),
                                  RateRandomWalk(K_deg_h_1_5=t["rw_deg_h_rt_h"])))
        return simulate(model, GM_HOURS * 3600.0, GM_RATE_HZ, seed=seed).rate_deg_s[
            :, 0
        ], GM_RATE_HZ
    gyro = PAPER_GYROS[int(case.kind)]
    return simulate_paper_gyro(gyro.true, np.random.default_rng(seed)), SAMPLE_RATE_HZ


# ------------------------------------------------------------- Allan fits of a nonlinear model


class AllanModelFit:
    """``wls`` or ``logwls`` of a GMWM model form (with correlation times) to an Allan curve.

    Parameters: log variances and log correlation times; the model Allan variance is
    ``sum_t v_t g_t(tau; T_t)`` with ``g_t`` twice the term's unit wavelet variance.
    """

    GRID_PER_OCTAVE = 2

    def __init__(self, allan: AllanResult, model: GmwmModel, method: str) -> None:
        self.model, self.method = model, method
        self.tau = allan.tau_s
        self.avar = np.asarray(allan.avar, dtype=float)
        self.dt = 1.0 / allan.sample_rate_hz
        self.duration = allan.n_samples * self.dt
        if method == "wls":
            self.w = allan.n_clusters.astype(float)  # residual J (a - A), Lv 2015 eq. 11-14
            self.scale = float(np.max(np.abs(self.w * self.avar)))
        else:  # the logwls weights of analysis.fit: octave share over (2/edf + floor^2)
            edf = np.asarray(allan.edf, dtype=float)
            self.w = np.sqrt(log_tau_share(self.tau) / (2.0 / edf + DEFAULT_MODEL_ERROR**2))
            self.target = np.log(self.avar) - (special.digamma(edf / 2.0) - np.log(edf / 2.0))
        self.slices = model.slices()
        self.var_idx = [iv for iv, _ in self.slices]
        self.shape_idx = [ish for _, ish in self.slices if ish is not None]
        self._cache: tuple[tuple[float, ...], np.ndarray] | None = None

    def columns(self, x: np.ndarray) -> np.ndarray:
        """Allan variance of each term with unit variance at the shapes in ``x``, (n_tau,
        n_terms)."""
        key = tuple(float(x[i]) for i in self.shape_idx)
        if self._cache is None or self._cache[0] != key:
            cols = [2.0 * kind.unit_wv(self.tau, float(x[ish]) if ish is not None else 0.0, self.dt)
                    for kind, (_, ish) in zip(self.model.kinds, self.slices, strict=True)]
            self._cache = (key, np.column_stack(cols))
        return self._cache[1]

    def residual(self, x: np.ndarray) -> np.ndarray:
        model_avar = self.columns(x) @ np.exp(x[self.var_idx])
        if self.method == "wls":
            return self.w * (self.avar - model_avar) / self.scale
        return self.w * (self.target - np.log(np.maximum(model_avar, 1e-300)))

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        cols = self.columns(x)
        v = np.exp(x[self.var_idx])
        d = np.zeros((len(self.tau), len(x)))
        d[:, self.var_idx] = cols * v
        for c, (kind, (_, ish)) in enumerate(zip(self.model.kinds, self.slices, strict=True)):
            if ish is not None:
                h = 1e-5
                d[:, ish] = 2.0 * v[c] * (kind.unit_wv(self.tau, x[ish] + h, self.dt)
                                          - kind.unit_wv(self.tau, x[ish] - h, self.dt)) / (2 * h)
        if self.method == "wls":
            return -self.w[:, None] * d / self.scale
        model_avar = cols @ v
        return -(self.w / np.maximum(model_avar, 1e-300))[:, None] * d

    def start(self, shapes: np.ndarray) -> tuple[float, np.ndarray]:
        """Variances by NNLS for fixed correlation times (on the normal equations): objective, x."""
        x = np.zeros(self.model.n_params)
        x[self.shape_idx] = shapes
        cols = self.columns(x)
        if self.method == "wls":
            a, b = cols * self.w[:, None], self.avar * self.w
        else:  # relative residuals, the measured values standing in for the model
            a, b = cols * (self.w / self.avar)[:, None], self.w
        gram, rhs = a.T @ a, a.T @ b
        norm = np.sqrt(np.diag(gram))
        norm[norm == 0] = 1.0
        chol = linalg.cholesky(gram / np.outer(norm, norm) + 1e-12 * np.eye(len(norm)), lower=False)
        u, _ = optimize.nnls(chol, linalg.solve_triangular(chol, rhs / norm, trans="T"))
        v = u / norm
        x[self.var_idx] = np.log(np.maximum(v, 1e-12 * max(float(v.max()), 1e-300)))
        r = self.residual(x)
        return float(r @ r), x

    def fit(self) -> dict[str, float]:
        t_lo, t_hi = math.log(self.dt), math.log(self.duration)
        grid = np.linspace(t_lo, t_hi, int((t_hi - t_lo) / math.log(2) * self.GRID_PER_OCTAVE) + 1)
        _, x0 = min((self.start(np.array([g])) for g in grid), key=lambda s: s[0])
        lower = np.full(len(x0), -np.inf)
        upper = np.full(len(x0), np.inf)
        lower[self.shape_idx], upper[self.shape_idx] = t_lo, t_hi
        sol = optimize.least_squares(
            self.residual,
            x0,
            jac=self.jacobian,
            bounds=(lower, upper),
            method="trf",
            x_scale="jac",
            max_nfev=100,
        )
        best = np.array(sol.x)
        best[self.var_idx] = np.exp(sol.x[self.var_idx])
        values, _ = self.model.physical(best, None, self.dt)
        return values


# ------------------------------------------------------------------------------- one run


def one_run(task: tuple[int, int]) -> tuple[int, dict[str, dict[str, float]], dict[str, float]]:
    """Fit one record of one case with every method: (case, {method: values}, GMWM stderr)."""
    index, seed = task
    case = CASES[index]
    rate, fs = record_of(case, seed)
    model = GmwmModel.parse(case.model)
    fit = gmwm(haar_wavelet_variance(rate, fs), model)
    out = {"gmwm": fit.values}
    allan = cluster_allan_variance(rate, fs, taus="all")
    if case.kind == "gm":
        # wls as the paper runs it (cluster, every m); logwls as station analyze does (overlapping,
        # log grid)
        out["wls"] = AllanModelFit(allan, model, "wls").fit()
        out["logwls"] = AllanModelFit(overlapping_allan_variance(rate, fs), model, "logwls").fit()
    else:
        for method in ("wls", "logwls"):
            f = fit_noise_terms(allan, method=method, terms="QNB")
            out[method] = {
                QNB_KEYS[t]: (math.nan if f.values[t] is None else f.values[t]) for t in "QNB"
            }
    return index, out, fit.stderr


def run_cases(runs: int, seed: int, workers: int) -> None:
    tasks = [(i, seed * 100_000 + i * 1000 + r) for i in range(len(CASES)) for r in range(runs)]
    results: dict[int, list] = {i: [] for i in range(len(CASES))}
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for index, values, stderr in pool.map(one_run, tasks):
            results[index].append((values, stderr))
    took = time.perf_counter() - start
    print(
        f"GMWM against the Allan fits: {runs} runs per case, seed {seed}, {took:.0f} s with "
        f"{workers} workers\n"
    )
    print(
        f"{'case':<38}{'parameter':<17}{'true':>9}  "
        f"{'relative RMS error: gmwm':>24}{'wls':>9}{'logwls':>9}"
        f"{'gmwm/best':>10}{'+-1se cover':>12}"
    )
    for i, case in enumerate(CASES):
        rows = results[i]
        for key, true in case.truth.items():
            err = {
                m: math.sqrt(np.nanmean([(v[m][key] / true - 1.0) ** 2 for v, _ in rows]))
                for m in METHODS
            }
            cover = np.mean([abs(v["gmwm"][key] - true) <= se[key] for v, se in rows])
            best_allan = min(err["wls"], err["logwls"])
            print(
                f"{case.name:<38}{key:<17}{true:>9.4g}  "
                f"{100 * err['gmwm']:>23.1f}%{100 * err['wls']:>8.1f}%"
                f"{100 * err['logwls']:>8.1f}%{err['gmwm'] / best_allan:>10.2f}"
                f"{100 * cover:>11.0f}%"
            )
        print()


def timing(seed: int) -> None:
    n, fs = 2_000_000, 100.0
    t = CASES[1].truth
    model = NoiseModel(terms=(AngleRandomWalk(N_deg_rt_h=t["wn_deg_rt_h"]),
                              GaussMarkov(sigma_deg_h=t["gm_sigma_deg_h"], tau_s=t["gm_tau_s"]),
                              RateRandomWalk(K_deg_h_1_5=t["rw_deg_h_rt_h"])))
    rate = simulate(model, n / fs, fs, seed=seed).rate_deg_s[:, 0]
    print(f"GMWM on {n:.0e} samples of one axis (wavelet variance + fit), load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores:")
    for spec in ("wn+gm+rw", "auto"):
        cpu, wall = [], []
        for _ in range(3):
            c0, w0 = time.process_time(), time.perf_counter()
            sel = gmwm_analysis(rate, fs, model=spec)
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
        print(
            f"  model {spec:<9} -> {sel.best.model.name:<10} CPU {np.median(cpu):.2f} s, wall "
            f"{np.median(wall):.2f} s "
            f"(median of 3; {len(sel.ranking)} candidate(s))"
        )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", type=int, default=20, help="runs per case (default 20)")
    parser.add_argument("--seed", type=int, default=1, help="base seed (default 1)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--timing", action="store_true", help="only the 2e6-sample timing")
    args = parser.parse_args()
    if args.timing:
        timing(args.seed)
        return
    run_cases(args.runs, args.seed, args.workers)


if __name__ == "__main__":
    main()
