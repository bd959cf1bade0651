"""The spectral process test of reconcile (analysis/reconcile/process_test.py): the model's
spectrum is the one the station's simulator draws, the test keeps its false-alarm rate on
clean records, and it names a faint Gauss-Markov process the Allan gap passes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.models import terms as t
from analysis.models.simulation import simulate
from analysis.reconcile.discrepancy import ComparisonCache
from analysis.reconcile.loop import reconcile
from analysis.reconcile.process_test import (
    detect_process,
    model_spectrum,
    periodogram,
    sampled_gauss_markov_spectrum,
)

FS_HZ = 10.0
BASE = t.NoiseModel(terms=(t.AngleRandomWalk(N_deg_rt_h=0.5), t.BiasInstability(B_deg_h=2.0)))
#: The base's white noise, deg/s per sample.
SIGMA_W = 0.5 / 60.0 * math.sqrt(FS_HZ)


@pytest.mark.parametrize("terms", [
    BASE.terms,
    (t.AngleRandomWalk(N_deg_rt_h=0.5), t.GaussMarkov(sigma_deg_h=20.0, tau_s=5.0)),
    (t.AngleRandomWalk(N_deg_rt_h=0.5), t.GaussMarkov(sigma_deg_h=20.0, tau_s=0.05)),
    (t.Quantization(Q_urad=20.0), t.AngleRandomWalk(N_deg_rt_h=0.5)),
    (t.AngleRandomWalk(N_deg_rt_h=0.5), t.RateRandomWalk(K_deg_h_1_5=3.0)),
], ids=["arw+bi", "arw+gm", "arw+fast-gm", "quantization+arw", "arw+rw"])
def test_the_model_spectrum_is_what_the_simulator_draws(terms: tuple) -> None:
    model = t.NoiseModel(terms=terms)
    rates = simulate(model, 3600.0, FS_HZ, n_axes=40, seed=3).rate_deg_s
    w, _ = periodogram(rates[:, 0])
    mean = np.mean([periodogram(rates[:, i])[1] for i in range(40)], axis=0)
    ratio = mean / model_spectrum(model, FS_HZ, w)
    # 40 records: about 3 % scatter over bins 10-100, 1 % above; the lowest bins lose some
    # power to the least-squares line each record is cleared of
    for lo, hi, tol in ((10, 100, 0.1), (100, 1000, 0.04), (1000, w.size, 0.02)):
        assert abs(float(ratio[lo:hi].mean()) - 1.0) < tol, (lo, hi, ratio[lo:hi].mean())
    assert 0.6 < float(ratio[:10].mean()) < 1.3


def test_the_sampled_process_spectrum_holds_the_variance_of_its_means() -> None:
    w = np.linspace(0.0, 2.0 * np.pi, 200_001)[:-1]
    for tau in (0.01, 0.1, 1.0, 30.0):
        h = 0.1 / tau
        spectrum = sampled_gauss_markov_spectrum(2.0, tau, 0.1, w)
        # its mean over a period is r0, the variance of a sample mean
        assert float(spectrum.mean()) == pytest.approx(
            2.0 * 4.0 * (h - 1.0 + math.exp(-h)) / h**2, rel=1e-6)
    slow = sampled_gauss_markov_spectrum(1.0, 1e4, 0.1, w[1:2000])
    phi = math.exp(-1e-5)
    ar1 = (1 - phi**2) / (1 - 2 * phi * np.cos(w[1:2000]) + phi**2)
    # a slow process' means are its samples (AR(1)) within the share h = dt / T of its variance
    np.testing.assert_allclose(slow, ar1, rtol=1e-4, atol=1e-5)


def test_clean_records_are_rarely_called_a_process() -> None:
    cache = ComparisonCache()
    rates = simulate(BASE, 3600.0, FS_HZ, n_axes=20, seed=11).rate_deg_s
    found = [detect_process(rates[:, i], FS_HZ, BASE, alpha=0.01, cache=cache)
             for i in range(20)]
    assert all(f is not None for f in found)
    assert sum(f.significant for f in found if f is not None) <= 1  # 1 %: 0.2 expected


def test_a_faint_process_the_gap_passes_is_named_by_its_spectrum() -> None:
    truth = t.GaussMarkov(sigma_deg_h=0.05 * SIGMA_W * 3600.0, tau_s=3.0)
    rate = simulate(BASE.with_term(truth), 3600.0, FS_HZ, seed=10).rate_deg_s[:, 0]
    result = reconcile(rate, FS_HZ, BASE)
    assert not result.before.significant(0.01)  # the Allan gap alone names nothing here
    assert [e.name for e in result.effects] == ["gauss_markov"]
    effect = result.effects[0]
    assert effect.evidence.startswith("spectral process test")
    assert 1.0 < effect.params["tau_s"] < 9.0
    assert 0.3 < effect.params["sigma_deg_h"] / truth.sigma_deg_h < 3.0
