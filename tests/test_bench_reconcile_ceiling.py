"""The spectra the ceiling of reconcile's naming rests on (benchmarks/bench_reconcile_ceiling.py):
the naming bench's clean records average to the base spectrum the tests use, in both of
their domains, and the first difference needs its taper."""

from __future__ import annotations

import numpy as np

from benchmarks.bench_reconcile_ceiling import (
    DOMAINS,
    Domain,
    best_log_likelihood,
    parameters,
    record,
    rival_spectra,
    search_spectra,
    statistic,
    untold_statistic,
)

#: Bands of Fourier frequencies (indices from the lowest): the lowest few, where the walk and
#: the slow processes are, up to the highest.
BANDS = ((0, 3), (3, 10), (10, 100), (100, 1000), (1000, 17_000))


def _band_ratios(domain: Domain, clean: np.ndarray) -> list[float]:
    ratio = domain.periodogram(clean).mean(axis=0) / domain.base(domain.w)
    return [float(ratio[a:b].mean()) for a, b in BANDS]


def test_clean_records_average_to_the_base_spectrum_in_each_domain() -> None:
    clean = np.array([record("none", 700_000 + i, "faint") for i in range(60)])
    for effect, domain in DOMAINS.items():
        ratios = _band_ratios(domain, clean)
        # 60 records: about 8 % scatter in the lowest band (3 x 60 exponentials), 1 % above
        assert all(0.7 < r < 1.35 for r in ratios[:2]), (effect, ratios)
        assert all(0.95 < r < 1.05 for r in ratios[2:]), (effect, ratios)
    # the difference untapered: its two ends leak far above the base at the lowest frequencies
    assert _band_ratios(Domain(True, 0.0), clean)[0] > 20.0


def test_a_told_test_separates_a_strong_process_from_clean_records() -> None:
    clean = np.array([record("none", 710_000 + i, "faint") for i in range(40)])
    for effect in DOMAINS:
        p = parameters(effect, 1, "narrow")
        rate = record(effect, 1, "narrow")[None, :]
        domain = DOMAINS[effect]
        null = statistic(effect, p, domain.series(clean), domain.periodogram(clean))
        value = statistic(effect, p, domain.series(rate), domain.periodogram(rate))[0]
        assert value > null.max(), effect


def test_the_walk_and_its_rival_each_fit_their_own_records_best() -> None:
    """The naming bound's rival: a strong walk fits better as a walk than as more bias
    instability (each with its best parameter), a hidden bias-instability increase the
    other way round, and the untold test finds the walks beyond every clean record."""
    domain = DOMAINS["rate_random_walk"]
    walks, rival = search_spectra("rate_random_walk"), rival_spectra("rate_random_walk")
    clean = np.array([record("none", 720_000 + i, "faint") for i in range(40)])
    null = untold_statistic("rate_random_walk", domain.periodogram(clean), walks)
    for seed in (1, 2, 3):
        walk = domain.periodogram(record("rate_random_walk", seed, "narrow")[None, :])
        more = domain.periodogram(record("bias_instability", seed, "narrow")[None, :])
        assert best_log_likelihood(walk, walks)[0] > best_log_likelihood(walk, rival)[0] + 5.0
        assert best_log_likelihood(more, rival)[0] > best_log_likelihood(more, walks)[0]
        assert untold_statistic("rate_random_walk", walk, walks)[0] > null.max()
