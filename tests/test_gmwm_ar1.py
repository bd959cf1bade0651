"""GMWM correlation times below one sample period, and bad model strings at the command line.

An AR(1) with ``phi < e^-1`` has a correlation time ``T = -dt / ln(phi)`` shorter than one
sample period; the estimator reaches it (``phi -> 0``) for AR(1) and Gauss-Markov terms
alike. Records are simulated here from the AR(1) recursion with parameters set here.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from analysis.gmwm.estimator import gmwm
from analysis.gmwm.models import KINDS, GmwmModel
from analysis.gmwm.wavelet import haar_wavelet_variance
from station.cli import main
from station.storage.csv_records import write_csv_record

FS = 100.0
PHI, AR1_STD, RW_STEP = 0.2, 0.3, 2e-5  # AR(1) stationary std (deg/s), rate step per sample


def ar1_record(seed: int, n: int) -> np.ndarray:
    """AR(1) of coefficient PHI and stationary std AR1_STD plus a rate random walk (deg/s)."""
    rng = np.random.default_rng(seed)
    innovation = rng.standard_normal(n) * AR1_STD * math.sqrt(1.0 - PHI**2)
    ar1 = signal.lfilter([1.0], [1.0, -PHI], innovation)
    return ar1 + np.cumsum(rng.standard_normal(n) * RW_STEP)


@pytest.mark.parametrize("phi", [1e-6, 0.01, 0.2, 0.9])
def test_ar1_wavelet_variance_holds_down_to_phi_near_zero(phi: float):
    dt = 1.0 / FS
    shape = math.log(dt / -math.log(phi))
    tau = dt * 2.0 ** np.arange(12)
    wv = KINDS["ar1"].unit_wv(tau, shape, dt)
    # the same from the structure function of the sums of AR(1) samples (module docstring)
    d = KINDS["ar1"].unit_structure
    np.testing.assert_allclose(
        wv, (4 * d(tau, shape, dt) - d(2 * tau, shape, dt)) / (4 * tau**2), rtol=1e-9
    )
    # as phi -> 0 the AR(1) is white: variance s^2 per sample, nu^2 = s^2 dt / (2 tau);
    # off it by at most (1 + phi) / (1 - phi) - 1 (the long-tau ratio)
    white = 0.5 * dt / tau
    assert np.max(np.abs(wv / white - 1)) <= (1 + phi) / (1 - phi) - 1 + 1e-12


def test_ar1_below_one_sample_period_is_recovered_within_its_standard_error():
    rate = ar1_record(3, 400_000)
    fit = gmwm(haar_wavelet_variance(rate, FS, min_blocks=2), "ar1+rw")
    phi, se = fit.values["ar1_phi"], fit.stderr["ar1_phi"]
    assert fit.free[fit.model.slices()[0][1]], "phi held at a bound"
    assert phi < math.exp(-1.0) - 0.1 and 0 < se < 0.05, (phi, se)
    assert abs(phi - PHI) < 2.0 * se, (phi, se)
    assert fit.values["ar1_sigma_deg_h"] == pytest.approx(AR1_STD * 3600, rel=0.02)


def test_a_gauss_markov_term_reaches_below_one_sample_period():
    # AR(1) samples of phi 0.2 are a Gauss-Markov of T = 0.62 dt, observed at points
    # rather than as sample means: the fitted correlation time lies below dt, off its bound
    wv = haar_wavelet_variance(ar1_record(4, 200_000), FS, min_blocks=2)
    fit = gmwm(wv, "gm+rw")
    tau = fit.values["gm_tau_s"]
    assert 0.05 / FS < tau < 1.0 / FS, tau
    assert fit.free[fit.model.slices()[0][1]]


@pytest.fixture(scope="module")
def short_record(tmp_path_factory) -> Path:
    rate = np.random.default_rng(0).standard_normal((512, 1))
    return write_csv_record(tmp_path_factory.mktemp("gmwm_bad") / "short.csv", rate, FS,
                            axis_names=["x"])


@pytest.mark.parametrize(
    ("model", "names"),
    [
        ("wn+ar2+rw", "unknown GMWM term 'ar2'"),
        ("wn+rw+wn", "term 'wn' appears twice"),
        ("wn+rw+RW", "term 'rw' appears twice"),
        ("wn+gm*4+rw", "10 parameters, more than the 9 wavelet scales"),
        ("wn+gm*40", "more than 31 terms"),
    ],
)
def test_bad_model_strings_are_one_line_and_exit_2(short_record: Path, model: str, names: str,
                                                   capsys):
    assert main(["analyze", str(short_record), "--method", "gmwm", "--model", model]) == 2
    err = capsys.readouterr().err
    assert names in err and "Traceback" not in err, err
    assert len(err.strip().splitlines()) == 1, err


def test_every_level_the_record_holds_is_a_gmwm_scale():
    from analysis.gmwm.selection import gmwm_analysis

    n = 5000
    sel = gmwm_analysis(ar1_record(5, n), FS, model="wn+rw")
    assert len(sel.wavelet.tau_s) == math.floor(math.log2(n))
    assert GmwmModel.parse(sel.best.model.name).n_params == 2
