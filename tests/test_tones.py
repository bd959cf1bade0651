"""Tones: the Welch line test finds narrow-band lines and stays quiet on coloured noise."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.allan.curves import sinusoid_avar
from analysis.allan.estimators import overlapping_allan_variance
from analysis.figures.tones import find_tones, tones_avar, welch_segment
from analysis.models.noise import (
    flicker_rate_noise,
    random_walk_rate_noise,
    white_angle_noise,
    white_rate_noise,
)
from analysis.units.conversions import (
    arw_deg_rt_h_to_deg_rt_s,
    q_urad_to_deg,
    rate_deg_h_to_deg_s,
    rrw_deg_h_1_5_to_deg_s_1_5,
)

FS_HZ = 100.0
N_SAMPLES = 100_000


def coloured_noise(seed: int, kind: str) -> np.ndarray:
    """White rate noise (2 deg/sqrt(h)) plus one coloured noise strong enough to shape the
    spectrum."""
    rng = np.random.default_rng(seed)
    x = white_rate_noise(arw_deg_rt_h_to_deg_rt_s(2.0), N_SAMPLES, FS_HZ, rng)
    if kind == "quantization":  # white angle noise: the rate spectrum rises as f^2 to Nyquist
        x = x + white_angle_noise(q_urad_to_deg(50.0), N_SAMPLES, FS_HZ, rng)
    elif kind == "flicker":
        x = x + flicker_rate_noise(rate_deg_h_to_deg_s(30.0), N_SAMPLES, FS_HZ, rng)
    elif kind == "random walk":
        x = x + random_walk_rate_noise(rrw_deg_h_1_5_to_deg_s_1_5(300.0), N_SAMPLES, FS_HZ, rng)
    elif kind == "rounded":  # a coarse output LSB: the rounding error is not Gaussian
        x = np.round((x + 0.3) / 0.05) * 0.05
    return x


@pytest.mark.parametrize("kind", ["white", "quantization", "flicker", "random walk", "rounded"])
def test_no_tone_in_coloured_noise(kind: str) -> None:
    """Negative controls: 4 seeds each here (benchmarks/bench_readoffs.py: 0 of 600 at 1e5
    samples and 0 of 60 at 1e6, family-wise level 1e-3)."""
    for seed in range(4):
        assert find_tones(coloured_noise(seed, kind), FS_HZ) == ()


def test_a_sinusoid_is_found_with_its_frequency_and_amplitude() -> None:
    x = coloured_noise(0, "flicker")
    t = np.arange(N_SAMPLES) / FS_HZ
    amplitude, freq = (
        0.05,
        7.3,
    )  # deg/s: its power is a tenth of the white noise's in the whole band
    tones = find_tones(x + amplitude * np.sin(2 * np.pi * freq * t + 0.4), FS_HZ)
    assert len(tones) == 1
    tone = tones[0]
    assert tone.freq_hz == pytest.approx(freq, abs=FS_HZ / welch_segment(N_SAMPLES))
    assert tone.amplitude_deg_s == pytest.approx(amplitude, rel=0.1)
    assert tone.band_hz[0] < freq < tone.band_hz[1] and tone.p_value < 1e-3
    assert tone.amplitude_stderr_deg_s < 0.1 * amplitude
    assert set(tone.as_dict()) >= {"freq_hz", "amplitude_deg_s"}


def test_a_wandering_line_is_one_tone_carrying_its_power_and_allan_variance() -> None:
    """A resonance whose frequency drifts 19-21 Hz (as on the ADIS16405's z axis): one tone, the
    power of the whole line, and its Allan variance is the sinusoid's at taus beyond a period."""
    rng = np.random.default_rng(5)
    t = np.arange(N_SAMPLES) / FS_HZ
    freq = 20.0 + 1.0 * np.sin(2 * np.pi * t / 300.0)
    amplitude = 0.3
    line = amplitude * np.sin(2 * np.pi * np.cumsum(freq) / FS_HZ)
    x = white_rate_noise(arw_deg_rt_h_to_deg_rt_s(2.0), N_SAMPLES, FS_HZ, rng) + line
    tones = find_tones(x, FS_HZ)
    assert len(tones) == 1
    tone = tones[0]
    assert 19.5 < tone.freq_hz < 20.5 and tone.band_hz[0] < 19.2 and tone.band_hz[1] > 20.8
    assert tone.amplitude_deg_s == pytest.approx(amplitude, rel=0.1)
    # the tone's Allan variance is the line's own, at one or many periods
    r = overlapping_allan_variance(line, FS_HZ, taus=np.array([0.01, 0.02, 0.03, 0.25, 1.0, 3.0]))
    assert tones_avar(tones, r.tau_s, FS_HZ) == pytest.approx(r.avar, rel=0.2)
    # and beyond a few periods, the sin^4 lobes averaged over the band: 3/8 of IEEE 952's envelope
    envelope = amplitude**2 * 3.0 / 8.0 / (np.pi * 20.0 * r.tau_s[-2:]) ** 2
    assert r.avar[-2:] == pytest.approx(envelope, rel=0.2)


def test_the_allan_variance_of_a_sampled_tone_tends_to_ieee_952() -> None:
    """The discrete form equals A^2 sin^4(x)/x^2 (IEEE 952 Annex C) when f << fs."""
    tone = find_tones(np.sin(2 * np.pi * 0.5 * np.arange(200_000) / FS_HZ)
                      + white_rate_noise(0.01, 200_000, FS_HZ, np.random.default_rng(1)), FS_HZ)[0]
    tau = np.array([0.3, 0.7, 1.3, 3.1])
    assert tone.avar(tau, FS_HZ) == pytest.approx(sinusoid_avar(tau, 1.0, 2.0), rel=0.05)


def test_short_records_and_bad_input() -> None:
    assert find_tones(np.zeros(500), FS_HZ) == ()  # too short for 32 segments of 64 samples
    with pytest.raises(ValueError, match="alpha"):
        find_tones(np.zeros(10_000), FS_HZ, alpha=2.0)
    with pytest.raises(ValueError, match="one axis"):
        find_tones(np.zeros((10_000, 2)), FS_HZ)


def test_numpy_welch_is_scipys_welch() -> None:
    """The spectrum the tones are found in is ``scipy.signal.welch``'s (Hann, half
    overlap, mean removed per segment, one-sided density) within 1e-13 relative, computed
    without importing scipy.signal (1.2-1.4 s of a command's start)."""
    from scipy import signal

    from analysis.figures.tones import hann_welch

    rng = np.random.default_rng(5)
    for n, segment in ((360_000, 8192), (100_001, 4096), (12_345, 1024)):
        x = rng.standard_normal(n) + 5.0 + np.sin(0.3 * np.arange(n))
        f, p = signal.welch(x, fs=100.0, window="hann", nperseg=segment,
                            noverlap=segment // 2, detrend="constant", scaling="density")
        ours_f, ours_p = hann_welch(x, 100.0, segment)
        assert np.array_equal(ours_f, f)
        assert ours_p.shape == p.shape
        assert np.max(np.abs(ours_p / p - 1.0)) < 1e-13
