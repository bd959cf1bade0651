"""The station's GMWM beside R's ``gmwm`` package (the reference implementation) on one record.

R's ``gmwm`` (github.com/SMAC-Group/gmwm, AGPL-3) is run here as a separate program, through
``Rscript``, never linked or copied. Getting it on Debian::

    apt-get install -y r-base-core r-base-dev r-cran-rcpp r-cran-rcpparmadillo \\
        r-cran-ggplot2 r-cran-scales r-cran-reshape2
    git clone https://github.com/SMAC-Group/gmwm /tmp/gmwm-src   # or any copy of its source
    mkdir -p /tmp/rlib && R CMD INSTALL --no-docs --library=/tmp/rlib /tmp/gmwm-src

and pass ``--r-lib /tmp/rlib`` (compiling takes ~30 min on two cores). Without R the station's
side alone is printed. R's fit: ``gmwm(WN() + AR1() + RW(), x)`` (its defaults: the
``floor(log2 N)`` Haar scales, the diagonal weights ``Omega = diag((ci_high - ci_low)^-2)``
of its 95 % "eta3" intervals, its starting-value search).

Printed, side by side, in data-sheet units (N deg/sqrt(h), AR(1) std deg/h and phi, K
deg/h^1.5):

* R's estimates and objective;
* the station's objective at R's estimates under R's weights (the formulas agree: equal);
* the station's fit under R's scales and weights (``gmwm_with_covariance``): its objective
  should be at most R's (within 5 %);
* the station's own fit (``station analyze --method gmwm --model wn+ar1+rw``: its efficient
  weights, or the data's variances plus a 2 % floor when the J test rejects the model).

Whether each estimator recovers a known model: ``benchmarks/bench_gmwm_sim.py``.

Run from the repository root::

    python -m benchmarks.bench_gmwm_r [--record FILE] [--axis 0] [--r-lib /tmp/rlib]

(default record: ``../shared/real-data/adis16405_imu1_gyro_deg_s_100hz.csv.gz``, axis x).
"""

from __future__ import annotations

import argparse
import math
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from analysis.gmwm.estimator import GMWM_MIN_BLOCKS, gmwm, gmwm_with_covariance
from analysis.gmwm.models import GmwmModel
from analysis.gmwm.wavelet import haar_wavelet_variance
from analysis.units.conversions import S_PER_H
from station.storage.runs import read_record

REAL_DATA = Path(__file__).resolve().parents[2] / "shared" / "real-data"
RECORD = REAL_DATA / "adis16405_imu1_gyro_deg_s_100hz.csv.gz"
MODEL = "wn+ar1+rw"
R_SCRIPT = """
args <- commandArgs(trailingOnly = TRUE)
if (nchar(args[2]) > 0) .libPaths(c(args[2], .libPaths()))
suppressPackageStartupMessages(library(gmwm))
x <- scan(args[1], quiet = TRUE)
t0 <- proc.time()[["elapsed"]]
fit <- gmwm(WN() + AR1() + RW(), x)
cat("seconds", proc.time()[["elapsed"]] - t0, "\\n")
cat("names", rownames(fit$estimate), "\\n")
cat("estimate", format(fit$estimate[, 1], digits = 17), "\\n")
cat("objective", format(fit$obj.fun, digits = 17), "\\n")
cat("wv", format(fit$wv.empir, digits = 17), "\\n")
cat("ci_low", format(fit$ci.low, digits = 17), "\\n")
cat("ci_high", format(fit$ci.high, digits = 17), "\\n")
"""


def run_r(rate: np.ndarray, r_lib: str) -> dict[str, list[str]] | None:
    """R's fit of ``wn+ar1+rw`` to ``rate`` (deg/s) as ``{line key: values}``; None without R."""
    rscript = shutil.which("Rscript")
    if rscript is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        data, script = Path(tmp) / "x.txt", Path(tmp) / "fit.R"
        np.savetxt(data, rate, fmt="%.17g")
        script.write_text(R_SCRIPT)
        proc = subprocess.run([rscript, str(script), str(data), r_lib], capture_output=True,
                              text=True, timeout=3600)
    if proc.returncode != 0:
        print(f"Rscript failed ({proc.returncode}): {proc.stderr.strip()[-400:]}")
        return None
    return {line.split()[0]: line.split()[1:] for line in proc.stdout.splitlines() if line.strip()}


def r_values(names: list[str], est: list[float], fs: float) -> dict[str, float]:
    """R's estimates (``WN`` sigma2, ``AR1`` phi, ``SIGMA2`` its innovation variance, ``RW``
    gamma2; per sample, deg/s) in the station's data-sheet keys: N = sqrt(sigma2 / fs)
    deg/sqrt(s), s^2 = sigma2 / (1 - phi^2), K = sqrt(gamma2 fs) deg/s/sqrt(s)."""
    by_name = dict(zip(names, est, strict=True))
    wn, phi, ar, rw = (by_name[k] for k in ("WN", "AR1", "SIGMA2", "RW"))
    rt_h = math.sqrt(S_PER_H)
    return {
        "wn_deg_rt_h": math.sqrt(wn / fs) * rt_h,
        "ar1_sigma_deg_h": math.sqrt(ar / (1.0 - phi * phi)) * S_PER_H,
        "ar1_phi": phi,
        "rw_deg_h_rt_h": math.sqrt(rw * fs) * S_PER_H * rt_h,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record", type=Path, default=RECORD)
    parser.add_argument("--axis", type=int, default=0)
    parser.add_argument("--r-lib", default="",
                        help="R library holding gmwm (R CMD INSTALL --library)")
    args = parser.parse_args()
    record = read_record(args.record, sample_rate_hz=100.0, units="deg/s")
    rate = np.ascontiguousarray(record.rate_deg_s[:, args.axis])
    fs = record.sample_rate_hz
    dt = 1.0 / fs
    model = GmwmModel.parse(MODEL)
    keys = [k for k, _, _ in model.keys()]
    rows: dict[str, tuple[dict[str, float], float, str]] = {}

    t0 = time.perf_counter()
    own = gmwm(haar_wavelet_variance(rate, fs, min_blocks=GMWM_MIN_BLOCKS), model)
    rows["station (own weights)"] = (own.values, own.objective,
                                     f"{own.weights}, {time.perf_counter() - t0:.1f} s")
    # R's scales and weights: its 95 % eta3 intervals, Omega = diag((hi - lo)^-2)
    wv = haar_wavelet_variance(rate, fs, min_blocks=GMWM_MIN_BLOCKS, ci="eta3", confidence=0.95)
    r = run_r(rate, args.r_lib)
    if r is not None:
        low, high = np.array(r["ci_low"], float), np.array(r["ci_high"], float)
        ci_diff = max(np.max(np.abs(low / wv.ci_low - 1)), np.max(np.abs(high / wv.ci_high - 1)))
        print(f"R: {len(r['wv'])} scales, station {len(wv.tau_s)}; WV max rel. diff "
              f"{np.max(np.abs(np.array(r['wv'], float) / wv.wv - 1)):.1e}, intervals "
              f"{ci_diff:.1e}")
    else:
        print("R's gmwm not run (no Rscript, or it failed): the station's side alone")
        low, high = wv.ci_low, wv.ci_high
    sd = high - low
    t0 = time.perf_counter()
    under_r = gmwm_with_covariance(wv, model, np.diag(sd**2))
    rows["station (R's weights)"] = (under_r.values, under_r.objective,
                                     f"{time.perf_counter() - t0:.1f} s")
    if r is not None:
        values = r_values(r["names"], [float(v) for v in r["estimate"]], fs)
        nu = model.wv(model.internal(values, dt), wv.tau_s, dt)
        j_station = float(np.sum(((wv.wv - nu) / sd) ** 2))
        rows["R gmwm"] = (values, float(r["objective"][0]),
                          f"{float(r['seconds'][0]):.1f} s; station's J there {j_station:.4g}")
    width = max(len(k) for k in keys)
    print(f"\n{MODEL} on {args.record.name}, axis {args.axis}, {len(rate)} samples at {fs:g} Hz")
    print(f"{'':24}" + "".join(f"{k:>{width + 2}}" for k in keys) + f"{'objective':>12}  note")
    for name, (vals, obj, note) in rows.items():
        print(f"{name:24}" + "".join(f"{vals[k]:>{width + 2}.4g}" for k in keys)
              + f"{obj:>12.4g}  {note}")
    if r is not None:
        ratio = rows["station (R's weights)"][1] / rows["R gmwm"][1]
        print(f"\nstation / R objective under R's scales and weights: {ratio:.3f}")


if __name__ == "__main__":
    main()
