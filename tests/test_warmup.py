"""Warm-up detector and stationarity verdict on simulated runs (analysis.davar.warmup)."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.davar.estimators import dynamic_allan_variance
from analysis.davar.warmup import detect_warmup
from analysis.models.noise import flicker_rate_noise

FS = 1.0
N = 20_000
WINDOW_S = 1000.0
T_WARM = 1500.0  # s, time constant of the simulated warm-up


def stationary_run(seed: int) -> np.ndarray:
    """White rate noise (1 deg/s per sample) plus a little bias instability, in deg/s."""
    rng = np.random.default_rng(seed)
    return rng.standard_normal(N) + flicker_rate_noise(0.05, N, FS, rng)


def warming_run(seed: int) -> np.ndarray:
    """A stationary run whose bias (3 deg/s) and noise level (x3) decay as exp(-t / T_WARM)."""
    t = np.arange(N) / FS
    decay = np.exp(-t / T_WARM)
    return stationary_run(seed) * (1.0 + 2.0 * decay) + 3.0 * decay


def test_no_false_warmup_in_at_least_95_percent_of_stationary_seeds() -> None:
    verdicts = [detect_warmup(dynamic_allan_variance(stationary_run(seed), FS, window_s=WINDOW_S))
                for seed in range(40)]
    false_alarms = [v.warmup_end_s for v in verdicts if not v.stationary]
    assert len(false_alarms) <= 2, f"false warm-ups at {false_alarms}"
    for v in verdicts:
        assert v.stationary == (v.warmup_end_s == 0.0)
        assert len(v.settled) == len(v.window_start_s) == len(v.excess) == 191


def test_detects_the_end_of_an_exponential_warmup() -> None:
    ends = []
    for seed in range(100, 110):
        verdict = detect_warmup(dynamic_allan_variance(warming_run(seed), FS, window_s=WINDOW_S))
        assert not verdict.stationary
        assert verdict.warmup_end_s is not None
        ends.append(verdict.warmup_end_s)
        # every window before the end that was judged unsettled really is before it
        assert np.all(verdict.window_start_s[~verdict.settled] < verdict.warmup_end_s)
        assert verdict.excess[0] > 0.1  # the first window is far outside the later band
    ends_t = np.array(ends) / T_WARM
    # noise excess 1 + 2 exp(-t/T): ~1.3 at 2 T, ~1.1 at 3 T, within the band's reach
    assert np.all((ends_t >= 1.5) & (ends_t <= 4.0)), ends_t
    assert 1.8 <= np.median(ends_t) <= 3.2


def test_a_run_that_never_settles_has_no_warmup_end() -> None:
    rng = np.random.default_rng(7)
    rate = rng.standard_normal(N) * np.exp(np.arange(N) / 2500.0)  # noise grows to the end
    verdict = detect_warmup(dynamic_allan_variance(rate, FS, window_s=WINDOW_S))
    assert verdict.warmup_end_s is None
    assert not verdict.stationary


def test_a_late_change_moves_the_end_past_it() -> None:
    rng = np.random.default_rng(8)
    rate = rng.standard_normal(N)
    rate[12_000:] *= 1.5  # a change at 12 000 s: the curve settles only after it
    verdict = detect_warmup(dynamic_allan_variance(rate, FS, window_s=WINDOW_S))
    assert not verdict.stationary
    assert verdict.warmup_end_s == pytest.approx(12_000, abs=WINDOW_S)


def test_judges_about_ten_windows_per_window_length_and_checks_confidence() -> None:
    result = dynamic_allan_variance(stationary_run(1)[:5000], FS, window_s=500.0, step_s=1.0)
    verdict = detect_warmup(result)
    assert np.allclose(np.diff(verdict.window_start_s)[:-1], 50.0)
    assert verdict.window_start_s[-1] == result.window_start_s[-1]
    with pytest.raises(ValueError, match="confidence"):
        detect_warmup(result, confidence=1.0)
