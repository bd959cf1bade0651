"""Model versus measurement: a faint correlated process the Allan curve cannot see (the
Gauss-Markov process' detector).

A Gauss-Markov process of a few seconds and a twentieth of the white noise's standard
deviation lifts the spectrum below its corner ``1 / (2 pi T)`` by a fifth or so: the
Allan curve spreads that over an octave or two whose intervals hold it, and the gap (G2 of
:mod:`analysis.reconcile.discrepancy`) averages it with every other octave. The
periodogram's likelihood weighs each of the few hundred Fourier frequencies below the
corner: where the gap finds 269 of 300 faint processes of
``benchmarks/bench_reconcile_naming.py``, a likelihood ratio of this kind finds 280 of them
at the same false-alarm rate (``benchmarks/bench_reconcile_ceiling.py``, its test told only
the effect's kind). This module is that test, as :mod:`analysis.reconcile.line_test` is the
sinusoid's.

**Spectrum of the model.** Every sample is the mean rate over its period (the station's
simulator and an integrating gyro alike), so each stochastic term's spectrum is that of
its sample means, ``S(w) = r_0 + 2 sum_k r_k cos(k w)`` over the covariances ``r_k`` of
the means, ``w`` in rad per sample (:func:`model_spectrum`):

* white rate noise (ARW): ``N^2 / dt``; quantization: ``Q^2 4 sin^2(w/2) / dt^2``;
* a Gauss-Markov process of variance ``s^2`` and correlation time ``T`` (``h = dt / T``,
  ``a = e^-h``): ``r_0 = 2 s^2 (h - 1 + a) / h^2``, ``r_k = s^2 (1 - a)^2 a^(k-1) / h^2``,
  so

      S_GM(w) = r_0 + 2 r_1 (cos w - a) / (1 - 2 a cos w + a^2)                      (P1)

  (``h -> 0``: the AR(1) spectrum ``s^2 (1 - a^2) / (1 - 2 a cos w + a^2)``);
* bias instability: the sum of (P1) over the flicker bank's poles and its white and
  random-walk tails (:func:`analysis.models.noise.flicker_bank`, the simulator's own);
* a rate random walk: ``K^2 dt (2 + cos w) / (3 * 4 sin^2(w/2))``.

Deterministic terms (bias, ramp, sinusoid, temperature, steps) are taken out of the record
before the test (:class:`analysis.reconcile.confirm.RoundEvidence`), and its least-squares
line with them.

**Test.** With ``I_k = |X_k|^2 / n`` the periodogram of the record (less its line) at the
Fourier frequencies ``w_k = 2 pi k / n``, ``0 < k < n / 2``, Whittle's log-likelihood ratio
of the model plus a Gauss-Markov process ``(s, T)`` against the model alone,

    Lambda(s, T) = sum_k I_k (1 / S0_k - 1 / S1_k) + log(S0_k / S1_k),
    S1 = S0 + S_GM(s, T),                                                            (P2)

is maximized over a grid of ``T`` (``GRID_PER_OCTAVE`` per octave, from two samples to
``GM_TAU_LIMIT`` of the record, beyond which a process is a random walk) and of ``s``
(``SIGMA_STEPS`` log-spaced from ``SIGMA_RANGE[0]`` to ``SIGMA_RANGE[1]`` of the model's
white level). The model disagrees when the maximum exceeds its ``1 - alpha`` quantile under
the model, taken over ``NULL_DRAWS`` periodograms drawn as ``S0_k E_k`` with ``E_k`` Exp(1)
(Whittle's own null, seeded: the threshold is the model's and the record length's, not a
table's) (P3). The maximizing ``(s, T)`` is the process to add. Records longer than
``MAX_SAMPLES`` are tested as block means (the same means of a slower rate).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.models.noise import flicker_bank
from analysis.models.terms import (
    AngleRandomWalk,
    BiasInstability,
    GaussMarkov,
    NoiseModel,
    Quantization,
    RateRandomWalk,
)
from analysis.reconcile.discrepancy import ComparisonCache, block_means
from analysis.units.conversions import rate_deg_s_to_deg_h

#: Correlation times searched per octave.
GRID_PER_OCTAVE = 2
#: Standard deviations searched, as shares of the model's white level (the square root of its
#: spectrum at the highest frequency), and how many, log-spaced.
SIGMA_RANGE = (0.01, 1.0)
SIGMA_STEPS = 12
#: Periodograms drawn under the model for the threshold (P3).
NULL_DRAWS = 400
#: Longer records are tested as block means of at most this many samples.
MAX_SAMPLES = 1 << 15
#: The longest correlation time searched, as a share of the record (that of
#: :data:`analysis.reconcile.confirm.GM_TAU_LIMIT`: beyond it a process is a random walk).
TAU_LIMIT = 0.25


def sampled_gauss_markov_spectrum(sigma: float, tau_s: float, dt_s: float,
                                  w: NDArray[np.float64]) -> NDArray[np.float64]:
    """(P1): the spectrum of the sample means (over ``dt_s``) of a Gauss-Markov rate of
    standard deviation ``sigma`` (deg/s) and correlation time ``tau_s`` (s), at ``w`` (rad
    per sample), (deg/s)^2 per unit of ``w / 2 pi``."""
    h = dt_s / tau_s
    a = math.exp(-h)
    one_minus_a = -math.expm1(-h)
    # h - 1 + a = h + expm1(-h), by its series where the two nearly cancel
    lead = h * h / 2.0 - h**3 / 6.0 + h**4 / 24.0 if h < 1e-3 else h + math.expm1(-h)
    r0 = 2.0 * sigma**2 * lead / h**2
    r1 = sigma**2 * one_minus_a**2 / h**2
    out: NDArray[np.float64] = r0 + 2.0 * r1 * (np.cos(w) - a) / (1.0 - 2.0 * a * np.cos(w) + a * a)
    return out


def model_spectrum(model: NoiseModel, sample_rate_hz: float,
                   w: NDArray[np.float64]) -> NDArray[np.float64]:
    """The spectrum of the model's stochastic terms' sample means at ``w`` (rad per sample),
    (deg/s)^2 per unit of ``w / 2 pi``: the expected periodogram ``|X|^2 / n`` of a record of
    the model (module docstring)."""
    dt = 1.0 / sample_rate_hz
    total = np.zeros_like(w)
    walk = 0.0
    for term in model.terms:
        if isinstance(term, AngleRandomWalk):
            total += term.n_deg_rt_s**2 / dt
        elif isinstance(term, Quantization):
            total += term.q_deg**2 * 4.0 * np.sin(w / 2.0) ** 2 / dt**2
        elif isinstance(term, GaussMarkov):
            total += sampled_gauss_markov_spectrum(term.sigma_deg_s, term.tau_s, dt, w)
        elif isinstance(term, BiasInstability):
            bank = flicker_bank(term.b_deg_s, sample_rate_hz)
            for s, t in zip(bank.sigma, bank.correlation_s, strict=True):
                total += sampled_gauss_markov_spectrum(float(s), float(t), dt, w)
            total += bank.white_n**2 / dt
            walk += bank.walk_k**2
        elif isinstance(term, RateRandomWalk):
            walk += term.k_deg_s_1_5**2
    if walk > 0:
        total += walk * dt * (2.0 + np.cos(w)) / (12.0 * np.sin(w / 2.0) ** 2)
    return total


def periodogram(rate: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(w, I): the Fourier frequencies ``0 < k < n / 2`` (rad per sample) and the periodogram
    ``|X_k|^2 / n`` of ``rate`` less its least-squares line."""
    n = rate.shape[0]
    t = np.arange(n, dtype=np.float64)
    slope, intercept = np.polyfit(t, rate, 1)
    x = rate - (slope * t + intercept)
    k = np.arange(1, (n - 1) // 2 + 1)
    out: NDArray[np.float64] = np.abs(np.fft.rfft(x)[k]) ** 2 / n
    return 2.0 * np.pi * k / n, out


@dataclass(frozen=True)
class ProcessDetection:
    """The best Gauss-Markov process (P2) the test finds and whether it is significant.

    Attributes
    ----------
    statistic : float
        The largest log-likelihood ratio Lambda (P2), dimensionless.
    threshold : float
        Its ``1 - alpha`` quantile under the model (P3).
    sigma_deg_s, tau_s : float
        The maximizing standard deviation (deg/s) and correlation time (s).
    """

    statistic: float
    threshold: float
    sigma_deg_s: float
    tau_s: float

    @property
    def significant(self) -> bool:
        """Whether the model disagrees (Lambda above its threshold)."""
        return self.statistic > self.threshold

    def term(self) -> GaussMarkov:
        """The process to add."""
        return GaussMarkov(sigma_deg_h=rate_deg_s_to_deg_h(self.sigma_deg_s), tau_s=self.tau_s)

    def describe(self) -> str:
        """One line for the report."""
        return (f"spectral process test: log-likelihood ratio {self.statistic:.3g} > "
                f"{self.threshold:.3g} (sigma {rate_deg_s_to_deg_h(self.sigma_deg_s):.3g} "
                f"deg/h, T {self.tau_s:.3g} s)")


def detect_process(rate_deg_s: NDArray[np.float64], sample_rate_hz: float, model: NoiseModel,
                   *, alpha: float, seed: int = 0, cache: ComparisonCache | None = None,
                   ) -> ProcessDetection | None:
    """Test a record (the model's deterministic terms taken out) for a Gauss-Markov process
    the model lacks (P2, P3).

    Parameters
    ----------
    rate_deg_s : ndarray, shape (n,)
        The record, deg/s.
    sample_rate_hz : float
        Its sample rate, Hz.
    model : NoiseModel
        The model under test.
    alpha : float
        False-alarm rate of the test.
    seed : int
        Seed of the null draws.
    cache : ComparisonCache, optional
        Memo of the thresholds: records of one model and length (seeds of a test, axes and
        units of a line) draw its null once.

    Returns
    -------
    ProcessDetection or None
        None when the model has no stochastic spectrum or the record is too short for a
        grid of correlation times.
    """
    block = max(1, -(-rate_deg_s.shape[0] // MAX_SAMPLES))
    rate_deg_s = block_means(rate_deg_s, block)
    fs = sample_rate_hz / block
    dt = 1.0 / fs
    w, obs = periodogram(np.asarray(rate_deg_s, dtype=np.float64))
    s0 = model_spectrum(model, fs, w)
    if w.size < 16 or not np.all(s0 > 0):
        return None
    octaves = math.log2(TAU_LIMIT * rate_deg_s.shape[0] / 2.0)
    if octaves < 1:
        return None
    taus = 2.0 * dt * 2.0 ** np.linspace(0.0, octaves, int(octaves * GRID_PER_OCTAVE) + 1)
    sigmas = math.sqrt(float(s0[-1])) * np.geomspace(SIGMA_RANGE[0], SIGMA_RANGE[1], SIGMA_STEPS)
    best, best_at = -np.inf, (0.0, 0.0)
    for tau, weight, offset in _alternatives(s0, w, dt, taus, sigmas):
        observed = obs @ weight + offset
        i = int(np.argmax(observed))
        if observed[i] > best:
            best, best_at = float(observed[i]), (float(sigmas[i]), float(tau))
    cache = cache if cache is not None else ComparisonCache()
    threshold = cache.get(("process test", repr(model), w.size, fs, alpha, seed),
                          lambda: _threshold(s0, w, dt, taus, sigmas, alpha, seed))
    return ProcessDetection(statistic=best, threshold=threshold, sigma_deg_s=best_at[0],
                            tau_s=best_at[1])


def _alternatives(s0: NDArray[np.float64], w: NDArray[np.float64], dt: float,
                  taus: NDArray[np.float64], sigmas: NDArray[np.float64],
                  ) -> Iterator[tuple[float, NDArray[np.float64], NDArray[np.float64]]]:
    """Per correlation time of the grid: ``T`` and the weights ``1/S0 - 1/S1`` and offsets
    ``sum log(S0/S1)`` of (P2) for every sigma (columns)."""
    inv0 = 1.0 / s0
    for tau in taus:
        shape = sampled_gauss_markov_spectrum(1.0, float(tau), dt, w)
        s1 = s0[:, None] + shape[:, None] * sigmas[None, :] ** 2
        yield float(tau), inv0[:, None] - 1.0 / s1, np.sum(np.log(s0[:, None] / s1), axis=0)


def _threshold(s0: NDArray[np.float64], w: NDArray[np.float64], dt: float,
               taus: NDArray[np.float64], sigmas: NDArray[np.float64], alpha: float,
               seed: int) -> float:
    """(P3): the ``1 - alpha`` quantile of the largest (P2) over ``NULL_DRAWS`` periodograms
    ``S0 E`` of the model, ``E`` Exp(1)."""
    draws = s0 * np.random.default_rng(seed).standard_exponential((NULL_DRAWS, w.size))
    null = np.full(NULL_DRAWS, -np.inf)
    for _, weight, offset in _alternatives(s0, w, dt, taus, sigmas):
        null = np.maximum(null, (draws @ weight + offset).max(axis=1))
    return float(np.quantile(null, 1.0 - alpha))


__all__ = [
    "ProcessDetection",
    "detect_process",
    "model_spectrum",
    "periodogram",
    "sampled_gauss_markov_spectrum",
]
