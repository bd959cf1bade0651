"""Haar wavelet variance: the Allan relation, each term's closed form by Monte Carlo, intervals,
robustness.

Monte Carlo records come from :mod:`analysis.models.simulation` (every sample the mean rate over its
period, the convention of the closed forms) except the AR(1) term, which is point-sampled
by a recursion written here; each check states its number of runs and its tolerance, set
at about four standard errors of the Monte Carlo mean.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from analysis.allan.estimators import overlapping_allan_variance
from analysis.errors import TooFewSamplesError
from analysis.gmwm.models import KINDS, GmwmModel
from analysis.gmwm.wavelet import (
    haar_wavelet_variance,
    huber_constant,
    huber_efficiency,
)
from analysis.models.simulation import simulate
from analysis.models.terms import (
    AngleRandomWalk,
    BiasInstability,
    GaussMarkov,
    NoiseModel,
    Quantization,
    RateRamp,
    RateRandomWalk,
)

FS = 10.0


def test_wavelet_variance_is_half_the_overlapping_allan_variance_at_every_dyadic_tau():
    rng = np.random.default_rng(11)
    x = rng.standard_normal((5000, 2)).cumsum(axis=0) * 0.01 + rng.standard_normal((5000, 2))
    wv = haar_wavelet_variance(x, FS)
    allan = overlapping_allan_variance(x, FS, taus=wv.tau_s)
    np.testing.assert_allclose(wv.wv, allan.avar / 2.0, rtol=1e-12)
    np.testing.assert_allclose(wv.avar, allan.avar, rtol=1e-12)
    assert wv.tau_s[0] == pytest.approx(1 / FS) and np.all(np.diff(np.log2(wv.m)) == 1)
    assert wv.m[-1] <= 5000 // 8 < 2 * wv.m[-1]
    one = wv.axis(1)
    np.testing.assert_allclose(one.wv, haar_wavelet_variance(x[:, 1], FS).wv, rtol=1e-12)


# (term, noise model, data-sheet values of the GMWM term)
TERMS = {
    "wn": (AngleRandomWalk(N_deg_rt_h=2.0), {"wn_deg_rt_h": 2.0}),
    "qn": (Quantization(Q_urad=300.0), {"qn_urad": 300.0}),
    "rw": (RateRandomWalk(K_deg_h_1_5=200.0), {"rw_deg_h_rt_h": 200.0}),
    "dr": (RateRamp(R_deg_h2=5e4), {"dr_deg_h2": 5e4}),
    "bi": (BiasInstability(B_deg_h=20.0), {"bi_deg_h": 20.0}),
    "gm": (GaussMarkov(sigma_deg_h=30.0, tau_s=2.0), {"gm_sigma_deg_h": 30.0, "gm_tau_s": 2.0}),
}


@pytest.mark.parametrize("code", list(TERMS))
def test_each_terms_closed_form_wavelet_variance_matches_monte_carlo(code):
    noise, values = TERMS[code]
    runs, n = 200, 2048
    x = simulate(NoiseModel(terms=(noise,)), n / FS, FS, n_axes=runs, seed=5).rate_deg_s
    wv = haar_wavelet_variance(x, FS, ci="eta3")
    model = GmwmModel.parse(code)
    theory = model.wv(model.internal(values, 1 / FS), wv.tau_s, 1 / FS)
    mean = wv.wv.mean(axis=1)
    if code == "dr":  # deterministic: every run the same, exact
        np.testing.assert_allclose(mean, theory, rtol=1e-9)
        return
    sem = wv.wv.std(axis=1, ddof=1) / math.sqrt(runs)
    assert np.all(np.abs(mean - theory) < 4.5 * sem + 1e-3 * theory), (code, mean / theory)


def test_ar1_closed_form_matches_a_point_sampled_recursion():
    runs, n, sigma, phi = 300, 2048, 0.3, 0.9
    rng = np.random.default_rng(8)
    e = rng.standard_normal((n + 500, runs)) * sigma * math.sqrt(1 - phi**2)
    x = signal.lfilter([1.0], [1.0, -phi], e, axis=0)[500:]
    wv = haar_wavelet_variance(x, FS, ci="eta3")
    model = GmwmModel.parse("ar1")
    values = {"ar1_sigma_deg_h": sigma * 3600.0, "ar1_phi": phi}
    p = model.internal(values, 1 / FS)
    theory = model.wv(p, wv.tau_s, 1 / FS)
    sem = wv.wv.std(axis=1, ddof=1) / math.sqrt(runs)
    assert np.all(np.abs(wv.wv.mean(axis=1) - theory) < 4.5 * sem)
    back, _ = model.physical(p, None, 1 / FS)
    assert back == pytest.approx(values)


@pytest.mark.parametrize("code", list(KINDS))
def test_each_terms_structure_function_gives_its_wavelet_variance(code):
    kind = KINDS[code]
    dt = 0.01
    tau = dt * 2.0 ** np.arange(14)
    shape = math.log(0.37)
    d = lambda s: kind.unit_structure(s, shape, dt)  # noqa: E731
    from_structure = (4 * d(tau) - d(2 * tau)) / (4 * tau**2)
    if code == "dr":
        assert np.all(from_structure == 0)  # deterministic: no randomness to correlate
    else:
        np.testing.assert_allclose(from_structure, kind.unit_wv(tau, shape, dt), rtol=1e-9)


def test_pw_interval_covers_white_noise_at_its_nominal_rate():
    runs, n = 400, 4096
    x = np.random.default_rng(3).standard_normal((n, runs))
    wv = haar_wavelet_variance(x, FS)  # +-1 sigma, chi-square with the PW edf
    true = 1.0 / (2.0 * wv.m)  # unit white noise per sample
    inside = (wv.ci_low <= true[:, None]) & (true[:, None] <= wv.ci_high)
    coverage = inside.mean(axis=1)
    assert np.all(coverage[:7] > 0.60) and np.all(coverage[:7] < 0.76), coverage
    # the edf of the fine scales is Greenhall's computed edf of the same Allan values
    allan = overlapping_allan_variance(x[:, 0], FS, taus=wv.tau_s)
    np.testing.assert_allclose(np.median(wv.edf, axis=1)[:5], allan.edf[:5], rtol=0.06)
    sym = haar_wavelet_variance(x[:, :50], FS, ci="asymptotic")
    half = (sym.ci_high - sym.wv)[:3]
    np.testing.assert_allclose(half, np.sqrt(sym.variance[:3]), rtol=1e-9)


def test_robust_wavelet_variance_resists_outliers_and_matches_on_clean_data():
    c = huber_constant(0.6)
    assert huber_efficiency(c) == pytest.approx(0.6, abs=1e-9)
    rng = np.random.default_rng(21)
    x = rng.standard_normal(20_000)
    clean = haar_wavelet_variance(x, FS)
    robust = haar_wavelet_variance(x, FS, robust=True)
    assert np.all(np.abs(robust.wv - clean.wv)[:8] < 3.0 * np.sqrt(robust.variance[:8]))
    assert np.all(robust.variance > clean.variance)  # the price of robustness: 1/efficiency
    dirty = x.copy()
    dirty[rng.choice(len(x), 20, replace=False)] += 200.0  # 0.1 % of samples, 200 sigma
    plain = haar_wavelet_variance(dirty, FS)
    hardy = haar_wavelet_variance(dirty, FS, robust=True)
    plain_error, hardy_error = (
        np.abs(plain.wv / clean.wv - 1)[:6],
        np.abs(hardy.wv / clean.wv - 1)[:6],
    )
    assert np.all(plain_error > 2.0)
    # Huber's bias grows with the share of coefficients an outlier touches (2m per outlier)
    assert np.all(hardy_error < 0.25) and np.all(hardy_error < 0.05 * plain_error), (
        hardy_error,
        plain_error,
    )


def test_bad_inputs_are_refused():
    with pytest.raises(TooFewSamplesError, match="too few"):
        haar_wavelet_variance(np.zeros(7), FS)
    with pytest.raises(ValueError, match="ci must be"):
        haar_wavelet_variance(np.zeros(100), FS, ci="nope")
    with pytest.raises(ValueError, match="non-finite"):
        haar_wavelet_variance(np.array([1.0, np.nan] * 50), FS)


def test_gaps_leave_out_every_haar_window_that_holds_a_missing_sample():
    x = np.random.default_rng(4).standard_normal(40_000)
    gapped = x.copy()
    gapped[10_000:10_500] = np.nan
    wv = haar_wavelet_variance(gapped, FS, gaps=True)
    # the same coefficients, taken from the two stretches on their own
    parts = [x[:10_000], x[10_500:]]
    for j, m in enumerate(wv.m[:6]):
        sums = [
            haar_wavelet_variance(p, FS, max_level=j + 1).wv[j] * (len(p) - 2 * m + 1)
            for p in parts
        ]
        count = sum(len(p) - 2 * m + 1 for p in parts)
        assert wv.wv[j] == pytest.approx(sum(sums) / count, rel=1e-9)
    assert wv.n_samples == 39_500 and wv.n_coefficients[0] == 39_500 - 2 * 1 + 1 - 1
    with pytest.raises(ValueError, match="non-finite"):
        haar_wavelet_variance(gapped, FS)


def test_levels_longer_than_every_gap_free_window_are_left_out_not_read_as_zero():
    """A gap every 3000 samples: windows of 2 m = 4096 all hold one, so the record says
    nothing of m = 2048 and above (before, those levels read 0 (deg/s)^2)."""
    x = np.random.default_rng(5).standard_normal(36_000)
    x[::3000] = np.nan
    wv = haar_wavelet_variance(x, FS, gaps=True)
    assert wv.m[-1] == 1024 and np.all(wv.wv > 0) and np.all(wv.variance > 0)
    assert wv.n_coefficients[-1] > 0
    every_other = np.random.default_rng(6).standard_normal(1_000)
    every_other[::2] = np.nan
    with pytest.raises(TooFewSamplesError, match="without a gap"):
        haar_wavelet_variance(every_other, FS, gaps=True)
