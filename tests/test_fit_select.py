"""The default fit (logwls with term selection) recovers the terms a record holds, and only those.

A small Monte Carlo over pairs and triples of the five IEEE terms, each case one the data
resolve (a fit of the true model to the exact expected curve gives every true term's
variance coefficient a standard error under a third of itself). The full version, with
more seeds, longer records and cases at the edge, is ``benchmarks/fit_monte_carlo.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.allan.estimators import overlapping_allan_variance
from analysis.fit.least_squares import COEFFICIENT_NAMES, TERMS, fit_noise_terms
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
#: (true coefficients in data-sheet units, hours, Hz, tau grid up to two clusters)
CASES = [
    ({"Q": 20.0, "N": 0.5}, 1 / 6, 100.0, False),
    ({"N": 0.1, "B": 2.0}, 2.0, 10.0, False),
    ({"N": 0.1, "K": 10.0}, 2.0, 10.0, False),
    ({"N": 0.1, "R": 30.0}, 2.0, 10.0, False),
    ({"N": 0.05, "B": 2.0, "K": 15.0}, 3.0, 10.0, False),
    ({"N": 0.1, "K": 10.0}, 2.0, 10.0, True),
]
SEEDS = 4


def _record(true: dict[str, float], hours: float, fs: float, seed: int) -> np.ndarray:
    model = NoiseModel(tuple(TERM_CLASS[t](**{COEFFICIENT_NAMES[t]: v}) for t, v in true.items()))
    return simulate(model, hours * 3600.0, fs, seed=seed).rate_deg_s[:, 0]


@pytest.mark.slow
def test_selected_fit_recovers_the_true_terms_with_honest_errors() -> None:
    z_scores, invented, absent, right_model, fits = [], 0, 0, 0, 0
    for true, hours, fs, to_two_clusters in CASES:
        errors: dict[str, list[float]] = {t: [] for t in true}
        for seed in range(SEEDS):
            rate = _record(true, hours, fs, seed)
            taus = "log"
            if to_two_clusters:
                # the longest tau with two clusters, as the analysis grid will reach
                n = len(rate)
                taus = np.unique(np.rint(np.geomspace(1, n // 2, 100)).astype(np.int64)) / fs
            fit = fit_noise_terms(overlapping_allan_variance(rate, fs, taus=taus), method="logwls")
            fits += 1
            right_model += fit.terms == "".join(t for t in TERMS if t in true)
            for term in TERMS:
                if term in true:
                    errors[term].append(fit.values[term] / true[term] - 1.0)
                    z_scores.append((fit.values[term] - true[term]) / fit.stderr[term])
                else:
                    absent += 1
                    invented += fit.values[term] > 0
        for term, e in errors.items():
            # mean error within 15 %, give or take the error of a mean of SEEDS runs
            tolerance = 0.15 + 2.0 * np.std(e, ddof=1) / math.sqrt(SEEDS)
            assert abs(np.mean(e)) < tolerance, (true, term, e)
    assert right_model >= 0.8 * fits, (right_model, fits)
    assert invented <= 0.1 * absent, (invented, absent)
    # 1-sigma coverage in 55-85 %, widened by its binomial error over this many z-scores
    coverage = np.mean(np.abs(z_scores) <= 1.0)
    slack = 2.0 * math.sqrt(0.68 * 0.32 / len(z_scores))
    assert 0.55 - slack < coverage < 0.85 + slack, (coverage, len(z_scores))


def test_a_one_degree_value_near_zero_does_not_decide_the_selection() -> None:
    # N 0.1 deg/sqrt(h) + K 1 deg/h^1.5, 6 h at 10 Hz, on the analysis grid (to half the
    # record): the value at half the record is one squared difference; a draw of a
    # thousandth of its mean (chance 2.5 %) must not read the walk away (before the
    # criterion's edf floor it read this record, and 9 of seeds 1-12, as white noise alone)
    from dataclasses import replace

    from analysis.allan import analysis_log_m
    from analysis.fit.selection import MIN_CRITERION_EDF

    rate = _record({"N": 0.1, "K": 1.0}, 6.0, 10.0, 2)
    result = overlapping_allan_variance(rate, 10.0, taus=analysis_log_m(len(rate)) / 10.0)
    edf = np.asarray(result.edf, dtype=float)
    assert edf[-1] < MIN_CRITERION_EDF  # the grid reaches the one-difference values
    fit = fit_noise_terms(result, method="logwls")
    assert "K" in fit.terms
    low = np.asarray(result.avar, dtype=float).copy()
    low[-1] *= 1e-3
    damaged = fit_noise_terms(replace(result, avar=low), method="logwls")
    assert "K" in damaged.terms, damaged.criteria
    assert damaged.values["K"] == pytest.approx(fit.values["K"], rel=0.1)
