"""Tones: narrow-band lines in a rate record, found in its Welch periodogram.

A tone (a resonance, a motor, a dither frequency beating with the sample clock) is a
deterministic line, not noise; its Allan signature at taus of a few periods (a bump,
then a -1 slope on the Allan deviation) looks like quantization noise to the five-term
fit and like a white-noise excess to a read-off. :func:`find_tones` finds the lines so
that the analysis can say so and keep them out of both.

**Spectrum.** Welch's averaged periodogram (what ``scipy.signal.welch`` computes, within
3e-15 relative, in numpy: :func:`hann_welch`; importing scipy.signal costs a command
1.2-1.4 s: Hann window, 50 %
overlap, mean removed per segment, one-sided density in (deg/s)^2/Hz) with segments of
``2^k`` samples, at least :data:`MIN_SEGMENTS` of them. Each ordinate is then a chi-square
variable with ``nu = 2K / (1 + 2 rho^2)`` degrees of freedom over its expectation (``K``
segments, ``rho = 0.167`` the correlation of Hann segments overlapping by half; Welch
1967, eq. 25 with the Hann window's overlap correlation, as tabulated by Harris 1978).

**Background.** The median of the ordinates in a window symmetric in frequency about
each bin, ``[f (1 - w), f (1 + w)]`` (w = :data:`WINDOW_FRACTION`), divided by the median
of ``chi2(nu)/nu``. The median of a monotone sequence is its middle element, so any
smooth spectrum that is monotone across the window (white, flicker, random walk,
quantization's ``f^2``, a filter's roll-off) is followed exactly at the centre bin, and a
line narrower than half the window does not move it much. Bins whose symmetric window
would hold fewer than ``2 MIN_HALF_WINDOW + 1`` bins (the lowest frequencies, the last
bins before Nyquist) are not tested.

**Test.** ``R_k = P_k / B_k`` is ``chi2(nu_eff)/nu_eff`` under the null, with
``nu_eff = nu / (1 + pi / (2 n))`` widening for the median's own error (its variance is
``pi/2`` times a mean's, over ``n`` independent bins, half the window's bins for Hann).
A bin is significant when its p-value is below ``alpha / n_tested`` (Bonferroni over
every tested bin, family-wise level ``alpha``) and it stands at least
:data:`MIN_PEAK_RATIO` above the background. Adjacent significant bins form one tone;
its band grows to the bins still above the background by one standard deviation (plus
the Hann main lobe), its power is the excess over the background summed over the band,
its ``amplitude_deg_s`` that of the sinusoid of equal power (``sqrt(2 power)``) and its
``freq_hz`` the excess-weighted mean frequency.

**Allan variance of a tone.** For a sampled record, ``avar(tau) = 2 sum_k e_k
sin^4(pi f_k tau) / (m sin(pi f_k / fs))^2`` with ``e_k`` the excess power in bin k and
``m = tau fs`` (the discrete form of IEEE Std 952-1997 Annex C's ``A^2 sin^4(x)/x^2``,
x = pi f tau, to which it tends when f << fs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import blocks
from analysis.allan.estimators import as_samples, check_sample_rate
from analysis.allan.gaps import valid_stretches
from analysis.distributions import chi2_ppf, chi2_sf

#: Fewest Welch segments (each bin's edf is about 1.9 times the count).
MIN_SEGMENTS = 32
#: Longest Welch segment, samples (frequency resolution fs / 8192).
MAX_SEGMENT = 8192
#: Shortest segment worth testing, samples.
MIN_SEGMENT = 64
#: Half-width of the background window as a fraction of the bin's frequency.
WINDOW_FRACTION = 0.25
#: Fewest bins either side of a tested bin in its background window.
MIN_HALF_WINDOW = 8
#: Family-wise false-alarm level of the line test over every tested bin.
ALPHA = 1e-3
#: A line must raise the spectrum at its peak at least this much over the background.
MIN_PEAK_RATIO = 1.5
#: Most tones reported (the strongest).
MAX_TONES = 10
#: Correlation of adjacent Hann segments overlapping by half.
HANN_OVERLAP_RHO = 0.167


@dataclass(frozen=True)
class Tone:
    """A narrow-band line of a rate record.

    Attributes
    ----------
    freq_hz : float
        Excess-weighted mean frequency of the line, Hz.
    amplitude_deg_s : float
        Peak amplitude of the sinusoid carrying the line's power, deg/s.
    band_hz : tuple of float
        Lowest and highest frequency of the bins the line occupies, Hz.
    peak_ratio : float
        Periodogram ordinate over the background at the line's strongest bin.
    p_value : float
        Family-wise p-value of that bin (Bonferroni over the bins tested).
    bin_freq_hz, bin_power : tuple of float
        The band's bins and their excess power over the background, (deg/s)^2 each.
    amplitude_stderr_deg_s : float
        Standard error of the amplitude (each ordinate's chi-square spread over the band).
    """

    freq_hz: float
    amplitude_deg_s: float
    band_hz: tuple[float, float]
    peak_ratio: float
    p_value: float
    bin_freq_hz: tuple[float, ...] = ()
    bin_power: tuple[float, ...] = ()
    amplitude_stderr_deg_s: float = 0.0

    def avar(self, tau_s: ArrayLike, sample_rate_hz: float) -> NDArray[np.float64]:
        """Allan variance ((deg/s)^2) the line adds at ``tau_s`` in a record sampled at
        ``sample_rate_hz``."""
        tau = np.atleast_1d(np.asarray(tau_s, dtype=float))
        f = np.asarray(self.bin_freq_hz)[None, :]
        e = np.asarray(self.bin_power)[None, :]
        m = tau[:, None] * sample_rate_hz
        dirichlet = (m * np.sin(np.pi * f / sample_rate_hz)) ** 2
        return np.asarray((2.0 * e * np.sin(np.pi * f * tau[:, None]) ** 4 / dirichlet).sum(axis=1),
                          dtype=np.float64)

    def as_dict(self) -> dict[str, object]:
        """JSON form: ``freq_hz``, ``amplitude_deg_s``, ``band_hz``, ``peak_ratio``, ``p_value``."""
        return {
            "freq_hz": self.freq_hz,
            "amplitude_deg_s": self.amplitude_deg_s,
            "band_hz": list(self.band_hz),
            "peak_ratio": self.peak_ratio,
            "p_value": self.p_value,
        }

    def describe(self, unit: str = "deg/s") -> str:
        """One line for a report: frequency, amplitude, band and strength (the amplitude in
        ``unit``, that of the series: "m/s^2" for an accelerometer's)."""
        return (
            f"tone at {self.freq_hz:.4g} Hz ({self.band_hz[0]:.4g}-{self.band_hz[1]:.4g} Hz), "
            f"amplitude {self.amplitude_deg_s:.3g} {unit}, {self.peak_ratio:.1f} x the background"
        )


def welch_segment(n_samples: int) -> int | None:
    """Welch segment length (a power of 2) for a record of ``n_samples``; None if too short."""
    longest = (
        2 * n_samples // (MIN_SEGMENTS + 1)
    )  # K half-overlapping segments span (K + 1) / 2 lengths
    if longest < MIN_SEGMENT:
        return None
    return int(min(MAX_SEGMENT, 2 ** int(math.floor(math.log2(longest)))))


def welch_edf(segments: int) -> float:
    """Degrees of freedom of one Welch ordinate averaged over ``segments`` (Hann, 50 % overlap)."""
    return 2.0 * segments / (1.0 + 2.0 * HANN_OVERLAP_RHO**2 * (segments - 1) / segments)


def welch_spectrum(x: NDArray[np.float64], sample_rate_hz: float
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], float] | None:
    """(frequencies, Welch density, edf per ordinate) of a rate record; NaN marks missing samples.

    A record with gaps is averaged over the segments that fit inside its gap-free
    stretches (each stretch's periodogram weighted by its segment count), so no segment
    straddles a gap. None when fewer than :data:`MIN_SEGMENTS` segments of
    :data:`MIN_SEGMENT` samples fit.
    """
    if blocks.is_long(len(x)):
        stretches = _stretches_long(x)
    else:
        stretches = list(zip(*valid_stretches(np.isfinite(x)), strict=True))
    segment = welch_segment(sum(b - a for a, b in stretches))
    longest = max((b - a for a, b in stretches), default=0)
    while segment is not None and segment > longest:
        segment = segment // 2 if segment // 2 >= MIN_SEGMENT else None
    if segment is None:
        return None
    total, counts, freq = None, 0, None
    for a, b in stretches:
        if b - a < segment:
            continue
        k = (b - a - segment) // (segment // 2) + 1
        f, p = _welch_sum(x, a, k, segment, sample_rate_hz)
        total = p if total is None else total + p
        counts += k
        freq = f
    if total is None or freq is None or counts < MIN_SEGMENTS // 2:
        return None
    return (np.asarray(freq, dtype=np.float64), np.asarray(total / counts, dtype=np.float64),
            welch_edf(counts))


def _welch_sum(x: NDArray[np.float64], a: int, k: int, segment: int, fs: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(frequencies, sum of the ``k`` half-overlapping Hann periodograms from sample ``a``):
    scipy's Welch average times ``k``, over groups of segments of at most a block of
    samples (a long record is never copied whole)."""
    hop = segment // 2
    per_group = k if not blocks.is_long(k * hop) else max(1, blocks.BLOCK_SAMPLES // hop)
    total = None
    for s0, s1 in blocks.spans(0, k, per_group):
        start = a + s0 * hop
        chunk = np.asarray(x[start: start + (s1 - s0 - 1) * hop + segment], dtype=np.float64)
        f, p = hann_welch(chunk, fs, segment)
        total = p * (s1 - s0) if total is None else total + p * (s1 - s0)
        blocks.release(x)
    assert total is not None
    return f, total


def hann_welch(x: NDArray[np.float64], fs: float, segment: int
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(frequencies in Hz, one-sided Welch density) of ``x``: the mean of the periodograms
    of its half-overlapping segments of ``segment`` samples (from sample 0; a partial last
    one is left out), each with its mean removed and a periodic Hann window, scaled by
    ``1 / (fs sum w^2)`` and doubled but at 0 and Nyquist: ``scipy.signal.welch(x, fs,
    "hann", segment, segment // 2, detrend="constant", scaling="density")`` (scipy 1.17),
    whose ordinates it gives within 3e-15 relative (the FFT is numpy's)."""
    hop = segment // 2
    count = (len(x) - (segment - hop)) // hop
    window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(segment) / segment)
    frames = np.lib.stride_tricks.sliding_window_view(x, segment)[::hop][:count]
    spectra = np.fft.rfft((frames - frames.mean(axis=1, keepdims=True)) * window, axis=1)
    power = (spectra.real**2 + spectra.imag**2) / (fs * float(np.sum(window * window)))
    power[:, 1:-1] *= 2.0
    frequencies = np.asarray(np.fft.rfftfreq(segment, 1.0 / fs), dtype=np.float64)
    return frequencies, np.asarray(power.mean(axis=0), dtype=np.float64)


def _stretches_long(x: NDArray[np.float64]) -> list[tuple[int, int]]:
    """The gap-free stretches (no NaN) of a long record, as ``(start, stop)``, a block at a time."""
    out: list[tuple[int, int]] = []
    open_at: int | None = None
    for a, b in blocks.spans(0, len(x)):
        present = np.isfinite(np.asarray(x[a:b]))
        edges = np.flatnonzero(np.diff(present.astype(np.int8))) + 1
        cuts = [0, *edges.tolist(), b - a]
        for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
            if present[lo]:
                open_at = a + lo if open_at is None else open_at
                if hi < b - a:
                    out.append((open_at, a + hi))
                    open_at = None
            elif open_at is not None:
                out.append((open_at, a + lo))
                open_at = None
        blocks.release(x)
    if open_at is not None:
        out.append((open_at, len(x)))
    return out


def running_background(
    power: NDArray[np.float64], nu: float
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Background level of every bin and its window's half-width in bins (0: not tested).

    The median is taken at bins spaced by an eighth of their half-window (every bin where
    the window is narrow) and interpolated between them: the background is smooth on the
    scale of its window by construction, and this keeps a 4097-bin spectrum to a few
    hundred medians.
    """
    n = len(power)
    k = np.arange(n)
    half = np.minimum(np.rint(WINDOW_FRACTION * k).astype(np.int64), n - 1 - k)
    half[half < MIN_HALF_WINDOW] = 0
    background = np.full(n, np.nan)
    tested = np.flatnonzero(half)
    if tested.size == 0:
        return background, half
    correction = float(chi2_ppf(0.5, nu)) / nu
    picks = [int(tested[0])]
    for i in tested[1:]:
        if i - picks[-1] >= max(1, half[picks[-1]] // 8) or i == tested[-1]:
            picks.append(int(i))
    level = np.array([np.median(power[i - half[i]: i + half[i] + 1]) for i in picks]) / correction
    background[tested] = np.exp(np.interp(tested, picks, np.log(level)))
    return background, half


def find_tones(
    rate_deg_s: ArrayLike,
    sample_rate_hz: float,
    *,
    alpha: float = ALPHA,
    max_tones: int = MAX_TONES,
) -> tuple[Tone, ...]:
    """Narrow-band lines of a 1-D rate record (deg/s), strongest first.

    Parameters
    ----------
    rate_deg_s : array_like, shape (N,)
        Rate samples, deg/s; NaN where a sample is missing (a record with gaps).
    sample_rate_hz : float
        Sample rate, Hz.
    alpha : float
        Family-wise false-alarm level over every bin tested (default 1e-3).
    max_tones : int
        Most tones returned.

    Returns
    -------
    tuple of Tone
        Empty when there is none, or the record is shorter than ``MIN_SEGMENTS``
        segments of ``MIN_SEGMENT`` samples.

    Raises
    ------
    ValueError
        If ``alpha`` is not in (0, 1) or the record has more than one axis.
    """
    fs = check_sample_rate(sample_rate_hz)
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    x = np.asarray(rate_deg_s, dtype=np.float64)
    x = x[:, 0] if x.ndim == 2 and x.shape[1] == 1 else x
    if x.ndim != 1:
        raise ValueError(f"find tones one axis at a time, got shape {x.shape}")
    if blocks.any_where(x, np.isinf) if blocks.is_long(len(x)) else np.isinf(x).any():
        as_samples(x)  # raises NonFiniteSamplesError naming the samples
    spectrum = welch_spectrum(x, fs)
    if spectrum is None:
        return ()
    freq, power, nu = spectrum
    background, half = running_background(power, nu)
    tested = half > 0
    if not tested.any():
        return ()
    ratio = np.where(tested, power / np.where(tested, background, 1.0), 0.0)
    nu_eff = nu / (1.0 + np.pi / np.maximum(2.0 * half + 1.0, 1.0))
    p_bin = np.where(tested, chi2_sf(ratio * nu_eff, nu_eff), 1.0)
    n_tested = int(tested.sum())
    significant = (p_bin * n_tested < alpha) & (ratio >= MIN_PEAK_RATIO)
    df = float(freq[1] - freq[0])
    bands = _merged([_grow(power, background, lo, hi, nu) for lo, hi in _runs(significant, gap=2)])
    found = (
        _tone(freq, power, background, ratio, p_bin, n_tested, lo, hi, df, nu) for lo, hi in bands
    )
    tones = [t for t in found if t is not None]
    return tuple(sorted(tones, key=lambda t: -t.amplitude_deg_s)[:max_tones])


def _runs(mask: NDArray[np.bool_], *, gap: int) -> list[tuple[int, int]]:
    """Index ranges ``[lo, hi]`` of the True runs of ``mask``, runs closer than ``gap`` merged."""
    out: list[tuple[int, int]] = []
    for a, b in zip(*valid_stretches(mask), strict=True):
        if out and a <= out[-1][1] + gap + 1:
            out[-1] = (out[-1][0], int(b) - 1)
        else:
            out.append((int(a), int(b) - 1))
    return out


def _grow(power: NDArray[np.float64], background: NDArray[np.float64], lo: int, hi: int,
          nu: float) -> tuple[int, int]:
    """Bins ``lo..hi`` grown to where the excess ends (one standard deviation) plus the Hann main
    lobe."""
    above = 1.0 + math.sqrt(2.0 / nu)
    n = len(power)
    while lo > 0 and np.isfinite(background[lo - 1]) and power[lo - 1] > above * background[lo - 1]:
        lo -= 1
    while (
        hi < n - 1
        and np.isfinite(background[hi + 1])
        and power[hi + 1] > above * background[hi + 1]
    ):
        hi += 1
    return max(lo - 2, 0), min(hi + 2, n - 1)  # the Hann main lobe is 4 bins wide


def _merged(bands: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Overlapping or touching bin ranges merged into one."""
    out: list[tuple[int, int]] = []
    for lo, hi in sorted(bands):
        if out and lo <= out[-1][1] + 1:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def _tone(freq: NDArray[np.float64], power: NDArray[np.float64], background: NDArray[np.float64],
          ratio: NDArray[np.float64], p_bin: NDArray[np.float64], n_tested: int, lo: int, hi: int,
          df: float, nu: float) -> Tone | None:
    """The tone occupying bins ``lo..hi``."""
    band = slice(lo, hi + 1)
    bg = np.where(np.isfinite(background[band]), background[band], np.nan)
    if np.isnan(bg).any():  # the lobe reaches an untested bin: take its nearest background
        bg = np.interp(np.arange(lo, hi + 1), np.flatnonzero(~np.isnan(bg)) + lo, bg[~np.isnan(bg)])
    excess = np.maximum(power[band] - bg, 0.0) * df
    total = float(excess.sum())
    if total <= 0:
        return None
    peak = lo + int(np.argmax(np.where(np.isfinite(ratio[band]), ratio[band], 0.0)))
    # var(P_k) = 2 P_k^2 / nu per ordinate; adjacent Hann ordinates are correlated, counted as 2
    total_sd = math.sqrt(2.0 * float(np.sum(power[band] ** 2)) * 2.0 / nu) * df
    amplitude = math.sqrt(2.0 * total)
    return Tone(
        freq_hz=float(np.sum(freq[band] * excess) / total),
        amplitude_deg_s=amplitude,
        band_hz=(float(freq[lo]), float(freq[hi])),
        peak_ratio=float(ratio[peak]),
        p_value=float(min(1.0, p_bin[peak] * n_tested)),
        bin_freq_hz=tuple(float(f) for f in freq[band]),
        bin_power=tuple(float(e) for e in excess),
        amplitude_stderr_deg_s=amplitude * total_sd / (2.0 * total),
    )


def tones_avar(
    tones: tuple[Tone, ...], tau_s: ArrayLike, sample_rate_hz: float
) -> NDArray[np.float64]:
    """Allan variance ((deg/s)^2) that all ``tones`` add at ``tau_s``."""
    tau = np.atleast_1d(np.asarray(tau_s, dtype=float))
    total = np.zeros(tau.shape)
    for tone in tones:
        total = total + tone.avar(tau, sample_rate_hz)
    return total
