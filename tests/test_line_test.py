"""The spectral line test (:mod:`analysis.reconcile.line_test`) and the faint sinusoid it lets
reconcile name.

The records are 1 h at 10 Hz of white noise plus flicker noise (the base model of
``tests/test_reconcile.py``) from :mod:`analysis.models.simulation`; the faint sinusoid's amplitude
and period are drawn here: 0.06-0.09 of the white noise's standard deviation (a variance
ratio of 0.002-0.004, far below what moves the Allan curve), periods 10-60 s.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, BiasInstability, NoiseModel
from analysis.reconcile.candidates import MIN_CYCLES
from analysis.reconcile.confirm import periodogram_peak
from analysis.reconcile.discrepancy import ComparisonCache
from analysis.reconcile.line_test import LINE_ALPHA, strongest_line
from analysis.reconcile.loop import reconcile

FS_HZ, DURATION_S = 10.0, 3600.0
BASE = NoiseModel(terms=(AngleRandomWalk(N_deg_rt_h=0.5), BiasInstability(B_deg_h=2.0)))
SIGMA_W_DEG_S = 0.5 / 60.0 * math.sqrt(FS_HZ)


def base_rate(seed: int) -> np.ndarray:
    return simulate(BASE, DURATION_S, FS_HZ, seed=seed).rate_deg_s[:, 0]


def faint_sine(rng: np.random.Generator) -> tuple[np.ndarray, float]:
    amp = rng.uniform(0.06, 0.09) * SIGMA_W_DEG_S
    period = math.exp(rng.uniform(math.log(10.0), math.log(60.0)))
    t = np.arange(int(DURATION_S * FS_HZ)) / FS_HZ
    return amp * np.sin(2 * math.pi * t / period + rng.uniform(0, 2 * math.pi)), period


def test_the_line_test_holds_its_level_on_smooth_spectra():
    # under the null every family-wise p-value is uniform or larger: fewer than a third of
    # 30 records may fall below 0.1 (binomial(30, 0.1) exceeds 9 with probability 0.001)
    ps = [strongest_line(base_rate(seed), FS_HZ, min_cycles=MIN_CYCLES).p_value
          for seed in range(7100, 7130)]
    assert sum(p < 0.1 for p in ps) <= 9, sorted(ps)[:10]
    assert min(ps) >= LINE_ALPHA / 10.0


@pytest.mark.parametrize("seed", [7201, 7202, 7203])
def test_a_faint_line_is_found_at_its_frequency(seed):
    sine, period = faint_sine(np.random.default_rng(seed))
    found = strongest_line(base_rate(seed) + sine, FS_HZ, min_cycles=MIN_CYCLES)
    assert found is not None and found.significant(), found
    # the ordinates sit every half bin: within a quarter bin of the line
    assert abs(found.freq_hz - 1.0 / period) <= 0.25 / DURATION_S + 1e-12, (found, period)


@pytest.mark.slow
def test_reconcile_names_a_faint_sinusoid_by_its_spectral_line():
    cache = ComparisonCache()
    for seed in (7301, 7302):
        sine, period = faint_sine(np.random.default_rng(seed))
        res = reconcile(base_rate(seed) + sine, FS_HZ, BASE, cache=cache)
        assert [e.name for e in res.effects] == ["sinusoid"], (seed, res.rounds)
        assert res.effects[0].params["period_s"] == pytest.approx(period, rel=0.01)
        assert "spectral line" in res.effects[0].evidence
        # and the same record without the line names nothing
        clean = reconcile(base_rate(seed), FS_HZ, BASE, cache=cache)
        assert not clean.effects and not clean.excess, (seed, clean.rounds)


@pytest.mark.parametrize("cycles", [7.5, 8.5, 9.5, 11.5])
def test_a_slow_line_between_bins_is_fitted_on_its_own_lobe(cycles):
    # a sine of 0.1 of the white noise with a period of 310-480 s, half a bin from the
    # nearest whole one: the fit started at a whole bin settled on a side lobe for some
    # phases (a fifth of the amplitude, the period a bin off), which refused the sinusoid
    # the Allan curve asked for; every phase must give the line itself
    period = DURATION_S / cycles
    t = np.arange(int(DURATION_S * FS_HZ)) / FS_HZ
    amp = 0.1 * SIGMA_W_DEG_S
    for i, phase in enumerate(np.linspace(0.0, 2.0 * math.pi, 6, endpoint=False)):
        rate = base_rate(7400 + i) + amp * np.sin(2.0 * math.pi * t / period + phase)
        ev = periodogram_peak(rate, FS_HZ, 0.9 * period)
        assert ev.confirmed, (phase, ev.statistic)
        assert ev.values["period_s"] == pytest.approx(period, rel=0.03), (phase, ev.values)
        got = ev.values["amplitude_deg_h"] / (amp * 3600.0)
        assert 0.75 < got < 1.25, (phase, ev.values)
