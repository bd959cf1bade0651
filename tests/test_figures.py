"""Spec figures: bias, bias stability and the IEEE 952 read-offs."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.allan.estimators import overlapping_allan_variance
from analysis.figures.readoffs import arw_readoff, bias_instability_readoff
from analysis.figures.spec import bias_stability
from analysis.models.noise import flicker_rate_noise, white_rate_noise
from analysis.units.conversions import arw_deg_rt_h_to_deg_rt_s, rate_deg_h_to_deg_s


def test_bias_stability_of_white_noise_follows_the_averaging_time() -> None:
    fs, n_deg_rt_h = 100.0, 0.5
    y = white_rate_noise(
        arw_deg_rt_h_to_deg_rt_s(n_deg_rt_h), 200_000, fs, np.random.default_rng(1)
    )
    for avg in (10.0, 100.0):
        bs = bias_stability(y, fs, avg)
        expected = n_deg_rt_h / 60.0 / np.sqrt(avg) * 3600.0  # deg/h: std of an avg-second mean
        assert bs.n_averages == int(2000 / avg)
        assert bs.ci_low_deg_h < bs.value_deg_h < bs.ci_high_deg_h
        assert bs.value_deg_h == pytest.approx(expected, rel=0.35)
    short = bias_stability(y[:250], fs, 1.0)
    assert short.value_deg_h is None and short.n_averages == 2


def test_readoffs_recover_arw_and_bias_instability() -> None:
    fs = 10.0
    n_true, b_true = 0.02, 0.3
    rng = np.random.default_rng(3)
    y = (white_rate_noise(arw_deg_rt_h_to_deg_rt_s(n_true), 300_000, fs, rng)
         + flicker_rate_noise(rate_deg_h_to_deg_s(b_true), 300_000, fs, rng))
    r = overlapping_allan_variance(y, fs)
    arw = arw_readoff(r)
    assert arw.value == pytest.approx(n_true, rel=0.05)
    assert arw.tau_low_s == pytest.approx(0.1) and arw.note == ""
    bi = bias_instability_readoff(r)
    # the minimum of a noisy curve sits a little under the plateau: a known low bias
    assert bi.value == pytest.approx(b_true, rel=0.2)
    assert bi.tau_low_s > 10.0


def test_readoff_notes_when_the_curve_has_not_turned() -> None:
    y = white_rate_noise(0.01, 20_000, 10.0, np.random.default_rng(0))
    bi = bias_instability_readoff(overlapping_allan_variance(y, 10.0))
    assert "upper bound" in bi.note
