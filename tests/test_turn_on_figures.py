"""Sequence figures in analysis: per-cycle summaries, turn-on repeatability, warm-up time,
bias temperature sensitivity and hysteresis, against set truths (analysis.sequences.cycle_stats,
analysis.sequences.turn_on, analysis.sequences.temperature_sensitivity,
analysis.models.power_cycle)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.errors import TooFewSamplesError
from analysis.models.power_cycle import PowerCycleModel, ThermalModel, first_order_step
from analysis.sequences.cycle_stats import (
    lognormal_mean_interval,
    std_interval,
    summarize_cycles,
)
from analysis.sequences.temperature_sensitivity import (
    TemperaturePoint,
    fit_temperature_sensitivity,
    hysteresis,
    plateau_point,
    ramp_points,
)
from analysis.sequences.turn_on import CycleBias, cycle_bias, turn_on_repeatability, warmup_curve
from analysis.units.conversions import S_PER_H

FS = 5.0


def test_intervals_cover_the_truth_at_their_level() -> None:
    """400 sets of 6 normal draws: the t interval of the mean and the chi-square interval
    of the spread each cover the truth in 95 % +- 3.3 % (3 sigma of 400 trials)."""
    rng = np.random.default_rng(7)
    mean_hits = std_hits = 0
    for _ in range(400):
        s = summarize_cycles(3.0 + 2.0 * rng.standard_normal(6), 0.95)
        assert s.mean_low is not None and s.std_low is not None
        mean_hits += s.mean_low <= 3.0 <= s.mean_high  # type: ignore[operator]
        std_hits += s.std_low <= 2.0 <= s.std_high  # type: ignore[operator]
    assert abs(mean_hits / 400 - 0.95) < 0.033
    assert abs(std_hits / 400 - 0.95) < 0.033


def test_a_time_interval_never_goes_below_zero() -> None:
    """Five warm-ups, one of them late: Student's t said 1.42 min [-1.54, 4.38]; a time's
    interval is log-normal, positive, and holds the mean; with a value of 0 (no logarithm)
    the t interval's lower bound is raised to 0."""
    warmups_min = np.array([18.0, 25.0, 20.0, 22.0, 341.0]) / 60.0
    t = summarize_cycles(warmups_min, 0.95)
    assert t.mean == pytest.approx(1.42) and t.mean_low == pytest.approx(-1.54, abs=0.005)
    assert t.mean_high == pytest.approx(4.38, abs=0.005)
    s = summarize_cycles(warmups_min, 0.95, positive=True)
    assert s.mean == t.mean and s.std_low == t.std_low
    assert s.mean_low is not None and s.mean_high is not None and s.mean is not None
    assert 0.0 < s.mean_low < s.mean < s.mean_high
    assert (s.mean_low, s.mean_high) == pytest.approx((0.151, 11.9), rel=0.01)
    zero = summarize_cycles([0.0, 0.2, 3.0], 0.95, positive=True)
    assert zero.mean_low == 0.0 and zero.mean_high == summarize_cycles([0.0, 0.2, 3.0]).mean_high
    equal = summarize_cycles([60.0, 60.0], 0.95, positive=True)
    assert (equal.mean_low, equal.mean_high) == pytest.approx((60.0, 60.0))
    with pytest.raises(ValueError, match="> 0"):
        lognormal_mean_interval([1.0, -1.0], 0.95)
    # two switch-ons of 5 s and 30 s at 99.9 %: exp(centre + 636.6 x 1.44) is beyond the
    # float range; no upper bound, not an overflow (a sequence's grading once died of it)
    low, high = lognormal_mean_interval([5.0, 30.0], 0.999)
    assert high == math.inf and 0.0 <= low < 5.0


def test_a_time_interval_keeps_its_level_on_skewed_draws() -> None:
    """2000 sets of five log-normal draws (sigma 1, mean exp(1/2)): the log-normal interval
    covers the mean 93 % (20000 draws: 93.4 %) at 95 %, within 3 sigma of 2000 trials;
    Student's t only 82 %."""
    rng = np.random.default_rng(11)
    truth = math.exp(0.5)
    draws = np.exp(rng.standard_normal((2000, 5)))
    hits = sum(lo <= truth <= hi for lo, hi in (lognormal_mean_interval(d, 0.95) for d in draws))
    t_hits = 0
    for d in draws:
        s = summarize_cycles(d, 0.95)
        t_hits += s.mean_low <= truth <= s.mean_high  # type: ignore[operator]
    assert 0.915 < hits / 2000 < 0.955
    assert t_hits / 2000 < 0.87


def test_summaries_of_few_cycles_say_what_they_cannot_tell() -> None:
    one = summarize_cycles([4.0, math.nan])
    assert (one.n, one.mean, one.mean_low, one.std) == (1, 4.0, None, None)
    assert summarize_cycles([]).mean is None
    with pytest.raises(ValueError):
        std_interval(1.0, 0, 0.95)
    with pytest.raises(ValueError):
        summarize_cycles([1.0, 2.0], confidence=1.0)


def _cycle(model: PowerCycleModel, bias_deg_h: float, n: int, rng: np.random.Generator, *,
           first_s: float = 2.0, noise_deg_h: float = 1.0) -> np.ndarray:
    """One switch-on's record (deg/s): the transient, a bias, white noise of
    ``noise_deg_h`` per sample."""
    t0 = first_s + np.arange(n) / FS
    return (model.transient_deg_h(t0, 1.0 / FS) + bias_deg_h
            + noise_deg_h * rng.standard_normal(n)) / S_PER_H


def test_warmup_time_comes_back_on_noisy_records_with_gaps() -> None:
    """A 20 deg/h exp(-t/30 s) transient into a 1 deg/h band: 30 ln 20 s, less the
    settled mean's share; 40 records with noise (0.1 deg/h on each 20 s average) and a
    gap of 20 s in the middle of the warm-up come back within 1.5 s on average."""
    model = PowerCycleModel(warmup_deg_h=20.0, warmup_tau_s=30.0)
    truth = model.warmup_time_s(1.0, record_s=302.0,
                                die_temperature_c=lambda t: np.full_like(t, 25.0))
    assert truth == pytest.approx(30 * math.log(20), abs=3.0)
    rng = np.random.default_rng(3)
    times = []
    for _ in range(40):
        x = _cycle(model, 5.0, 1500, rng, noise_deg_h=0.1 * math.sqrt(20 * FS))
        x[200:300] = np.nan
        curve = warmup_curve(x, FS, first_s=2.0, band_deg_h=1.0, average_s=20.0)
        assert curve.warmup_time_s is not None
        assert curve.average_noise_deg_h is not None and 0.03 < curve.average_noise_deg_h < 0.3
        times.append(curve.warmup_time_s)
    assert abs(np.mean(times) - truth) < 1.5
    assert 0.5 < np.std(times) < 5.0


def test_warmup_that_never_settles_and_a_record_too_short() -> None:
    for tau in (300.0, 3000.0):  # still falling at the end; a slow drift all along
        model = PowerCycleModel(warmup_deg_h=20.0, warmup_tau_s=tau)
        x = _cycle(model, 0.0, 1500, np.random.default_rng(1), noise_deg_h=0.0)
        curve = warmup_curve(x, FS, first_s=2.0, band_deg_h=1.0, average_s=20.0)
        assert curve.warmup_time_s is None, tau
    settled = _cycle(PowerCycleModel(), 0.0, 1500, np.random.default_rng(1), noise_deg_h=0.0)
    assert warmup_curve(settled, FS, first_s=2.0, band_deg_h=1.0,
                        average_s=20.0).warmup_time_s == 2.0
    with pytest.raises(TooFewSamplesError):
        warmup_curve(settled[:300], FS, first_s=2.0, band_deg_h=1.0, average_s=20.0)


def test_repeatability_is_the_spread_of_the_cycle_biases() -> None:
    """Biases drawn with a spread of 10 deg/h, each cycle noisy: the figure is the spread
    of the per-cycle means (close to the drawn ones), its interval chi-square on N - 1."""
    rng = np.random.default_rng(11)
    drawn = 10.0 * rng.standard_normal(6)
    model = PowerCycleModel(warmup_deg_h=30.0, warmup_tau_s=20.0)
    biases = [cycle_bias(_cycle(model, b, 1200, rng), FS, first_s=2.0, after_s=100.0)
              for b in drawn]
    for b, truth in zip(biases, drawn, strict=True):
        assert b.stderr_deg_h is not None and b.stderr_deg_h < 0.2
        assert abs(b.mean_deg_h - truth) < 5 * b.stderr_deg_h
    rep = turn_on_repeatability(biases, 0.95)
    assert rep.n_cycles == 6
    assert rep.value_deg_h == pytest.approx(np.std(drawn, ddof=1), abs=0.3)
    assert rep.ci_low_deg_h < rep.value_deg_h < rep.ci_high_deg_h  # type: ignore[operator]
    assert rep.within_cycle_deg_h is not None and rep.within_cycle_deg_h < 0.2
    assert turn_on_repeatability([CycleBias(1.0, None, 10, 0.0)]).value_deg_h is None
    with pytest.raises(TooFewSamplesError):
        cycle_bias(np.zeros(10), FS, first_s=0.0, after_s=100.0)


def test_temperature_coefficients_and_their_intervals() -> None:
    """Plateaus on b(T) = 2 + 0.4 (T - 25) + 0.006 (T - 25)^2 deg/h with 0.05 deg/h noise:
    the quadratic fit's intervals cover each coefficient; the linear fit's slope is the
    least-squares slope of the curve over the plateaus."""
    rng = np.random.default_rng(5)
    temps = np.array([-30.0, -10.0, 10.0, 25.0, 45.0, 70.0])

    def truth(t: np.ndarray) -> np.ndarray:
        return 2.0 + 0.4 * (t - 25) + 0.006 * (t - 25) ** 2

    points = [TemperaturePoint(float(t), float(truth(t) + 0.05 * rng.standard_normal()), 0.05,
                               "plateau", 1000) for t in temps]
    quad = fit_temperature_sensitivity(points, order=2, reference_c=25.0, confidence=0.99)
    for k, c in enumerate((2.0, 0.4, 0.006)):
        assert quad.ci_low[k] <= c <= quad.ci_high[k]
    assert quad.ci_high[2] - quad.ci_low[2] < 0.002
    lin = fit_temperature_sensitivity(points, order=1)
    assert lin.slope_deg_h_per_c == pytest.approx(np.polyfit(temps, truth(temps), 1)[0], rel=0.02)
    assert lin.chi2_reduced is not None and lin.chi2_reduced > 10  # the curvature shows
    with pytest.raises(TooFewSamplesError):
        fit_temperature_sensitivity(points[:2], order=2)


def test_each_switch_on_gets_its_own_bias_in_the_temperature_fit() -> None:
    """Plateaus 10, 25 | 40, 25 degC on b = b_s + 0.5 (T - 25) deg/h, the unit switched on
    again between 25 and 40 degC with its turn-on bias 18.5 deg/h lower (issue 39's
    campaign jump): one line through all four gets the slope wrong by more than 0.5
    deg/h/degC, a bias per switch-on finds it within its interval, on points - switch-ons - 1
    degrees of freedom, with each switch-on's bias at the reference; the up 25 and the
    down 25 of two switch-ons make no hysteresis."""
    rng = np.random.default_rng(3)
    rows = [(10.0, 1, 4.0), (25.0, 1, 4.0), (40.0, 2, -14.5), (25.0, 2, -14.5)]
    points = [TemperaturePoint(t, b + 0.5 * (t - 25) + 0.1 * float(rng.standard_normal()), 0.1,
                               "plateau", 1000, on) for t, on, b in rows]
    pooled = [TemperaturePoint(p.temperature_c, p.bias_deg_h, p.stderr_deg_h, p.direction,
                               p.n_samples) for p in points]
    wrong = fit_temperature_sensitivity(pooled, confidence=0.95)
    assert abs(wrong.slope_deg_h_per_c - 0.5) > 0.5
    fit = fit_temperature_sensitivity(points, confidence=0.95, reference_c=25.0)
    assert fit.ci_low[1] <= 0.5 <= fit.ci_high[1]
    assert fit.slope_deg_h_per_c == pytest.approx(0.5, abs=0.05)
    assert fit.dof == 1 and fit.switch_ons == (1, 2)
    assert fit.intercepts_deg_h == pytest.approx((4.0, -14.5), abs=0.5)
    assert fit.bias_deg_h(25.0, 2) == pytest.approx(-14.5, abs=0.5)
    assert hysteresis(points, tolerance_c=1.0, slope_deg_h_per_c=0.5) is None
    assert hysteresis(pooled, tolerance_c=1.0, slope_deg_h_per_c=0.5) is not None
    # one temperature per switch-on tells no slope
    with pytest.raises(TooFewSamplesError):
        fit_temperature_sensitivity([points[0], points[2]])


def test_ramp_points_know_their_direction_and_hysteresis_is_found() -> None:
    """A ramp up and a ramp down whose biases differ by 0.8 deg/h at equal temperature:
    every bin has its direction, and the hysteresis is 0.8 deg/h within its error."""
    rng = np.random.default_rng(2)
    n = 6000
    up_t = np.linspace(0.0, 40.0, n)
    down_t = up_t[::-1]
    noise = 0.5 / S_PER_H
    up = ramp_points((0.3 * up_t) / S_PER_H + noise * rng.standard_normal(n), up_t, bin_c=5.0)
    down = ramp_points((0.3 * down_t + 0.8) / S_PER_H + noise * rng.standard_normal(n),
                       down_t, bin_c=5.0)
    assert {p.direction for p in up} == {"up"} and {p.direction for p in down} == {"down"}
    h = hysteresis([*up, *down], tolerance_c=0.5, slope_deg_h_per_c=0.3)
    assert h is not None and h.n_pairs == len(up)
    assert abs(h.value_deg_h - 0.8) < 4 * h.stderr_deg_h + 0.05
    flat = plateau_point(np.full(500, 1.0 / S_PER_H), np.full(500, 25.0))
    assert (flat.direction, flat.bias_deg_h, flat.temperature_c) == ("plateau", 1.0, 25.0)
    assert hysteresis([flat]) is None


def test_thermal_lag_is_exact() -> None:
    """A first-order lag under a ramped input matches the closed form; a powered die warms
    to the air plus its self-heating."""
    x, tau, a = 20.0, 50.0, 0.1  # the input rises 0.1 degC/s from 30 degC
    got = first_order_step(x, 30.0, 30.0 + a * 100.0, tau, 100.0)
    exact = 30 + a * 100 - a * tau + (x - 30 + a * tau) * math.exp(-100 / tau)
    assert got == pytest.approx(exact, rel=1e-12)
    thermal = ThermalModel(unit_tau_s=60.0, self_heating_c=3.0)
    die = 25.0
    for _ in range(600):
        die = thermal.step(die, 25.0, 25.0, True, 1.0)
    assert die == pytest.approx(float(thermal.warm_die_c(25.0, 600.0)), abs=1e-9)
    assert die == pytest.approx(28.0, abs=0.01)
