"""The light quantiles of :mod:`analysis.distributions` give scipy.stats' numbers bit for bit."""

from __future__ import annotations

import numpy as np
from scipy import stats

from analysis import distributions as dist


def test_quantiles_and_tails_equal_scipy_stats_bit_for_bit() -> None:
    rng = np.random.default_rng(7)
    q = rng.uniform(1e-9, 1 - 1e-9, 500)
    x = rng.normal(0.0, 3.0, 500)
    df = rng.uniform(0.5, 500.0, 500)
    chi = np.abs(x) * 10
    pairs = {
        "norm.ppf": (dist.normal_ppf(q), stats.norm.ppf(q)),
        "norm.isf": (dist.normal_isf(q), stats.norm.isf(q)),
        "norm.cdf": (dist.normal_cdf(x), stats.norm.cdf(x)),
        "norm.sf": (dist.normal_sf(x), stats.norm.sf(x)),
        "norm.pdf": (dist.normal_pdf(x), stats.norm.pdf(x)),
        "chi2.sf": (dist.chi2_sf(chi, df), stats.chi2.sf(chi, df)),
        "chi2.ppf": (dist.chi2_ppf(q, df), stats.chi2.ppf(q, df)),
        "chi2.median": (dist.chi2_ppf(0.5, df), stats.chi2.median(df)),
        "t.ppf": (dist.t_ppf(q, df), stats.t.ppf(q, df)),
        "t.ppf int dof": (dist.t_ppf(0.975, 9), stats.t.ppf(0.975, 9)),
    }
    assert [k for k, (ours, theirs) in pairs.items() if not np.array_equal(ours, theirs)] == []
    assert float(dist.normal_ppf(0.975)) == float(stats.norm.ppf(0.975))
