"""The most any method can name of ``bench_reconcile_naming``'s hidden effects: the detection
rate of the likelihood-ratio test that is told the hidden effect's kind and parameters.

Naming an effect needs at least detecting it. On a record of the naming bench's generator
(:mod:`benchmarks.bench_reconcile_naming`: its base model, ranges and seeds), the most
powerful test of "this effect, with these parameters" against "the base model alone" at a
false-alarm rate alpha is the Neyman-Pearson test, which is told what a real method has to
find out: the effect, its magnitude and its time scale. Its detection rate over the effect's
parameter range is a ceiling on the share of records any reconcile can name right while
naming something in no more than alpha of clean records (naming also has to tell the effect
from its rivals, with its parameters unknown).

The test (spectra in the discrete frequency ``w``, rad per sample, over the Fourier
frequencies of the record; :class:`Domain`):

* base: white noise and Kasdin's flicker filter, ``S0 = sigma_w^2 + b^2 / (2 sin(w/2))``
  (:func:`analysis.models.noise.flicker_rate_noise`);
* Gauss-Markov process (``phi = exp(-dt/T)``): ``S1 = S0 + sigma^2 (1 - phi^2) / (1 - 2 phi
  cos w + phi^2)``; rate random walk, on the first difference of the rate (where it is
  stationary; both spectra times ``4 sin^2(w/2)``): ``S1 = S0 + q``, ``q`` the variance of a
  step; the log-likelihood ratio in Whittle's form, ``sum_k log(S0/S1) + I_k (1/S0 - 1/S1)``
  over the periodogram ``I_k``;
* sinusoid of known frequency (its phase unknown): ``|DFT(w0)|^2 / S0(w0)``.

Beside it, the same test told only the effect's kind (:func:`untold_statistic`): its
statistic maximized over the parameters (a grid of sigma and ``T``, of ``q``; the
strongest Fourier frequency), its threshold again from the clean records. That is the
generalized likelihood-ratio test, the detection a method searching the parameters, as
reconcile must, can hope for at the same false-alarm rate.

Each record's statistic is compared with the ``1 - alpha`` quantile of the same statistic
(the same parameters) over ``--clean`` clean records of the generator, so alpha is the
test's false-alarm rate on this generator whatever Whittle's approximation leaves out.
Whittle's likelihood is the exact one in the limit of long records and near it at 36 000
samples: the printed rates are those of a near-optimal test (the exact test could detect a
few more), not a bound to the last record.

    python -m benchmarks.bench_reconcile_ceiling [--first 90000] [--seeds 300] [--clean 1000]
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.signal import windows

from benchmarks.bench_reconcile_naming import (
    B_DEG_H,
    FS_HZ,
    N_SAMPLES,
    RANGES,
    SIGMA_W_DEG_S,
    base_rate,
    effect_parameters,
    hidden,
)


@dataclass(frozen=True)
class Domain:
    """The periodogram a test reads: of the rate itself (``differenced`` False; the
    Gauss-Markov process and the sine, stationary over the base) or of its first difference
    (the walk, stationary only there), under a Tukey taper of ``taper`` (the share of the
    record in its cosine ends; 0: none). The difference needs one: without it the record's
    two ends leak about ``2 sigma_w^2 / n`` into every frequency, a hundred times the base
    spectrum at the lowest ones, where the walk is; a Hann taper (1) removes that too but
    wastes the record (the Gauss-Markov test told the truth detected 263/300 through it,
    283 through 0.1, 285 on the rate untapered)."""

    differenced: bool
    taper: float

    @property
    def n(self) -> int:
        return N_SAMPLES - 1 if self.differenced else N_SAMPLES

    @property
    def w(self) -> np.ndarray:
        """Its Fourier frequencies (k = 1 .. n/2 - 1), rad per sample."""
        return 2.0 * np.pi * np.arange(1, self.n // 2) / self.n

    def window(self) -> np.ndarray:
        return windows.tukey(self.n, self.taper) if self.taper > 0 else np.ones(self.n)

    def gain(self, w: np.ndarray) -> np.ndarray:
        """``|1 - e^-iw|^2`` for the difference, 1 for the rate."""
        return 4.0 * np.sin(w / 2.0) ** 2 if self.differenced else np.ones_like(w)

    def base(self, w: np.ndarray) -> np.ndarray:
        """``S0`` at ``w``: white noise and Kasdin's flicker filter, ``b^2 / (2 sin(w/2))``
        (:func:`analysis.models.noise.flicker_rate_noise`), (deg/s)^2 per rad/sample."""
        flicker = (B_DEG_H / 3600.0) ** 2 / (2.0 * np.sin(w / 2.0))
        out: np.ndarray = self.gain(w) * (SIGMA_W_DEG_S**2 + flicker)
        return out

    def series(self, rates: np.ndarray) -> np.ndarray:
        """The tapered rows of ``rates`` (or of their differences), scaled so that a
        squared DFT divided by nothing more estimates the spectrum."""
        x = np.diff(rates, axis=-1) if self.differenced else rates
        taper = self.window()
        out: np.ndarray = x * taper / math.sqrt(float(taper @ taper))
        return out

    def periodogram(self, rates: np.ndarray) -> np.ndarray:
        """The periodograms of the rows of ``rates`` at :attr:`w`."""
        out: np.ndarray = np.abs(np.fft.rfft(self.series(rates), axis=-1)[..., 1:self.n // 2]) ** 2
        return out


#: The domain of each effect's test.
DOMAINS = {"gauss_markov": Domain(False, 0.0), "sinusoid": Domain(False, 0.0),
           "rate_random_walk": Domain(True, 0.1)}


def parameters(effect: str, seed: int, ranges: str) -> dict[str, float]:
    """The hidden effect's parameters the naming bench draws for ``seed`` (the same draws),
    with a walk's step variance ``q`` ((deg/s)^2) and a sine's frequency ``w0`` (rad per
    sample)."""
    rng = np.random.default_rng(seed)
    base_rate(rng)
    p = effect_parameters(effect, rng, ranges)
    if effect == "rate_random_walk":
        p["q"] = p["k"] ** 2 / FS_HZ
    if effect == "sinusoid":
        p["w0"] = 2.0 * math.pi / (p["period"] * FS_HZ)
    return p


def record(effect: str, seed: int, ranges: str) -> np.ndarray:
    """The naming bench's record of ``seed``: base plus the hidden effect (deg/s)."""
    rng = np.random.default_rng(seed)
    return base_rate(rng) + hidden(effect, rng, ranges)


def statistic(effect: str, p: dict[str, float], series: np.ndarray,
              periodograms: np.ndarray) -> np.ndarray:
    """The test's statistic on each record, given in the effect's domain as rows of
    ``series`` (:meth:`Domain.series`, for a sine) and ``periodograms`` (the others):
    Whittle's log-likelihood ratio, or for a sine the power at its frequency over the base
    spectrum there."""
    domain = DOMAINS[effect]
    if effect == "sinusoid":
        w0 = np.array([p["w0"]])
        tone = series @ np.exp(-1j * w0[0] * np.arange(domain.n))
        out: np.ndarray = np.abs(tone) ** 2 / domain.base(w0)[0]
        return out
    w = domain.w
    s0 = domain.base(w)
    if effect == "gauss_markov":
        phi = math.exp(-1.0 / (FS_HZ * p["tau"]))
        added = p["sigma"] ** 2 * (1.0 - phi**2) / (1.0 - 2.0 * phi * np.cos(w) + phi**2)
        s1 = s0 + domain.gain(w) * added
    else:
        s1 = s0 + p["q"]
    out = periodograms @ (1.0 / s0 - 1.0 / s1) + float(np.sum(np.log(s0 / s1)))
    return out


#: The untold test's search: correlation times (s), log-spaced over 0.5-600 s, and
#: sigmas (of the white noise's standard deviation), log-spaced over 0.02-0.5, of a
#: Gauss-Markov process; step variances of a walk (of the white noise's variance),
#: log-spaced over 1e-9-1e-3. Each spans the faint, wide and narrow ranges with room.
SEARCH_TAU_S = np.exp(np.linspace(math.log(0.5), math.log(600.0), 48))
SEARCH_SIGMA = np.exp(np.linspace(math.log(0.02), math.log(0.5), 30))
SEARCH_Q = np.exp(np.linspace(math.log(1e-9), math.log(1e-3), 61))


def search_spectra(effect: str) -> np.ndarray:
    """The alternative spectra the untold test searches, one column each."""
    domain = DOMAINS[effect]
    w = domain.w
    s0 = domain.base(w)
    if effect == "rate_random_walk":
        return s0[:, None] + SEARCH_Q[None, :] * SIGMA_W_DEG_S**2
    cols = []
    for tau in SEARCH_TAU_S:
        phi = math.exp(-1.0 / (FS_HZ * tau))
        shape = domain.gain(w) * (1.0 - phi**2) / (1.0 - 2.0 * phi * np.cos(w) + phi**2)
        cols.extend(s0 + (s * SIGMA_W_DEG_S) ** 2 * shape for s in SEARCH_SIGMA)
    return np.array(cols).T


def untold_statistic(effect: str, periodograms: np.ndarray,
                     spectra: np.ndarray | None = None) -> np.ndarray:
    """The generalized likelihood-ratio statistic of a test *not* told the parameters: the
    told statistic maximized over them (Whittle's log-likelihood ratio over the grid of
    :func:`search_spectra`; a sine's power over the base spectrum at the strongest Fourier
    frequency), on each record of ``periodograms`` (:meth:`Domain.periodogram`). It knows
    only the effect's kind; its rate is what a method that searches the parameters, as
    reconcile must, can reach at the same false alarms (for a sine nearly: a line between
    two Fourier frequencies loses up to half its power to the search)."""
    domain = DOMAINS[effect]
    if effect == "sinusoid":
        out: np.ndarray = (periodograms / domain.base(domain.w)).max(axis=-1)
        return out
    s1 = search_spectra(effect) if spectra is None else spectra
    s0 = domain.base(domain.w)
    gain = periodograms @ (1.0 / s0[:, None] - 1.0 / s1)
    out = (gain + np.sum(np.log(s0[:, None] / s1), axis=0)).max(axis=-1)
    return out


#: The rival's search: the bias instability of more flicker noise than the base's (deg/h),
#: from the base's own up to three times it.
RIVAL_B_DEG_H = np.linspace(B_DEG_H, 3.0 * B_DEG_H, 200)


def rival_spectra(effect: str) -> np.ndarray:
    """Spectra of the base with more bias instability (:data:`RIVAL_B_DEG_H`), in the effect's
    domain, one column each: the rival reconcile most often names in a faint walk's or
    process' place (``benchmarks/bench_reconcile_naming.py``)."""
    domain = DOMAINS[effect]
    w = domain.w
    flicker = (RIVAL_B_DEG_H / 3600.0) ** 2 / (2.0 * np.sin(w[:, None] / 2.0))
    out: np.ndarray = domain.gain(w)[:, None] * (SIGMA_W_DEG_S**2 + flicker)
    return out


def best_log_likelihood(periodograms: np.ndarray, spectra: np.ndarray) -> np.ndarray:
    """Whittle's log-likelihood of each row of ``periodograms`` under its best column of
    ``spectra``."""
    out: np.ndarray = -(periodograms @ (1.0 / spectra) + np.sum(np.log(spectra), axis=0))
    return out.max(axis=-1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--first", type=int, default=90000, help="first seed (default 90000)")
    parser.add_argument("--seeds", type=int, default=300, help="records per effect")
    parser.add_argument("--clean", type=int, default=1000,
                        help="clean records for each test's threshold (default 1000)")
    parser.add_argument("--ranges", choices=sorted(RANGES), default="faint")
    parser.add_argument("--alpha", type=float, nargs="+", default=[0.01, 0.05])
    args = parser.parse_args()
    start = time.perf_counter()
    clean = np.array([record("none", args.first + 500_000 + i, args.ranges)
                      for i in range(args.clean)])
    print(f"reconcile's ceiling on the naming bench ({args.ranges} ranges; {args.seeds} records "
          f"per effect from seed {args.first}, thresholds from {args.clean} clean records)")
    pooled = {a: 0 for a in args.alpha}
    for effect in ("gauss_markov", "rate_random_walk", "sinusoid"):
        domain = DOMAINS[effect]
        clean_series, clean_pg = domain.series(clean), domain.periodogram(clean)
        spectra = None if effect == "sinusoid" else search_spectra(effect)
        rival = None if spectra is None else rival_spectra(effect)
        untold_null = untold_statistic(effect, clean_pg, spectra)
        hits = {a: 0 for a in args.alpha}
        untold = {a: 0 for a in args.alpha}
        named = {a: 0 for a in args.alpha}
        for i in range(args.seeds):
            seed = args.first + i
            p = parameters(effect, seed, args.ranges)
            rate = record(effect, seed, args.ranges)[None, :]
            null = statistic(effect, p, clean_series, clean_pg)
            series, pg = domain.series(rate), domain.periodogram(rate)
            value = statistic(effect, p, series, pg)[0]
            searched = untold_statistic(effect, pg, spectra)[0]
            for a in args.alpha:
                told = value > np.quantile(null, 1.0 - a)
                found = searched > np.quantile(untold_null, 1.0 - a)
                hits[a] += int(told)
                untold[a] += int(found)
                # a walk or a process is named only where it is found and fits better than
                # the rival, each with its best parameters (no penalty for the process' second
                # one); a sine wherever the told test detects it: both generous to the namer
                named[a] += int(told if rival is None else found and bool(
                    best_log_likelihood(pg, spectra)[0] > best_log_likelihood(pg, rival)[0]))
        for a in args.alpha:
            pooled[a] += named[a]
        for what, counts in (("detected by the test told it", hits),
                             ("detected by the test told only its kind", untold),
                             ("named at most, by likelihood", named)):
            shares = ", ".join(f"alpha {a:g}: {counts[a]}/{args.seeds} "
                               f"({100 * counts[a] / args.seeds:.1f} %)" for a in args.alpha)
            print(f"{effect:<17} {what}: {shares}", flush=True)
    shares = ", ".join(f"alpha {a:g}: {pooled[a]}/{3 * args.seeds} "
                       f"({100 * pooled[a] / (3 * args.seeds):.1f} %)" for a in args.alpha)
    print(f"the three effects, at most named by likelihood: {shares}")
    print(f"# {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
