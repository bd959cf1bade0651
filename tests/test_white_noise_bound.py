"""The white-noise bound of the ARW / VRW read-off (issue 38 part 4): a -1/2 stretch whose
level the rest of the curve does not allow white noise is passed over, and where no
stretch is left the least ``sigma(tau) sqrt(tau)`` is read as an upper bound.

The independent reference is the physics of the Allan variance, not our code: white noise
of density ``q`` has Allan variance ``q^2 / tau``, and a Gauss-Markov process of variance
``s^2`` and correlation time ``T`` has ``2 s^2 T / tau`` at ``tau >> T`` (a -1/2 slope at a
level above the white noise's), so the long-tau -1/2 stretch is the Gauss-Markov's, not
the white noise's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from analysis.allan.variance import allan_variance
from analysis.figures.readoffs import arw_readoff, white_noise_bound
from analysis.figures.zones import TauZone
from analysis.units.conversions import S_PER_H

FS = 100.0
WHITE = 0.02  # per-sample standard deviation of the white noise
GM_SIGMA, GM_T = 0.01, 10.0  # Gauss-Markov standard deviation and correlation time (s)


@pytest.fixture(scope="module")
def white_and_markov() -> np.ndarray:
    rng = np.random.default_rng(38)
    n = 400_000
    phi = math.exp(-1.0 / (FS * GM_T))
    markov = signal.lfilter([GM_SIGMA * math.sqrt(1 - phi**2)], [1.0, -phi], rng.normal(size=n))
    return np.asarray(rng.normal(0.0, WHITE, n) + markov)


def test_a_long_tau_half_slope_above_the_white_bound_is_passed_over(
        white_and_markov: np.ndarray) -> None:
    taus = np.unique(np.geomspace(1, len(white_and_markov) // 4, 70).astype(int)) / FS
    result = allan_variance(white_and_markov, FS, taus=taus)
    # the short taus a tone zone, as on an ADIS16405 accelerometer: only 10 ms and the
    # Gauss-Markov tail (tau >> T, slope -1/2 at sqrt(q^2 + 2 s^2 T)) are left to read
    zones = (TauZone(0.015, 5.0, "tone", "a tone"),)
    n_true = WHITE / math.sqrt(FS) * math.sqrt(S_PER_H)
    tail = math.sqrt(WHITE**2 / FS + 2 * GM_SIGMA**2 * GM_T) * math.sqrt(S_PER_H)
    assert tail > 4 * n_true
    read = arw_readoff(result, None, zones=zones)
    assert read.value == pytest.approx(n_true, rel=0.05)
    assert read.tau_high_s is not None and read.tau_high_s < 0.015
    assert "passed over" in read.note
    bound = white_noise_bound(result, zones)
    assert bound is not None and bound.upper_bound
    assert bound.interval()[0] == 0.0 and bound.value == pytest.approx(n_true, rel=0.05)


def test_no_stretch_left_reads_the_bound_as_an_upper_bound(white_and_markov: np.ndarray) -> None:
    taus = np.unique(np.geomspace(1, len(white_and_markov) // 4, 70).astype(int)) / FS
    result = allan_variance(white_and_markov, FS, taus=taus)
    # 10 ms inside an output filter's zone and the rest up to 5 s a tone's: no white
    # stretch is left, the Gauss-Markov tail is above the bound, so the bound is read
    zones = (TauZone(0.0, 0.015, "output filter", "a filter"),
             TauZone(0.015, 5.0, "tone", "a tone"))
    read = arw_readoff(result, None, zones=zones)
    n_true = WHITE / math.sqrt(FS) * math.sqrt(S_PER_H)
    assert read.upper_bound and "upper bound" in read.note
    assert 0.98 * n_true <= read.value < 1.3 * n_true  # type: ignore[operator]
    low, high = read.interval(0.95)
    assert low == 0.0 and high is not None and high > read.value  # type: ignore[operator]
