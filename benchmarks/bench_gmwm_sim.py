"""Which GMWM recovers a known ``wn+ar1+rw``: the station's weights, R's weights, or R itself.

On the ADIS16405 imu1 x record R's ``gmwm`` and the station disagree on the random walk
(``bench_gmwm_r``). This benchmark asks which estimator is right when the truth is known:
records of the real one's length and rate are simulated from the fitted models (the
station's own fit, the station's fit under R's weights, and R's fit when ``Rscript`` and
the ``gmwm`` package are present), a few seeds each, and fitted by

* the station (``gmwm``: efficient weights, floored when the J test rejects);
* the station under R's scales and weights (``Omega = diag((ci_high - ci_low)^-2)`` of the
  95 % eta3 intervals, ``gmwm_with_covariance``);
* R's ``gmwm(WN() + AR1() + RW(), x)`` (its defaults), when present.

Printed per truth and estimator: the mean and the spread (standard deviation over the
seeds) of each estimate in data-sheet units, and the RMS of ``log(estimate / truth)`` of
the white noise and the random walk (a term estimated at zero counts as 1/10 of the truth).
The records are the model's own recursions (per sample: white noise of variance
``sigma2``, ``x_t = phi x_{t-1} + e_t`` with ``Var e = s^2 (1 - phi^2)``, a random walk of
step variance ``gamma2``), i.e. R's parametrization.

Run from the repository root::

    python -m benchmarks.bench_gmwm_sim [--seeds 3] [--r-lib /tmp/rlib]
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy import signal

from analysis.gmwm.estimator import GMWM_MIN_BLOCKS, gmwm, gmwm_with_covariance
from analysis.gmwm.models import GmwmModel
from analysis.gmwm.wavelet import haar_wavelet_variance
from analysis.units.conversions import S_PER_H
from benchmarks.bench_gmwm_r import MODEL, RECORD, r_values, run_r
from station.storage.runs import read_record

FS = 100.0
#: Estimates compared on log scale (the variances of the white noise and the random walk).
LOG_KEYS = ("wn_deg_rt_h", "rw_deg_h_rt_h")


def simulate(values: dict[str, float], n: int, seed: int) -> np.ndarray:
    """``n`` samples (deg/s) of ``wn+ar1+rw`` with data-sheet ``values`` (keys of the model)."""
    rng = np.random.default_rng(seed)
    rt_h = math.sqrt(S_PER_H)
    sigma2 = (values["wn_deg_rt_h"] / rt_h) ** 2 * FS
    phi = values["ar1_phi"]
    s2 = (values["ar1_sigma_deg_h"] / S_PER_H) ** 2
    gamma2 = (values["rw_deg_h_rt_h"] / (S_PER_H * rt_h)) ** 2 / FS
    ar1 = signal.lfilter([1.0], [1.0, -phi], rng.standard_normal(n) * math.sqrt(s2 * (1 - phi**2)))
    return (rng.standard_normal(n) * math.sqrt(sigma2) + ar1
            + np.cumsum(rng.standard_normal(n) * math.sqrt(gamma2)))


def fits(rate: np.ndarray, model: GmwmModel, r_lib: str | None
         ) -> tuple[dict[str, dict[str, float]], str]:
    """Each estimator's data-sheet estimates from one record, and the station's weights."""
    own = gmwm(haar_wavelet_variance(rate, FS, min_blocks=GMWM_MIN_BLOCKS), model)
    out = {"station": own.values}
    wv = haar_wavelet_variance(rate, FS, min_blocks=GMWM_MIN_BLOCKS, ci="eta3", confidence=0.95)
    out["station, R's weights"] = gmwm_with_covariance(
        wv, model, np.diag((wv.ci_high - wv.ci_low) ** 2)).values
    if r_lib is not None:
        r = run_r(rate, r_lib)
        if r is not None:
            out["R gmwm"] = r_values(r["names"], [float(v) for v in r["estimate"]], FS)
    return out, own.weights


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--r-lib", default=None,
                        help="R library holding gmwm (R CMD INSTALL --library); omit: no R")
    args = parser.parse_args()
    model = GmwmModel.parse(MODEL)
    keys = [k for k, _, _ in model.keys()]
    record = read_record(RECORD, sample_rate_hz=FS, units="deg/s")
    rate = np.ascontiguousarray(record.rate_deg_s[:, 0])
    n = len(rate)
    truths, weights = fits(rate, model, args.r_lib)
    print(f"{MODEL}: {args.seeds} records of {n} samples at {FS:g} Hz per truth; truths fitted "
          f"to {RECORD.name} x (station's weights there: {weights}); mean (spread) per "
          "estimator; RMS log error of N and K")
    width = max(len(k) for k in keys) + 2
    for truth_name, truth in truths.items():
        found: dict[str, list[dict[str, float]]] = {}
        used = []
        for seed in range(args.seeds):
            estimates, weights = fits(simulate(truth, n, seed), model, args.r_lib)
            used.append(weights)
            for name, values in estimates.items():
                found.setdefault(name, []).append(values)
        print(f"\ntruth: {truth_name}'s fit (station's weights: {', '.join(used)})")
        print(f"{'':24}" + "".join(f"{k:>{width + 10}}" for k in keys) + "   rms log N, K")
        print(f"{'truth':24}" + "".join(f"{truth[k]:>{width + 10}.4g}" for k in keys))
        for name, runs in found.items():
            cells = []
            for k in keys:
                v = np.array([run[k] for run in runs])
                cells.append(f"{np.mean(v):.4g} ({np.std(v):.2g})")
            errors = [
                math.sqrt(np.mean([math.log(max(run[k], 0.1 * truth[k]) / truth[k]) ** 2
                                   for run in runs]))
                if truth[k] > 1e-3 * max(run[k] for run in runs) else math.nan
                for k in LOG_KEYS
            ]
            print(f"{name:24}" + "".join(f"{c:>{width + 10}}" for c in cells)
                  + "   " + ", ".join(f"{e:.2f}" for e in errors))


if __name__ == "__main__":
    main()
