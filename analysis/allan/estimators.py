"""Allan variance of gyro rate records: estimators, tau grids and confidence intervals.

Two estimators are provided, both for one axis (``N``) or several (``N x k``):

* :func:`cluster_allan_variance`, the non-overlapping cluster form (Lv et al. 2015,
  eq. 1-2), with the number of clusters ``J = floor(N / m)`` that the weighted fit needs;
* :func:`overlapping_allan_variance`, the fully overlapping form written on the
  cumulative angle (Zhang et al. 2015, eq. 5), O(N) per tau.

Both work on the cumulative angle ``theta`` (one leading zero, ``N + 1`` points), so a
cluster sum or a second difference is a difference of ``theta`` values and the all-m
grid of the cluster form costs O(N log N) in total.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

import analysis.allan.blocks as blocks
import analysis.allan.kernels as kernels
import analysis.allan.long_sums as long_sums
from analysis.allan.confidence import (  # re-exported: part of this module's API
    ONE_SIGMA as ONE_SIGMA,
    allan_edf_grid as allan_edf_grid,
    chi2_interval as chi2_interval,
    estimator_terms as estimator_terms,
    local_noise_alpha as local_noise_alpha,
    overlapping_edf as overlapping_edf,
)
from analysis.allan.kinds import Estimator as Estimator
from analysis.allan.noise_id import identify_noise
from analysis.errors import (
    InvalidSampleRateError,
    InvalidTauError,
    NonFiniteSamplesError,
    TooFewSamplesError,
)

InputKind = Literal["rate", "angle_increment"]
TauGrid = Literal["log", "octave", "all"]
Missing = Literal["raise", "gap"]


class AllanDeviationMixin:
    """Allan deviation views of a result holding ``avar``, ``ci_low`` and ``ci_high``."""

    avar: NDArray[np.float64]
    ci_low: NDArray[np.float64]
    ci_high: NDArray[np.float64]

    @property
    def adev(self) -> NDArray[np.float64]:
        """Allan deviation, in the input unit (e.g. deg/s)."""
        return np.sqrt(self.avar)

    @property
    def adev_ci_low(self) -> NDArray[np.float64]:
        """Lower confidence bound of the Allan deviation (input unit)."""
        return np.sqrt(self.ci_low)

    @property
    def adev_ci_high(self) -> NDArray[np.float64]:
        """Upper confidence bound of the Allan deviation (input unit)."""
        return np.sqrt(self.ci_high)


@dataclass(frozen=True)
class AllanResult(AllanDeviationMixin):
    """Allan variance at a set of averaging times.

    Attributes
    ----------
    tau_s : ndarray, shape (n_tau,)
        Averaging times in seconds, ``tau = m / sample_rate_hz``.
    m : ndarray of int, shape (n_tau,)
        Averaging factors (samples per cluster).
    avar : ndarray, shape (n_tau,) or (n_tau, k)
        Allan variance in (input unit)^2, e.g. (deg/s)^2. One column per axis when the
        input had several axes.
    n_clusters : ndarray of int, shape (n_tau,)
        Number of whole clusters ``J = floor(N / m)`` (Lv 2015, section 2.2).
    n_terms : ndarray of int, shape (n_tau,)
        Number of squared differences summed: ``J - 1`` for the cluster estimator,
        ``N + 1 - 2m`` for the overlapping one.
    edf : ndarray, same shape as ``avar``
        Equivalent degrees of freedom behind the confidence interval.
    ci_low, ci_high : ndarray, same shape as ``avar``
        Chi-square confidence interval of the Allan variance at level ``confidence``.
    confidence : float
        Two-sided confidence level of ``ci_low``/``ci_high`` (0.683 is +-1 sigma).
    estimator : str
        ``"clusters"`` or ``"overlapping"``.
    sample_rate_hz : float
        Sample rate of the input record in Hz.
    n_samples : int
        Number of samples per axis in the input record.
    noise_alpha : ndarray of int, same shape as ``avar``
        Dominant noise type behind each interval, as the rate-noise exponent (2 white
        angle, 1 flicker angle, 0 white rate, -1 flicker rate, -2 rate random walk), from
        :func:`analysis.allan.noise_id.identify_noise`.
    """

    tau_s: NDArray[np.float64]
    m: NDArray[np.int64]
    avar: NDArray[np.float64]
    n_clusters: NDArray[np.int64]
    n_terms: NDArray[np.int64]
    edf: NDArray[np.float64]
    ci_low: NDArray[np.float64]
    ci_high: NDArray[np.float64]
    confidence: float
    estimator: str
    sample_rate_hz: float
    n_samples: int
    noise_alpha: NDArray[np.int64]

    @property
    def relative_error(self) -> NDArray[np.float64]:
        """1-sigma relative error of the root Allan variance, ``1/sqrt(2(J-1))``.

        Lv et al. 2015, eq. 8 (as a fraction, not per cent); ``inf`` where ``J < 2``.
        """
        j = self.n_clusters.astype(float)
        with np.errstate(divide="ignore"):
            return np.where(j > 1, 1.0 / np.sqrt(2.0 * np.maximum(j - 1.0, 1e-300)), np.inf)

    def axis(self, index: int) -> AllanResult:
        """The result of one axis of a multi-axis result (a 1-D result for ``index``)."""
        if self.avar.ndim == 1:
            if index != 0:
                raise IndexError(f"a single-axis result has no axis {index}")
            return self
        return AllanResult(
            tau_s=self.tau_s,
            m=self.m,
            avar=self.avar[:, index],
            n_clusters=self.n_clusters,
            n_terms=self.n_terms,
            edf=self.edf[:, index],
            ci_low=self.ci_low[:, index],
            ci_high=self.ci_high[:, index],
            confidence=self.confidence,
            estimator=self.estimator,
            sample_rate_hz=self.sample_rate_hz,
            n_samples=self.n_samples,
            noise_alpha=self.noise_alpha[:, index],
        )


# --------------------------------------------------------------------------- input checks


def check_sample_rate(sample_rate_hz: float) -> float:
    """Return ``sample_rate_hz`` as a float, or raise :class:`InvalidSampleRateError`."""
    try:
        fs = float(sample_rate_hz)
    except (TypeError, ValueError) as exc:
        raise InvalidSampleRateError(f"sample rate {sample_rate_hz!r} is not a number") from exc
    if not np.isfinite(fs) or fs <= 0:
        raise InvalidSampleRateError(
            f"sample rate must be a finite positive number of Hz, got {sample_rate_hz!r}"
        )
    return fs


def _non_finite_error(arr: NDArray[np.float64], offset: int = 0) -> NonFiniteSamplesError:
    finite = np.isfinite(arr)
    rows, cols = np.nonzero(~finite)
    where = ", ".join(f"sample {offset + r} axis {c} ({arr[r, c]})"
                      for r, c in zip(rows[:5], cols[:5], strict=True))
    more = f" and {len(rows) - 5} more" if len(rows) > 5 else ""
    return NonFiniteSamplesError(
        f"{len(rows)} non-finite sample(s): {where}{more}; remove or interpolate them first"
    )


def as_samples(samples: ArrayLike) -> NDArray[np.float64]:
    """Return samples as a 2-D float64 array (N x k), refusing NaN and inf with their position.

    A long float64 array (:func:`analysis.allan.blocks.is_long`, e.g. a memmap) is checked a
    block at a time and returned as a view, not copied.

    Raises
    ------
    NonFiniteSamplesError
        If any sample is NaN or infinite; the message names the first few sample indices.
    ValueError
        If the array has more than two dimensions.
    """
    arr = np.asarray(samples, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ValueError(f"samples must be 1-D (N) or 2-D (N x axes), got shape {arr.shape}")
    if blocks.is_long(arr.shape[0]):
        first = blocks.first_non_finite(arr)
        if first >= 0:
            raise _non_finite_error(np.asarray(arr[first: first + blocks.BLOCK_SAMPLES]), first)
        return arr
    if not np.isfinite(arr).all():
        raise _non_finite_error(arr)
    return arr


def cumulative_angle(
    samples: ArrayLike, sample_rate_hz: float, *, input_kind: InputKind = "rate",
    out: NDArray[np.float64] | None = None, backend: kernels.Backend = "numpy",
) -> NDArray[np.float64]:
    """Cumulative angle ``theta`` (N + 1 x k, leading zero) of a rate or angle-increment record.

    The record's mean is removed first: a constant rate adds a straight line to ``theta``,
    which every Allan difference cancels, and leaving it in costs float64 precision.

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate in (unit)/s, or angle increments in (unit) per sample when
        ``input_kind="angle_increment"``. A long record (a memmap) is read a block at a
        time (:mod:`analysis.allan.blocks`).
    sample_rate_hz : float
        Sample rate in Hz.
    input_kind : {"rate", "angle_increment"}
        What the samples are.
    out : ndarray, shape (N + 1, k), optional
        Where to write the angle (e.g. a memmap, for a record too long for memory).
    backend : {"numpy", "numba", "auto"}
        ``"numba"`` (or ``"auto"``, numba where installed) takes the running sum of an
        in-memory record in one compiled pass instead of numpy's subtract, divide and
        cumsum (the same angle, bit for bit); the overlapping Allan variance asks for it
        where its sums run compiled. A memory-mapped record or ``out`` keeps the
        block-wise numpy path.

    Returns
    -------
    ndarray, shape (N + 1, k)
        Angle in (unit) of the mean-free record, ``theta[0] = 0`` (``out`` when given).
    """
    fs = check_sample_rate(sample_rate_hz)
    if input_kind not in ("rate", "angle_increment"):
        raise ValueError(f"input_kind must be 'rate' or 'angle_increment', got {input_kind!r}")
    divisor = fs if input_kind == "rate" else 1.0
    compiled = None if backend == "numpy" else kernels.compiled_kernels(backend)
    if compiled is not None:
        theta_compiled = _compiled_angle(samples, divisor, out, compiled)
        if theta_compiled is not None:
            return theta_compiled
    arr = as_samples(samples)
    n, k = arr.shape
    theta = np.empty((n + 1, k)) if out is None else out
    if theta.shape != (n + 1, k):
        raise ValueError(f"out must have shape {(n + 1, k)}, got {theta.shape}")
    theta[0] = 0.0
    if not blocks.is_long(n):
        increments = arr - arr.mean(axis=0)
        if input_kind == "rate":
            increments /= fs
        np.cumsum(increments, axis=0, out=theta[1:])
        return theta
    mean = blocks.column_sums(arr) / n
    carry = np.zeros(k)
    for a, b in blocks.spans(0, n):
        increments = np.asarray(arr[a:b]) - mean
        if input_kind == "rate":
            increments /= fs
        increments[0] += carry  # one running sum, as np.cumsum over the whole record
        np.cumsum(increments, axis=0, out=increments)
        theta[a + 1: b + 1] = increments
        carry = increments[-1].copy()
        blocks.release(arr)
        blocks.release(theta)
    return theta


def _compiled_angle(samples: ArrayLike, divisor: float, out: NDArray[np.float64] | None,
                    compiled: ModuleType) -> NDArray[np.float64] | None:
    """:func:`cumulative_angle` of an in-memory record in one compiled pass, or None where
    the numpy path must take it (a memory map, a shape or a sample it refuses)."""
    arr = np.asarray(samples, dtype=np.float64)
    arr = arr[:, None] if arr.ndim == 1 else arr
    if (arr.ndim != 2 or arr.shape[0] == 0 or blocks.is_mapped(arr)
            or (out is not None and (blocks.is_mapped(out) or out.shape != (arr.shape[0] + 1,
                                                                           arr.shape[1])))):
        return None
    n = arr.shape[0]
    # the mean of the numpy path (its pairwise mean, or block sums for a long record)
    mean = np.atleast_1d(blocks.column_sums(arr) / n if blocks.is_long(n) else arr.mean(axis=0))
    if not np.isfinite(mean).all():
        return None  # a NaN or an infinity: as_samples names it (or the sum overflowed)
    theta = np.empty((n + 1, arr.shape[1])) if out is None else out
    kernels.running_angle(arr, mean, divisor, theta, compiled)
    return theta


# ------------------------------------------------------------------------------ tau grids


def all_m(n_samples: int) -> NDArray[np.int64]:
    """Every averaging factor ``m = 1 .. floor(N/2)`` (Lv 2015, section 2.2, step 1)."""
    return np.arange(1, n_samples // 2 + 1, dtype=np.int64)


def octave_m(n_samples: int, *, min_clusters: int = 2) -> NDArray[np.int64]:
    """Averaging factors ``m = 1, 2, 4, ...`` with at least ``min_clusters`` clusters."""
    m_max = n_samples // min_clusters
    if m_max < 1:
        return np.zeros(0, dtype=np.int64)
    return 2 ** np.arange(int(np.log2(m_max)) + 1, dtype=np.int64)


def log_m(
    n_samples: int,
    *,
    ratio: float | None = None,
    n_points: int = 100,
    min_clusters: int = 9,
    max_m: int | None = None,
) -> NDArray[np.int64]:
    """Log-spaced averaging factors, ``m_i = round(ratio**(i-1))`` (Zhang 2015, eq. 20).

    The largest ``m`` keeps at least ``min_clusters`` clusters (eq. 20 takes 9, a 25 %
    error by eq. 4). When ``ratio`` (the paper's tau_g) is not given it is chosen so that
    ``n_points`` values span ``1 .. N/min_clusters`` before rounding; repeated ``m`` after
    rounding are removed, so fewer points may come back. With ``max_m``, the grid goes on
    at the same spacing up to ``max_m`` (:func:`analysis_log_m` reaches two clusters so).
    """
    m_max = n_samples // min_clusters
    top = m_max if max_m is None else int(max_m)
    if m_max < 1 and top < 1:
        return np.zeros(0, dtype=np.int64)
    if ratio is None:
        if n_points < 2 or m_max <= 1:
            ratio = 2.0 ** (1.0 / 8.0) if top > 1 else 2.0
        else:
            ratio = m_max ** (1.0 / (n_points - 1))
    if not ratio > 1.0:
        raise ValueError(f"tau ratio must be > 1, got {ratio}")
    count = int(np.floor(np.log(max(top, 1)) / np.log(ratio) + 1e-9)) + 1
    m = np.unique(np.rint(ratio ** np.arange(count)).astype(np.int64))
    m = m[(m >= 1) & (m <= top)]
    if max_m is not None and m.size and m[-1] < top:
        # the longest tau the estimator allows is always on the grid
        m = np.append(m if top > m[-1] * np.sqrt(ratio) else m[:-1], top)
    return m


#: Clusters the analysis' log grid keeps at its longest tau (Stable32 goes as far).
LOG_GRID_MIN_CLUSTERS = 2


def analysis_log_m(n_samples: int, *, max_m: int | None = None) -> NDArray[np.int64]:
    """The log grid of a whole-record analysis (``station analyze``): eq. 20's spacing (100
    points up to ``N/9``), continued to the longest tau with :data:`LOG_GRID_MIN_CLUSTERS`
    clusters, ``N/2`` (or to ``max_m``), as Stable32 goes. The values past ``N/9`` carry
    wide intervals. The named ``"log"`` grid stays eq. 20's: a DAVAR window (a reproduction
    of Zhang 2015, where each window's curve feeds a warm-up test) keeps its nine clusters.
    """
    top = n_samples // LOG_GRID_MIN_CLUSTERS if max_m is None else max_m
    return log_m(n_samples, max_m=top)


def m_from_tau(tau_s: ArrayLike, sample_rate_hz: float, *, rtol: float = 1e-6) -> NDArray[np.int64]:
    """Averaging factors of explicit averaging times, checked to be multiples of 1/fs.

    Raises
    ------
    InvalidTauError
        If a tau is not positive or not a multiple of the sample period.
    """
    fs = check_sample_rate(sample_rate_hz)
    taus = np.atleast_1d(np.asarray(tau_s, dtype=np.float64))
    exact = taus * fs
    m = np.rint(exact).astype(np.int64)
    bad = (m < 1) | (np.abs(exact - m) > rtol * np.maximum(1.0, np.abs(exact)))
    if bad.any():
        tau = taus[np.argmax(bad)]
        raise InvalidTauError(
            f"tau {tau} s is not a positive multiple of the sample period {1 / fs} s "
            f"({fs} Hz); pick tau = m / {fs} for a whole m"
        )
    return np.unique(m)


def resolve_m(
    taus: TauGrid | ArrayLike, n_samples: int, sample_rate_hz: float
) -> NDArray[np.int64]:
    """Averaging factors of a named grid (``"log"``, ``"octave"``, ``"all"``) or explicit taus (s).

    ``"log"`` is Zhang 2015 eq. 20's :func:`log_m` (to nine clusters); a whole-record
    analysis asks for :func:`analysis_log_m` (to two) by passing its taus.

    Raises
    ------
    TooFewSamplesError
        If the record is too short for any requested tau (it needs ``2 m`` samples).
    """
    if isinstance(taus, str):
        grids = {"log": log_m, "octave": octave_m, "all": all_m}
        if taus not in grids:
            raise ValueError(f"tau grid must be one of {sorted(grids)} or an array of taus in s")
        m = grids[taus](n_samples)
        if m.size == 0:
            raise TooFewSamplesError(
                f"{n_samples} samples are too few for the {taus!r} tau grid; record longer"
            )
        return m
    m = m_from_tau(taus, sample_rate_hz)
    too_long = m > n_samples // 2
    if too_long.any():
        raise TooFewSamplesError(
            f"tau {m[too_long][0] / sample_rate_hz} s needs at least {2 * m[too_long][0]} "
            f"samples, the record has {n_samples}"
        )
    return m


# --------------------------------------------------------------------------------- kernels


def overlapping_sums(
    theta: NDArray[np.float64], m_values: NDArray[np.int64]
) -> NDArray[np.float64]:
    """Sum of squared second differences ``theta[n+2m] - 2 theta[n+m] + theta[n]`` per m.

    ``theta`` is (N + 1) x k; the sum runs over the ``N + 1 - 2m`` available ``n``.
    Returns an (n_m, k) array. One streaming pass over ``theta`` per m: the compiled
    kernel of :mod:`analysis.allan.kernels` when numba is installed, else cache-blocked numpy.
    """
    return kernels.overlapping_sums(theta, m_values)


def cluster_sums(theta: NDArray[np.float64], m_values: NDArray[np.int64]) -> NDArray[np.float64]:
    """Sum of squared differences of adjacent cluster angles (tau x cluster mean; eq. 2) per m.

    ``theta`` is (N + 1) x k. The clusters of size m are read off ``theta`` at multiples
    of m, and m values are handled in blocks ``[a, 2a)`` gathered at once, so the work of
    a block is O(N) and the whole all-m grid is O(N log N).
    """
    n = theta.shape[0] - 1
    if blocks.is_mapped(theta) and blocks.is_long(n):
        return long_sums.cluster_square_sums(theta, np.asarray(m_values, dtype=np.int64))
    order = np.argsort(m_values)
    ms_sorted = np.asarray(m_values, dtype=np.int64)[order]
    out = np.empty((len(ms_sorted), theta.shape[1]))
    start = 0
    while start < len(ms_sorted):
        a = ms_sorted[start]
        stop = int(np.searchsorted(ms_sorted, 2 * a, side="left"))
        block = ms_sorted[start:stop]
        j = n // block
        j_max = int(j.max())
        k = np.arange(j_max + 1)
        idx = np.minimum(block[:, None] * k[None, :], n)
        cluster_angles = np.diff(theta[idx], axis=1)
        d = np.diff(cluster_angles, axis=1)
        valid = k[None, : j_max - 1] < (j - 1)[:, None]
        out[start:stop] = np.einsum("bjk,bjk,bj->bk", d, d, valid.astype(float))
        start = stop
    result = np.empty_like(out)
    result[order] = out
    return result


# ---------------------------------------------------------------------------- estimators


def _finish(
    sums: NDArray[np.float64],
    m: NDArray[np.int64],
    theta: NDArray[np.float64],
    *,
    estimator: str,
    fs: float,
    squeeze: bool,
    confidence: float,
) -> AllanResult:
    n = theta.shape[0] - 1
    overlapping = estimator == "overlapping"
    n_terms = estimator_terms(n, m, overlapping=overlapping)
    avar = sums / (2.0 * (m[:, None].astype(float) / fs) ** 2 * n_terms[:, None])
    alpha = identify_noise(theta, m).alpha
    edf = allan_edf_grid(n, m, alpha, overlapping=overlapping)
    low, high = chi2_interval(avar, edf, confidence)
    if squeeze:
        avar, edf, low, high, alpha = avar[:, 0], edf[:, 0], low[:, 0], high[:, 0], alpha[:, 0]
    return AllanResult(
        tau_s=m / fs,
        m=m,
        avar=avar,
        n_clusters=(n // m).astype(np.int64),
        n_terms=n_terms.astype(np.int64),
        edf=edf,
        ci_low=low,
        ci_high=high,
        confidence=confidence,
        estimator=estimator,
        sample_rate_hz=fs,
        n_samples=n,
        noise_alpha=alpha,
    )


def overlapping_allan_variance(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
    angle_out: NDArray[np.float64] | None = None,
) -> AllanResult:
    """Fully overlapping Allan variance from the cumulative angle.

    ``avar(m) = sum_n (theta[n+2m] - 2 theta[n+m] + theta[n])^2 / (2 tau^2 (N + 1 - 2m))``
    with ``tau = m / fs`` (Zhang et al. 2015, eq. 5; the phase convention of a leading
    zero angle, ``N + 1`` points, is that of IEEE Std 1139 and allantools' ``oadev``).

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate samples (e.g. deg/s), or angle increments per sample with
        ``input_kind="angle_increment"`` (the result is then in the same rate unit
        per second, e.g. deg -> (deg/s)^2).
    sample_rate_hz : float
        Sample rate in Hz.
    taus : {"log", "octave", "all"} or array_like
        Tau grid: log-spaced (eq. 20), octaves, every m, or explicit taus in seconds
        (``analysis_log_m(N) / fs`` for the grid that reaches two clusters).
    input_kind : {"rate", "angle_increment"}
        What the samples are.
    confidence : float
        Two-sided level of the chi-square interval (default +-1 sigma). The edf is
        computed (:mod:`analysis.allan.confidence`) for the noise type identified at each tau
        (:mod:`analysis.allan.noise_id`).
    angle_out : ndarray, shape (N + 1, k), optional
        Where to keep the cumulative angle: a memmap for a record too long for memory
        (a long record is read a block at a time throughout, :mod:`analysis.allan.blocks`).

    Returns
    -------
    AllanResult

    Raises
    ------
    NonFiniteSamplesError, TooFewSamplesError, InvalidSampleRateError, InvalidTauError

    References
    ----------
    IEEE Std 952-1997, Annex C; Zhang et al., Acta Optica Sinica 35(4), 2015, eq. 5.
    """
    fs = check_sample_rate(sample_rate_hz)
    shape = np.shape(samples)
    if len(shape) in (1, 2) and shape[0] > 0:
        # the grid first, so that the angle's running sum runs compiled where the sums will
        m = resolve_m(taus, shape[0], fs)
        compiled = kernels.overlapping_backend(shape[0] + 1, m, 1 if len(shape) == 1 else shape[1])
        backend: kernels.Backend = "numpy" if compiled is None else "numba"
        theta = cumulative_angle(samples, fs, input_kind=input_kind, out=angle_out,
                                 backend=backend)
    else:
        theta = cumulative_angle(samples, fs, input_kind=input_kind, out=angle_out)
        m = resolve_m(taus, theta.shape[0] - 1, fs)
    sums = overlapping_sums(theta, m)
    return _finish(sums, m, theta, estimator="overlapping", fs=fs, squeeze=np.ndim(samples) == 1,
                   confidence=confidence)


def cluster_allan_variance(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    taus: TauGrid | ArrayLike = "all",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
    angle_out: NDArray[np.float64] | None = None,
) -> AllanResult:
    """Non-overlapping (cluster) Allan variance, Lv et al. 2015, eq. 1-2.

    The N samples are cut into ``J = floor(N/m)`` clusters of m samples; the variance is
    ``sum_k (mean_{k+1} - mean_k)^2 / (2 (J - 1))``. The confidence interval's edf is
    computed (:mod:`analysis.allan.confidence`) for the noise type identified at each tau
    (:mod:`analysis.allan.noise_id`); eq. 8's
    ``1/sqrt(2(J-1))`` (``relative_error``) assumes ``J - 1`` independent differences,
    which adjacent cluster differences are not (white rate noise: edf about 2(J-1)/3).

    Parameters and raised errors are those of :func:`overlapping_allan_variance` (with
    ``angle_out`` a long record's angle is kept there and read a block at a time); the
    default grid is every m (``"all"``), as in the paper.
    """
    fs = check_sample_rate(sample_rate_hz)
    theta = cumulative_angle(samples, fs, input_kind=input_kind, out=angle_out)
    n = theta.shape[0] - 1
    m = resolve_m(taus, n, fs)
    sums = cluster_sums(theta, m)
    return _finish(sums, m, theta, estimator="clusters", fs=fs, squeeze=np.ndim(samples) == 1,
                   confidence=confidence)
