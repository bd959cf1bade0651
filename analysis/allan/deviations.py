"""The Allan family beside the Allan variance: modified, Hadamard, time, total and Theo1.

Every estimator here works, like :mod:`analysis.allan`, on the cumulative angle ``theta``
of a rate record (``N`` rate samples, ``N + 1`` angle points, mean rate removed): a gyro's
angle is the "phase" and its rate the "frequency" of frequency-stability work, so each
variance is in (rate unit)^2, e.g. (deg/s)^2, except the time variance, in (angle unit)^2.
With ``tau = m / fs`` (NIST SP 1065 numbering):

* ``mdev``, modified Allan (eq. 14): the second difference of angles averaged over m,
  ``sum_j (sum_{i=j}^{j+m-1} theta_{i+2m} - 2 theta_{i+m} + theta_i)^2 / (2 m^2 tau^2 (N + 2 -
  3m))``;
* ``tdev``, time (eq. 15): ``tau^2 / 3`` times the modified Allan variance, an angle;
* ``hdev``, ``ohdev``, Hadamard and overlapping Hadamard (eq. 18, 20): the third
  difference ``theta_{n+3m} - 3 theta_{n+2m} + 3 theta_{n+m} - theta_n``, squared over
  ``6 tau^2``, at every m-th n or every n; blind to a rate ramp;
* ``totdev``, total (eq. 25): the overlapping Allan sum over the ``N - 1`` interior
  centres of the angle extended by reflection at both ends
  (``theta*_{-j} = 2 theta_0 - theta_j``, ``theta*_{N+j} = 2 theta_N - theta_{N-j}``);
* ``theo1`` (eq. 30), at even ``m >= 10``, reported at ``tau = 0.75 m / fs``: the
  weighted double sum of :mod:`analysis.allan.theo1` over ``0.75 (N + 1 - m) (m / fs)^2``.
  Theo1 is biased against the Allan variance except for white rate noise (Stable32's
  bias-corrected Theo1 for flicker angle noise is 0.6028 times the variance here, read
  off its PHASE.DAT outputs); this is the unbiased-for-white-rate statistic allantools and
  Stable32's "alpha = 0" give.

Confidence intervals are chi-square with the edf of each estimator and of the noise type
identified per tau (:mod:`analysis.allan.noise_id`):

* modified, time and both Hadamard variances: the edf is computed from the structure
  function (:func:`analysis.allan.confidence.difference_edf_grid`, Greenhall and Riley 2003);
* total: NIST SP 1065 Table 7, ``edf = b N/m - c`` (white rate 1.50, 0; flicker rate
  1.17, 0.22; rate random walk 0.93, 0.36); for white and flicker angle noise, where the
  table gives none, and at m = 1, where the two estimators are the same, the overlapping
  Allan variance's computed edf (an approximation for angle noise at m > 1: a Monte Carlo
  of flicker angle noise finds total's edf at or below it, and half of NIST's "simple"
  flicker-PM formula that Stable32 gives total, benchmarks/bench_deviations.py);
* Theo1: NIST SP 1065's Theo1 edf formulas for the five noise types (Howe and Peppler
  2003, fitted to simulations: an approximation), with the noise type identified at the
  Allan averaging factor ``round(0.75 m)`` of the Theo1 tau.

Costs per tau: O(N) for all but Theo1 (one pass over the angle, three for total), whose
direct sum is O(N m): it is summed directly while that is at most 2e7 terms and from FFT
correlations beyond (O(N log N) per record plus O(m log^2 m) per tau; see
:mod:`analysis.allan.theo1`). The default log grids reach the longest tau each estimator
allows: N/2 (total), N/3 (modified, time, Hadamard), 0.75 N (Theo1).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

import analysis.allan.blocks as blocks
import analysis.allan.long_sums as long_sums
from analysis.allan.confidence import ONE_SIGMA, chi2_interval, difference_edf_grid, estimator_terms
from analysis.allan.estimators import (
    AllanResult,
    Estimator,
    InputKind,
    TauGrid,
    analysis_log_m,
    check_sample_rate,
    cluster_allan_variance,
    cumulative_angle,
    m_from_tau,
    octave_m,
    overlapping_allan_variance,
)
from analysis.allan.kinds import DEVIATION_KINDS as DEVIATION_KINDS, DeviationKind as DeviationKind
from analysis.allan.noise_id import identify_noise
from analysis.allan.theo1 import theo1_sums
from analysis.allan.variance import allan_variance
from analysis.errors import InvalidTauError, TooFewSamplesError

#: What each deviation is called in a table or a plot.
DEVIATION_LABELS: dict[str, str] = {
    "oadev": "overlapping Allan deviation", "adev": "Allan deviation (clusters)",
    "mdev": "modified Allan deviation", "hdev": "Hadamard deviation",
    "ohdev": "overlapping Hadamard deviation", "tdev": "time deviation",
    "totdev": "total deviation", "theo1": "Theo1 deviation",
}
#: Theo1's tau is this fraction of m / fs (NIST SP 1065, eq. 30).
THEO1_TAU_FACTOR = 0.75
#: Smallest Theo1 averaging factor (NIST SP 1065: 10 <= m, m even).
THEO1_MIN_M = 10
#: Points per decade of Theo1's default log grid.
THEO1_POINTS_PER_DECADE = 10
#: NIST SP 1065 Table 7: total variance edf = b N/m - c, by rate-noise exponent.
TOTAL_EDF_TABLE = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}


@dataclass(frozen=True)
class DeviationResult:
    """A deviation of the Allan family at a set of averaging times, with its intervals.

    Attributes
    ----------
    kind : str
        Which deviation (one of :data:`DEVIATION_KINDS`).
    tau_s : ndarray, shape (n_tau,)
        Averaging times in s (Theo1: ``0.75 m / fs``).
    m : ndarray of int, shape (n_tau,)
        Averaging factors in samples.
    variance : ndarray, shape (n_tau,) or (n_tau, k)
        The variance, in (input rate unit)^2, or (angle unit)^2 for ``tdev``.
    n_terms : ndarray of int, shape (n_tau,)
        Number of squared terms summed (Theo1: the ``N + 1 - m`` outer terms).
    edf : ndarray, same shape as ``variance``
        Equivalent degrees of freedom behind the interval.
    ci_low, ci_high : ndarray, same shape as ``variance``
        Chi-square confidence interval of the variance at level ``confidence``.
    noise_alpha : ndarray of int, same shape as ``variance``
        Rate-noise exponent identified at each tau (2 white angle .. -2 rate random walk).
    confidence : float
        Two-sided level of the interval.
    sample_rate_hz : float
        Sample rate of the record in Hz.
    n_samples : int
        Rate samples per axis.
    unit : {"rate", "angle"}
        Whether the deviation is a rate (deg/s for deg/s input) or an angle (``tdev``).
    interval : str
        Where the edf comes from, in words (and how approximate it is).
    notes : tuple of str
        Anything a reader of the values should know (e.g. a Theo1 rounding bound).
    """

    kind: str
    tau_s: NDArray[np.float64]
    m: NDArray[np.int64]
    variance: NDArray[np.float64]
    n_terms: NDArray[np.int64]
    edf: NDArray[np.float64]
    ci_low: NDArray[np.float64]
    ci_high: NDArray[np.float64]
    noise_alpha: NDArray[np.int64]
    confidence: float
    sample_rate_hz: float
    n_samples: int
    unit: Literal["rate", "angle"]
    interval: str
    notes: tuple[str, ...] = ()

    @property
    def deviation(self) -> NDArray[np.float64]:
        """The deviation, square root of ``variance``."""
        return np.sqrt(self.variance)

    @property
    def deviation_ci_low(self) -> NDArray[np.float64]:
        """Lower confidence bound of the deviation."""
        return np.sqrt(self.ci_low)

    @property
    def deviation_ci_high(self) -> NDArray[np.float64]:
        """Upper confidence bound of the deviation."""
        return np.sqrt(self.ci_high)

    @property
    def n_clusters(self) -> NDArray[np.int64]:
        """Whole clusters of m samples in the record, ``floor(N / m)``."""
        return (self.n_samples // self.m).astype(np.int64)

    def axis(self, index: int) -> DeviationResult:
        """The result of one axis of a multi-axis result."""
        if self.variance.ndim == 1:
            if index != 0:
                raise IndexError(f"a single-axis result has no axis {index}")
            return self
        pick = {name: getattr(self, name)[:, index]
                for name in ("variance", "edf", "ci_low", "ci_high", "noise_alpha")}
        return replace(self, **pick)


def from_allan(result: AllanResult) -> DeviationResult:
    """An Allan result (:mod:`analysis.allan`) as a :class:`DeviationResult`."""
    return DeviationResult(
        kind="oadev" if result.estimator == "overlapping" else "adev",
        tau_s=result.tau_s,
        m=result.m,
        variance=result.avar,
        n_terms=result.n_terms,
        edf=result.edf,
        ci_low=result.ci_low,
        ci_high=result.ci_high,
        noise_alpha=result.noise_alpha,
        confidence=result.confidence,
        sample_rate_hz=result.sample_rate_hz,
        n_samples=result.n_samples,
        unit="rate",
        interval="edf computed from the structure function (Greenhall and Riley 2003)",
    )


# ------------------------------------------------------------------------------- tau grids


def max_m(kind: DeviationKind, n_samples: int) -> int:
    """Largest averaging factor of an estimator over ``N`` samples (``N + 1`` angles)."""
    if kind in ("oadev", "adev", "totdev"):
        return n_samples // 2
    if kind in ("mdev", "tdev"):
        return (n_samples + 1) // 3
    if kind in ("hdev", "ohdev"):
        return n_samples // 3
    if kind == "theo1":
        return n_samples - n_samples % 2
    raise ValueError(f"unknown deviation {kind!r}; use one of {DEVIATION_KINDS}")


def deviation_m(
    kind: DeviationKind, taus: TauGrid | ArrayLike, n_samples: int, sample_rate_hz: float
) -> NDArray[np.int64]:
    """Averaging factors of a named grid or explicit taus (s) for one estimator.

    Raises
    ------
    TooFewSamplesError
        If the record is too short for the grid or a tau.
    InvalidTauError
        If an explicit tau is not a multiple of the sample period (Theo1: of 0.75 of an
        even number, at least 10, of sample periods).
    """
    top = max_m(kind, n_samples)
    m: NDArray[np.int64]
    if isinstance(taus, str):
        grid: NDArray[np.float64] | NDArray[np.int64]
        if taus == "log" and kind == "theo1":
            # each Theo1 tau costs O(m log^2 m) at long tau: ten per decade, not twenty
            decades = np.log10(max(top, THEO1_MIN_M) / THEO1_MIN_M)
            grid = np.geomspace(THEO1_MIN_M, max(top, THEO1_MIN_M),
                                int(THEO1_POINTS_PER_DECADE * decades) + 1)
        elif taus == "log":
            grid = analysis_log_m(n_samples, max_m=top)
        elif taus == "octave":
            grid = octave_m(n_samples, min_clusters=1)
        elif taus == "all":
            grid = np.arange(1, top + 1, dtype=np.int64)
        else:
            raise ValueError("tau grid must be 'log', 'octave', 'all' or an array of taus in s")
        grid = grid[grid <= top]
        if kind == "theo1":
            m = np.unique(2 * np.rint(grid / 2.0).astype(np.int64))
            m = m[(m >= THEO1_MIN_M) & (m <= top)]
        else:
            m = np.asarray(grid, dtype=np.int64)
        if m.size == 0:
            raise TooFewSamplesError(
                f"{n_samples} samples are too few for the {taus!r} grid of {kind}; record longer"
            )
        return m
    if kind == "theo1":
        m = m_from_tau(np.asarray(taus, dtype=float) / THEO1_TAU_FACTOR, sample_rate_hz)
        bad = (m % 2 == 1) | (m < THEO1_MIN_M)
        if bad.any():
            raise InvalidTauError(
                f"Theo1 tau {m[bad][0] * THEO1_TAU_FACTOR / sample_rate_hz} s is not 0.75 m sample "
                f"periods for an even m >= {THEO1_MIN_M}"
            )
    else:
        m = m_from_tau(taus, sample_rate_hz)
    if (m > top).any():
        raise TooFewSamplesError(
            f"{kind} at m = {m[m > top][0]} needs more than the {n_samples} samples of the record "
            f"(at most m = {top})"
        )
    return m


# ------------------------------------------------------------------------------- kernels


def _modified_sums(theta: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """Sum over j of the squared box sum of m second differences (per axis)."""
    d2 = theta[2 * m:] - 2.0 * theta[m:-m] + theta[: len(theta) - 2 * m]
    running = np.concatenate([np.zeros((1, theta.shape[1])), np.cumsum(d2, axis=0)])
    box = running[m:] - running[:-m]
    return np.asarray(np.einsum("ij,ij->j", box, box), dtype=np.float64)


def _hadamard_sums(theta: NDArray[np.float64], m: int, stride: int) -> NDArray[np.float64]:
    n = len(theta) - 3 * m
    d3 = theta[3 * m: 3 * m + n: stride] - 3.0 * theta[2 * m: 2 * m + n: stride] \
        + 3.0 * theta[m: m + n: stride] - theta[:n:stride]
    return np.asarray(np.einsum("ij,ij->j", d3, d3), dtype=np.float64)


def _total_sums(theta: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """Second differences of the reflected angle around the ``N - 1`` interior points."""
    p = len(theta)
    inner = theta[1:-1]
    extended = np.concatenate([2.0 * theta[0] - inner[::-1], theta, 2.0 * theta[-1] - inner[::-1]])
    centre = np.arange(p - 2) + (p - 2) + 1  # interior points 1..P-2, in extended indices
    lo, mid, hi = extended[centre - m], extended[centre], extended[centre + m]
    d2 = hi - 2.0 * mid + lo
    return np.asarray(np.einsum("ij,ij->j", d2, d2), dtype=np.float64)


def _long_sums(kind: str, theta: NDArray[np.float64], m: NDArray[np.int64], overlapping: bool
               ) -> NDArray[np.float64]:
    """The sums of :func:`_compute` for a memory-mapped angle, a block at a time."""
    out = np.empty((len(m), theta.shape[1]))
    for i, mi in enumerate(int(v) for v in m):
        for col in range(theta.shape[1]):
            x = theta[:, col]
            if kind in ("mdev", "tdev"):
                out[i, col] = long_sums.box_square_sum(x, mi)
            elif kind == "totdev":
                out[i, col] = long_sums.total_square_sum(x, mi)
            else:
                out[i, col] = long_sums.hadamard_square_sum(x, mi, 1 if overlapping else mi)
    return out


# ---------------------------------------------------------------------------------- edf


def total_edf(
    n_samples: int, m: NDArray[np.int64], alpha: NDArray[np.int64]
) -> NDArray[np.float64]:
    """Total variance edf: NIST SP 1065 Table 7, ``b N/m - c``, for rate noise (alpha 0, -1, -2);
    the overlapping Allan variance's computed edf for angle noise (alpha 2, 1), where the
    table gives none, and at m = 1 (the same estimator there). ``alpha`` is (n_tau, k);
    floored at 1."""
    allan = difference_edf_grid(n_samples, m, alpha, overlapping=True)
    ratio = (n_samples / m.astype(float))[:, None]
    out = allan.copy()
    for a, (b, c) in TOTAL_EDF_TABLE.items():
        out = np.where(alpha == a, b * ratio - c, out)
    # at m = 1 the reflection adds no term: total is the overlapping Allan variance, and the
    # table (fitted at longer tau) would give white rate noise 1.5 N against its 0.67 N
    out = np.where((m == 1)[:, None], allan, out)
    return np.maximum(out, 1.0)


def theo1_edf(n_points: int, m: NDArray[np.int64], alpha: NDArray[np.int64]) -> NDArray[np.float64]:
    """Theo1 edf, NIST SP 1065 (Howe and Peppler 2003): ``n_points`` angles, ``r = 0.75 m``.

    white angle ``0.86 (N+1)(N - 4r/3) / (N - r) * r / (r + 1.14)``; flicker angle
    ``(4.798 N^2 - 6.374 N r + 12.387 r) / (sqrt(r + 36.6) (N - r)) * r / (r + 0.3)``; white
    rate ``((4.1 N + 0.8)/r - (3.1 N + 6.5)/N) * r^1.5 / (r^1.5 + 5.2)``; flicker rate
    ``(2 N^2 - 1.3 N r - 3.5 r) / (N r) * r^3 / (r^3 + 2.3)``; rate random walk
    ``(4.4 N - 2) / (2.9 r) * ((4.4 N - 1)^2 - 8.6 r (4.4 N - 1) + 11.4 r^2) / (4.4 N - 3)^2``.
    Floored at 1.
    """
    n = float(n_points)
    r = (THEO1_TAU_FACTOR * np.asarray(m, dtype=float))[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        table = {
            2: 0.86 * (n + 1) * (n - 4 * r / 3) / (n - r) * r / (r + 1.14),
            1: (4.798 * n**2 - 6.374 * n * r + 12.387 * r)
            / (np.sqrt(r + 36.6) * (n - r))
            * r
            / (r + 0.3),
            0: ((4.1 * n + 0.8) / r - (3.1 * n + 6.5) / n) * r**1.5 / (r**1.5 + 5.2),
            -1: (2 * n**2 - 1.3 * n * r - 3.5 * r) / (n * r) * r**3 / (r**3 + 2.3),
            -2: (4.4 * n - 2)
            / (2.9 * r)
            * ((4.4 * n - 1) ** 2 - 8.6 * r * (4.4 * n - 1) + 11.4 * r**2)
            / (4.4 * n - 3) ** 2,
        }
    out = np.ones(np.shape(alpha))
    for a, values in table.items():
        out = np.where(alpha == a, np.broadcast_to(values, np.shape(alpha)), out)
    return np.maximum(np.nan_to_num(out, nan=1.0), 1.0)


# ---------------------------------------------------------------------------- estimators


@dataclass(frozen=True)
class _Spec:
    order: int
    modified: bool
    overlapping: bool
    interval: str


_COMPUTED = "edf computed from the structure function (Greenhall and Riley 2003)"
_SPECS: dict[str, _Spec] = {
    "mdev": _Spec(2, True, True, _COMPUTED),
    "tdev": _Spec(2, True, True, _COMPUTED),
    "hdev": _Spec(3, False, False, _COMPUTED),
    "ohdev": _Spec(3, False, True, _COMPUTED),
    "totdev": _Spec(
        2,
        False,
        True,
        "edf of NIST SP 1065 Table 7 (white, flicker rate, rate random walk); "
        "the overlapping Allan edf for angle noise (approximate)",
    ),
    "theo1": _Spec(
        2, False, True, "edf of NIST SP 1065's Theo1 formulas (fitted to simulations: approximate)"
    ),
}


def _compute(kind: str, samples: ArrayLike, sample_rate_hz: float, *, taus: TauGrid | ArrayLike,
             input_kind: InputKind, confidence: float,
             angle_out: NDArray[np.float64] | None = None) -> DeviationResult:
    fs = check_sample_rate(sample_rate_hz)
    theta = cumulative_angle(samples, fs, input_kind=input_kind, out=angle_out)
    n = theta.shape[0] - 1
    m = deviation_m(kind, taus, n, fs)  # type: ignore[arg-type]
    spec = _SPECS[kind]
    tau = m / fs
    notes: list[str] = []
    if kind == "theo1":
        sums = np.empty((len(m), theta.shape[1]))
        worst = 0.0
        for col in range(theta.shape[1]):
            sums[:, col], bound = theo1_sums(theta[:, col], m)
            worst = max(worst, float(bound.max()))
        n_terms = (n + 1 - m).astype(np.int64)
        variance = sums / (THEO1_TAU_FACTOR * n_terms[:, None] * tau[:, None] ** 2)
        tau = THEO1_TAU_FACTOR * tau
        m_id = np.maximum(np.rint(THEO1_TAU_FACTOR * m).astype(np.int64), 1)
        alpha = identify_noise(theta, np.unique(m_id)).alpha[np.searchsorted(np.unique(m_id), m_id)]
        edf = theo1_edf(n + 1, m, alpha)
        if worst > 1e-4:
            notes.append(
                f"Theo1 sums carry a relative rounding error of up to {worst:.1g} (the angle "
                f"wanders far against its short-tau differences)"
            )
    else:
        if blocks.is_mapped(theta) and blocks.is_long(n):
            sums = _long_sums(kind, theta, m, spec.overlapping)
        elif kind in ("mdev", "tdev"):
            sums = np.stack([_modified_sums(theta, int(mi)) for mi in m])
        elif kind == "totdev":
            sums = np.stack([_total_sums(theta, int(mi)) for mi in m])
        else:
            sums = np.stack(
                [_hadamard_sums(theta, int(mi), 1 if spec.overlapping else int(mi)) for mi in m]
            )
        if kind == "totdev":
            n_terms = np.full(len(m), n - 1, dtype=np.int64)
        else:
            n_terms = estimator_terms(n, m, order=spec.order, modified=spec.modified,
                                      overlapping=spec.overlapping).astype(np.int64)
        if spec.modified:
            variance = sums / (2.0 * (m.astype(float) ** 2 * tau**2 * n_terms)[:, None])
        elif spec.order == 3:
            variance = sums / (6.0 * (tau**2 * n_terms)[:, None])
        else:
            variance = sums / (2.0 * (tau**2 * n_terms)[:, None])
        if kind == "tdev":
            variance = variance * (tau**2 / 3.0)[:, None]
        alpha = identify_noise(theta, m, d_max=spec.order).alpha
        if kind == "totdev":
            edf = total_edf(n, m, alpha)
        else:
            edf = difference_edf_grid(n, m, alpha, order=spec.order, modified=spec.modified,
                                      overlapping=spec.overlapping)
    low, high = chi2_interval(variance, edf, confidence)
    squeeze = np.ndim(samples) == 1
    if squeeze:
        variance, edf, low, high, alpha = (
            variance[:, 0],
            edf[:, 0],
            low[:, 0],
            high[:, 0],
            alpha[:, 0],
        )
    return DeviationResult(
        kind=kind,
        tau_s=tau,
        m=m,
        variance=variance,
        n_terms=n_terms,
        edf=edf,
        ci_low=low,
        ci_high=high,
        noise_alpha=alpha,
        confidence=confidence,
        sample_rate_hz=fs,
        n_samples=n,
        unit="angle" if kind == "tdev" else "rate",
        interval=spec.interval,
        notes=tuple(notes),
    )


def deviation(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    kind: DeviationKind = "oadev",
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
    angle_out: NDArray[np.float64] | None = None,
) -> DeviationResult:
    """One deviation of the Allan family of a rate record, with confidence intervals.

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate samples (e.g. deg/s), or angle increments per sample with
        ``input_kind="angle_increment"``.
    sample_rate_hz : float
        Sample rate in Hz.
    kind : str
        One of :data:`DEVIATION_KINDS` (see the module docstring).
    taus : {"log", "octave", "all"} or array_like
        Tau grid: log-spaced (to the longest tau the estimator allows), octaves, every m,
        or explicit taus in seconds (Theo1: Theo1 taus, ``0.75 m / fs``).
    input_kind : {"rate", "angle_increment"}
        What the samples are.
    confidence : float
        Two-sided level of the chi-square intervals (default +-1 sigma).
    angle_out : ndarray, shape (N + 1, k), optional
        Where to keep the angle of a long record (:func:`analysis.allan.blocks.is_long`; e.g. a
        memmap): the Allan, modified, Hadamard and total deviations then read it a block
        at a time (:mod:`analysis.allan.long_sums`), in bounded memory; Theo1 reads it whole.

    Returns
    -------
    DeviationResult

    Raises
    ------
    NonFiniteSamplesError, TooFewSamplesError, InvalidSampleRateError, InvalidTauError
    ValueError
        If ``kind`` is not a known deviation.

    References
    ----------
    W. J. Riley, Handbook of Frequency Stability Analysis, NIST SP 1065 (2008), eq. 14-30
    and Tables 7 and 11; C. A. Greenhall and W. J. Riley, Proc. 35th PTTI (2003); D. A. Howe
    and T. K. Peppler, Proc. 2003 IEEE FCS / EFTF (Theo1 edf).
    """
    if kind in ("oadev", "adev"):
        estimator: Estimator = "overlapping" if kind == "oadev" else "clusters"
        if isinstance(taus, str) and taus == "log":  # to two clusters, like every grid here
            fs = check_sample_rate(sample_rate_hz)
            n = int(np.shape(samples)[0]) if np.ndim(samples) else 0
            taus = analysis_log_m(n) / fs
            if not len(taus):
                raise TooFewSamplesError(
                    f"{n} samples are too few for the 'log' grid of {kind}; record longer"
                )
        if angle_out is not None and blocks.is_long(int(np.shape(samples)[0])):
            compute = (overlapping_allan_variance if estimator == "overlapping"
                       else cluster_allan_variance)
            return from_allan(compute(samples, sample_rate_hz, taus=taus, input_kind=input_kind,
                                      confidence=confidence, angle_out=angle_out))
        return from_allan(allan_variance(samples, sample_rate_hz, estimator=estimator, taus=taus,
                                         input_kind=input_kind, confidence=confidence))
    if kind not in _SPECS:
        raise ValueError(f"unknown deviation {kind!r}; use one of {DEVIATION_KINDS}")
    return _compute(kind, samples, sample_rate_hz, taus=taus, input_kind=input_kind,
                    confidence=confidence, angle_out=angle_out)
