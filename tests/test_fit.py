"""Five-term noise fits (Lv 2015 eq. 3-14 and our additions)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from analysis.allan.estimators import cluster_allan_variance, log_m, overlapping_allan_variance
from analysis.errors import FitError
from analysis.fit.least_squares import FIT_METHODS, fit_noise_terms, log_tau_share, theoretical_avar

TRUE = {"Q": 0.5, "N": 0.01, "B": 0.2, "K": 0.05, "R": 0.3}


def noise_free_result(coefficients: dict[str, float], n_samples: int = 400_000, fs: float = 10.0):
    """An AllanResult whose values are exactly eq. 3 of the given coefficients."""
    template = overlapping_allan_variance(
        np.random.default_rng(0).standard_normal(n_samples // 100), fs, taus="log"
    )
    m = log_m(n_samples)
    tau = m / fs
    avar = theoretical_avar(coefficients, tau)
    # a huge edf: logwls's mean-of-log correction, psi(edf/2) - log(edf/2), vanishes
    edf = np.full(len(m), 1e12)
    return dataclasses.replace(template, tau_s=tau, m=m, avar=avar, n_clusters=n_samples // m,
                               n_terms=n_samples + 1 - 2 * m, edf=edf, ci_low=avar * 0.9,
                               ci_high=avar * 1.1, n_samples=n_samples)


@pytest.mark.parametrize("method", FIT_METHODS)
def test_every_method_recovers_noise_free_coefficients(method: str) -> None:
    fit = fit_noise_terms(noise_free_result(TRUE), method=method, select=False)
    for term, value in TRUE.items():
        assert fit.values[term] == pytest.approx(value, rel=1e-5), (method, term)
    assert fit.negative_terms == ""


def test_rate_ramp_uses_r_squared_over_two_not_the_printed_k() -> None:
    """Lv 2015 prints K^2/2 as beta's last entry; the ramp term of eq. 3 is R^2 tau^2 / 2."""
    fit = fit_noise_terms(noise_free_result({"N": 0.01, "R": 2.0}), method="ols", terms="NR")
    assert fit.values["R"] == pytest.approx(2.0, rel=1e-6)
    assert fit.beta[4] == pytest.approx(0.5 * (2.0 / 3600**2) ** 2, rel=1e-6)


def test_subset_of_terms_leaves_the_others_out() -> None:
    fit = fit_noise_terms(noise_free_result({"N": 0.01, "B": 0.2}), method="wls", terms="NB")
    assert fit.terms == "NB"
    assert fit.values["Q"] is None and fit.values["K"] is None and fit.values["R"] is None
    assert fit.values["N"] == pytest.approx(0.01, rel=1e-6)
    d = fit.as_dict()
    assert d["Q_urad"] is None and d["Q_urad_stderr"] is None
    assert d["N_deg_rt_h"] == pytest.approx(0.01, rel=1e-6)


def test_negative_variance_term_is_none_not_a_silent_number() -> None:
    base = noise_free_result({"N": 0.01})
    # a curve that bends down at long tau: OLS needs a negative B or K term for it
    bent = dataclasses.replace(base, avar=base.avar * (1 - 0.5 * base.tau_s / base.tau_s.max()))
    ols = fit_noise_terms(bent, method="ols", terms="NBK")
    assert ols.negative_terms  # some term came out negative ...
    for term in ols.negative_terms:
        assert ols.values[term] is None  # ... and is reported as not estimable
        assert ols.as_dict()[{"B": "B_deg_h", "K": "K_deg_h_1_5", "N": "N_deg_rt_h"}[term]] is None
    for method in ("nnls", "logwls"):
        constrained = fit_noise_terms(bent, method=method, terms="NBK")
        assert constrained.negative_terms == ""
        assert all(v is not None and v >= 0 for v in constrained.values.values() if v is not None)


def test_bad_fit_requests_raise_fit_error() -> None:
    result = noise_free_result(TRUE)
    with pytest.raises(FitError, match="unknown fit method"):
        fit_noise_terms(result, method="magic")  # type: ignore[arg-type]
    with pytest.raises(FitError, match="subset"):
        fit_noise_terms(result, terms="XYZ")
    with pytest.raises(FitError, match="one axis"):
        two_axes = overlapping_allan_variance(
            np.random.default_rng(1).standard_normal((500, 2)), 1.0
        )
        fit_noise_terms(two_axes)
    short = cluster_allan_variance(np.random.default_rng(1).standard_normal(40), 1.0, taus="octave")
    with pytest.raises(FitError, match="usable"):
        fit_noise_terms(short, method="ols40")  # only J >= 5 values pass the 40 % rule


def test_log_tau_share_counts_octaves() -> None:
    share = log_tau_share(2.0 ** np.arange(6))
    np.testing.assert_allclose(share, 1.0)
    dense = log_tau_share(np.arange(1, 1025, dtype=float))
    # 1..1024 spans 10 octaves, plus half a step beyond each end (1/2 octave at m = 1)
    assert dense.sum() == pytest.approx(10.5, rel=0.01)
