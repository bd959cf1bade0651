"""Allan variance and averages of records with many short gaps: partial clusters.

A polled unit that loses one to three samples here and there (a few per cent of a record
in thousands of short gaps) leaves no gap-free stretch long enough for the strict rule of
:mod:`analysis.allan.gaps` (no difference straddles a gap) at taus past a minute. Stable32 and
allantools keep such records usable by averaging what is present; the rule here is that
one, stated and bounded:

* an average of ``m`` grid samples (a cluster, a bias-stability average, a DAVAR window's
  cluster) is **kept** when at most :data:`MAX_MISSING_SHARE` of its samples are missing,
  and its value is the mean of its present samples; one with more missing is left out;
* a difference of two averages is kept when both are kept;
* white rate noise makes a mean of ``c < m`` samples noisier than one of ``m``: the
  squared difference of two means of ``c1``, ``c2`` present samples expects
  ``k = m (1/c1 + 1/c2) / 2`` times the white part of the Allan variance. The estimate
  subtracts that excess, ``avar = raw - (N^2 / tau) (mean k - 1)``, with the white level
  ``N^2`` bounded above by the smallest ``avar(tau') tau'`` at shorter taus (every other
  term only adds to it), and never below ``raw / mean k`` (all of it white);
* degrees of freedom are reduced for what is missing: the edf of the unbroken record
  (:func:`analysis.allan.confidence.allan_edf_grid`) times the share of differences kept and
  times the share of samples present in the kept averages (the information a white-noise
  mean loses with its samples), so the intervals widen with the gaps.

Averages never mix samples across more than the threshold, so with the default 10 % a tau
shorter than 10 samples keeps only complete averages (a single missing sample is already
over the share) and equals the strict estimator there.

References
----------
IEEE Std 952-1997, Annex C (cluster averages, eq. C.2); W. J. Riley, *Handbook of
Frequency Stability Analysis*, NIST SP 1065 (2008), on gaps in frequency data (averages of
the available points); C. A. Greenhall and W. J. Riley, Proc. 35th PTTI (2003) for the edf
of the unbroken estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.confidence import ONE_SIGMA, allan_edf_grid, chi2_interval, local_noise_alpha
from analysis.allan.estimators import (
    AllanResult,
    Estimator,
    InputKind,
    TauGrid,
    check_sample_rate,
    resolve_m,
)
from analysis.allan.noise_id import identify_noise
from analysis.errors import NonFiniteSamplesError, TooFewSamplesError

#: Largest share (0..1) of an average's samples that may be missing for it to be kept.
MAX_MISSING_SHARE = 0.10


def _check_share(max_missing_share: float) -> float:
    share = float(max_missing_share)
    if not 0.0 <= share < 1.0:
        raise ValueError(f"max_missing_share must be in [0, 1), got {max_missing_share}")
    return share


def _least_present(m: int, max_missing_share: float) -> int:
    """Fewest present samples an average of ``m`` may hold to be kept (at least 1)."""
    return max(1, int(np.ceil(m * (1.0 - max_missing_share) - 1e-9)))


@dataclass(frozen=True)
class PartialMeans:
    """Consecutive non-overlapping averages of ``m`` grid samples, partial ones kept.

    Attributes
    ----------
    means : ndarray, shape (n_kept,)
        Mean of the present samples of each kept average (input unit, e.g. deg/s).
    present : ndarray of int, shape (n_kept,)
        Present samples in each kept average (``m`` for a complete one).
    m : int
        Samples per average on the time grid.
    n_dropped : int
        Averages left out (more than the threshold missing).
    """

    means: NDArray[np.float64]
    present: NDArray[np.int64]
    m: int
    n_dropped: int

    @property
    def missing_share(self) -> float:
        """Share (0..1) of the kept averages' samples that are missing."""
        return 1.0 - float(self.present.sum()) / (self.m * len(self.present)) if len(
            self.present) else 0.0

    @property
    def white_inflation(self) -> float:
        """Mean of ``m / c``: the factor white noise inflates the averages' variance by."""
        return float(np.mean(self.m / self.present)) if len(self.present) else 1.0


def partial_means(rate: ArrayLike, m: int, *,
                  max_missing_share: float = MAX_MISSING_SHARE) -> PartialMeans:
    """Averages of ``m`` consecutive grid samples of a 1-D record, NaN where missing
    (module docstring: kept when at most ``max_missing_share`` of ``m`` is missing)."""
    x = np.asarray(rate, dtype=np.float64).reshape(-1)
    if m < 1:
        raise ValueError(f"an average needs at least one sample, got m = {m}")
    share = _check_share(max_missing_share)
    count = len(x) // m
    blocks_ = x[: count * m].reshape(count, m)
    valid = np.isfinite(blocks_)
    present = valid.sum(axis=1)
    keep = present >= _least_present(m, share)
    sums = np.where(valid, blocks_, 0.0).sum(axis=1)
    means = sums[keep] / present[keep]
    return PartialMeans(means, present[keep].astype(np.int64), m, int(count - keep.sum()))


def white_level(result: AllanResult) -> float:
    """Upper bound of the white-rate-noise level ``N^2`` (input unit^2 s) of a 1-D Allan
    result: the smallest ``avar(tau) tau`` (every other noise term only adds to it)."""
    product = np.asarray(result.avar, dtype=float).reshape(len(result.tau_s), -1)[:, 0]
    product = product * result.tau_s
    finite = product[np.isfinite(product)]
    return float(finite.min()) if len(finite) else 0.0


def corrected_mean_variance(means: PartialMeans, sample_rate_hz: float,
                            white: float | None) -> float:
    """Sample variance (ddof 1) of partial averages less the excess white noise of their
    missing samples, ``N^2 fs mean(1/c - 1/m)``; never below ``raw / mean(m/c)``."""
    raw = float(np.var(means.means, ddof=1))
    if white is None or means.white_inflation <= 1.0:
        return raw
    excess = white * sample_rate_hz * float(np.mean(1.0 / means.present - 1.0 / means.m))
    return max(raw - excess, raw / means.white_inflation)


@dataclass(frozen=True)
class _Differences:
    """Per m and axis: raw Allan variance, mean white inflation, kept and possible counts."""

    raw: NDArray[np.float64]
    inflation: NDArray[np.float64]
    kept: NDArray[np.int64]
    possible: NDArray[np.int64]
    clusters: NDArray[np.int64]
    present_share: NDArray[np.float64]


def _differences(sums: NDArray[np.float64], counts: NDArray[np.int64], ms: NDArray[np.int64],
                 fs: float, share: float, overlapping: bool) -> _Differences:
    """Squared differences of adjacent partial means for every m (module docstring);
    ``sums``/``counts`` are cumulative sums of the centred present samples and of presence."""
    n = len(counts) - 1
    k = sums.shape[1]
    raw = np.full((len(ms), k), np.nan)
    inflation = np.ones(len(ms))
    kept = np.zeros(len(ms), dtype=np.int64)
    possible = np.zeros(len(ms), dtype=np.int64)
    clusters = np.zeros(len(ms), dtype=np.int64)
    present_share = np.ones(len(ms))
    for i, m in enumerate(int(v) for v in ms):
        stride = 1 if overlapping else m
        starts = np.arange(0, n - m + 1, stride)
        c = counts[starts + m] - counts[starts]
        ok = c >= _least_present(m, share)
        mean = (sums[starts + m] - sums[starts]) / np.maximum(c, 1)[:, None]
        lag = m // stride
        both = ok[lag:] & ok[:-lag]
        possible[i] = len(both)
        kept[i] = int(both.sum())
        clusters[i] = int(ok[::m // stride].sum())
        if not kept[i]:
            continue
        d = (mean[lag:] - mean[:-lag])[both]
        raw[i] = np.sum(d * d, axis=0) / (2.0 * kept[i])
        c1, c2 = c[:-lag][both], c[lag:][both]
        inflation[i] = float(np.mean(m * (1.0 / c1 + 1.0 / c2) / 2.0))
        present_share[i] = float(np.mean((c1 + c2) / (2.0 * m)))
    return _Differences(raw, inflation, kept, possible, clusters, present_share)


def _white_corrected(raw: NDArray[np.float64], inflation: NDArray[np.float64],
                     tau: NDArray[np.float64]) -> NDArray[np.float64]:
    """The raw values less their white excess, taus in increasing order (module docstring)."""
    out = raw.copy()
    level = np.full(raw.shape[1], np.inf)
    for i in np.argsort(tau):
        if not np.isfinite(raw[i]).all():
            continue
        excess = np.full_like(level, np.inf)
        known = np.isfinite(level)
        excess[known] = level[known] / tau[i] * (inflation[i] - 1.0)
        out[i] = np.maximum(raw[i] - excess, raw[i] / inflation[i])
        level = np.minimum(level, out[i] * tau[i])
    return out


def _grid_rate(samples: ArrayLike, fs: float, input_kind: InputKind) -> NDArray[np.float64]:
    arr = np.asarray(samples, dtype=np.float64)
    arr = arr[:, None] if arr.ndim == 1 else arr
    if arr.ndim != 2:
        raise ValueError(f"samples must be 1-D (N) or 2-D (N x axes), got shape {arr.shape}")
    if np.isinf(arr).any():
        raise NonFiniteSamplesError("a sample is infinite; only NaN marks a missing sample")
    if input_kind == "angle_increment":
        arr = arr * fs
    elif input_kind != "rate":
        raise ValueError(f"input_kind must be 'rate' or 'angle_increment', got {input_kind!r}")
    return arr


def _noise_alpha(increments: NDArray[np.float64], m: NDArray[np.int64],
                 avar: NDArray[np.float64]) -> NDArray[np.int64]:
    """Noise type per tau as Stable32 finds it, on the angle of the present samples (a few
    per cent of short gaps barely touch it); by the local slope where that angle is too
    short for an m."""
    theta = np.concatenate((np.zeros((1, increments.shape[1])), np.cumsum(increments, axis=0)))
    alpha = local_noise_alpha(m, avar, len(increments))
    fits = 2 * m <= len(increments)
    if fits.any():
        alpha[fits] = identify_noise(theta, m[fits]).alpha
    return alpha


def partial_allan_variance(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    estimator: Estimator = "overlapping",
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
    max_missing_share: float = MAX_MISSING_SHARE,
) -> AllanResult:
    """Allan variance of a record with short gaps, partial clusters kept (module docstring).

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate (e.g. deg/s) on the record's true time grid, NaN where a sample is missing
        (every axis missing the same samples); angle increments per sample with
        ``input_kind="angle_increment"``.
    sample_rate_hz : float
        Sample rate in Hz; ``tau = m / sample_rate_hz`` is true time.
    estimator : {"overlapping", "clusters"}
        Averages starting at every sample, or consecutive clusters (IEEE 952 eq. C.2).
    taus : {"log", "octave", "all"} or array_like
        Tau grid of the record's span; a tau with no kept difference is left out of a
        named grid and refused when given explicitly.
    input_kind : {"rate", "angle_increment"}
        What the samples are.
    confidence : float
        Two-sided level of the chi-square interval.
    max_missing_share : float
        Largest missing share of a kept average, 0 .. <1 (0: the strict rule).

    Returns
    -------
    AllanResult
        ``n_terms``: differences kept; ``n_clusters``: kept non-overlapping clusters;
        ``n_samples``: present samples; ``edf`` reduced for what is missing. Without a
        missing sample the values equal :func:`analysis.allan.allan_variance`'s to rounding.

    Raises
    ------
    NonFiniteSamplesError
        An infinite sample (only NaN marks a missing one).
    ValueError
        The axes miss different samples, an unknown estimator, or a share out of range.
    TooFewSamplesError
        No tau keeps a difference (or an explicit one keeps none).
    """
    fs = check_sample_rate(sample_rate_hz)
    share = _check_share(max_missing_share)
    if estimator not in ("overlapping", "clusters"):
        raise ValueError(f"estimator must be 'overlapping' or 'clusters', got {estimator!r}")
    arr = _grid_rate(samples, fs, input_kind)
    finite = np.isfinite(arr)
    valid = finite[:, 0]
    if not (finite == valid[:, None]).all():
        raise ValueError("the axes are missing different samples; analyze them one at a time")
    n_present = int(valid.sum())
    if n_present < 2:
        raise TooFewSamplesError(f"{n_present} present samples are too few for an Allan variance")
    centred = np.where(valid[:, None], arr - arr[valid].mean(axis=0), 0.0)
    sums = np.concatenate((np.zeros((1, arr.shape[1])), np.cumsum(centred, axis=0)))
    counts = np.concatenate(([0], np.cumsum(valid))).astype(np.int64)
    m = resolve_m(taus, arr.shape[0], fs)
    d = _differences(sums, counts, m, fs, share, estimator == "overlapping")
    usable = d.kept > 0
    if not usable.all() and not isinstance(taus, str):
        raise TooFewSamplesError(f"tau {m[~usable][0] / fs} s keeps no difference: more than "
                                 f"{share:.0%} of its averages' samples are missing")
    if not usable.any():
        raise TooFewSamplesError(f"no tau keeps a difference with at most {share:.0%} missing")
    m = m[usable]
    tau = m / fs
    avar = _white_corrected(d.raw[usable], d.inflation[usable], tau)
    alpha = _noise_alpha(centred[valid] / fs, m, avar)
    full = allan_edf_grid(arr.shape[0], m, alpha, overlapping=estimator == "overlapping")
    factor = (d.kept / d.possible * d.present_share)[usable]
    edf = np.clip(full * factor[:, None], 1.0, np.maximum(d.kept[usable], 1)[:, None])
    low, high = chi2_interval(avar, edf, confidence)
    if np.ndim(samples) == 1:
        avar, edf, low, high, alpha = avar[:, 0], edf[:, 0], low[:, 0], high[:, 0], alpha[:, 0]
    return AllanResult(tau_s=tau, m=m, avar=avar, n_clusters=d.clusters[usable],
                       n_terms=d.kept[usable], edf=edf, ci_low=low, ci_high=high,
                       confidence=confidence, estimator=estimator, sample_rate_hz=fs,
                       n_samples=n_present, noise_alpha=alpha)


def window_avar(rate: ArrayLike, sample_rate_hz: float, m: NDArray[np.int64], *,
                max_missing_share: float = MAX_MISSING_SHARE) -> tuple[NDArray[np.float64], float]:
    """Overlapping Allan variance at each ``m`` of one DAVAR window of a 1-D rate record
    (NaN where missing, partial clusters kept; NaN at an m that keeps no difference), and
    the share of the window's samples present (the factor its edf is reduced by)."""
    x = np.asarray(rate, dtype=np.float64).reshape(-1, 1)
    valid = np.isfinite(x[:, 0])
    if valid.sum() < 2:
        return np.full(len(m), np.nan), 0.0
    centred = np.where(valid[:, None], x - x[valid].mean(), 0.0)
    sums = np.concatenate((np.zeros((1, 1)), np.cumsum(centred, axis=0)))
    counts = np.concatenate(([0], np.cumsum(valid))).astype(np.int64)
    fs = check_sample_rate(sample_rate_hz)
    d = _differences(sums, counts, np.asarray(m, dtype=np.int64), fs,
                     _check_share(max_missing_share), True)
    return _white_corrected(d.raw, d.inflation, m / fs)[:, 0], float(valid.mean())


def partial_window_sums(rate: ArrayLike, sample_rate_hz: float, m: NDArray[np.int64], *,
                       max_missing_share: float = MAX_MISSING_SHARE
                       ) -> tuple[NDArray[np.float64], float]:
    """One DAVAR window of a 1-D rate record (NaN where missing) as the sums of squared
    angle second differences the DAVAR keeps per tau (``2 tau^2 (Nw + 1 - 2m)`` times its
    Allan variance, :func:`window_avar`), NaN when more than ``max_missing_share`` of the
    window is missing; and the share of its samples present (the factor its edf is
    reduced by)."""
    x = np.asarray(rate, dtype=np.float64).reshape(-1)
    present = float(np.isfinite(x).mean())
    if 1.0 - present > max_missing_share:
        return np.full(len(m), np.nan), present
    avar, _ = window_avar(x, sample_rate_hz, m, max_missing_share=max_missing_share)
    tau = m / sample_rate_hz
    return avar * 2.0 * tau**2 * (len(x) + 1 - 2 * m), present


def partial_windows(seg: NDArray[np.float64], local: NDArray[np.int64], window: int,
                    m: NDArray[np.int64], sample_rate_hz: float, sums: NDArray[np.float64], *,
                    max_missing_share: float = MAX_MISSING_SHARE) -> NDArray[np.float64]:
    """The windows of ``seg`` (rate, NaN where missing) starting at ``local`` that miss a
    sample, as :func:`partial_window_sums`, in place in ``sums`` (windows, taus, axes).
    Returns the share of each window's samples present (windows, axes)."""
    lost = np.isnan(seg)
    held = np.concatenate((np.zeros((1, seg.shape[1]), dtype=np.int64),
                           np.cumsum(lost, axis=0)))
    missing = held[local + window] - held[local]  # (windows, axes)
    for w, c in zip(*np.nonzero(missing), strict=True):
        sums[w, :, c], _ = partial_window_sums(seg[local[w]: local[w] + window, c],
                                               sample_rate_hz, m,
                                               max_missing_share=max_missing_share)
    return np.asarray(1.0 - missing / window, dtype=np.float64)
