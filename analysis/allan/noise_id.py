"""Which power-law noise dominates at each averaging time: lag-1 autocorrelation, B1, R(n).

The confidence interval of a value of the Allan family depends on the noise type at its
tau (:mod:`analysis.allan.confidence`). The type is identified here from the record itself, per
averaging factor m, the way Stable32 does it:

* **lag-1 autocorrelation** (W. J. Riley and C. A. Greenhall, "Power law noise
  identification using the lag 1 autocorrelation", Proc. 18th EFTF, 2004): the angle
  (phase) is decimated by m and differenced ``d`` times, ``d >= 1`` (the first difference
  is the series of m-sample rate averages; a gyro's angle carries its bias as a ramp, so
  a phase record's first test, at ``d = 0``, would fail on it anyway), until
  ``delta = r1 / (1 + r1) < 0.25`` (``r1`` the lag-1 autocorrelation, about the mean) or
  ``d = d_max``; then ``p = -2 (delta + d)`` estimates the angle's spectral exponent and
  ``alpha = p + 2`` the rate's, rounded to an integer. Nothing else is removed first: a
  rate drift is part of what the Allan variance sees. It needs about
  :data:`MIN_ACF_POINTS` decimated points. On the three Stable32 reference records that
  allantools ships (PHASE.DAT, GPS, Cs 5071A) this gives Stable32's type at all 105 taus
  with at least 30 points;
* with fewer, the **B1 ratio** (Barnes 1969; NIST SP 1065 section 5.6): the variance of
  the ``n = N / m`` rate averages over their Allan variance, compared with its expected
  value ``B1(n, mu)`` for each slope ``mu`` of the Allan variance, the boundaries being the
  geometric means of adjacent expected values; a slope of -2 (white or flicker angle) is
  split by **R(n)**, the modified over the overlapping Allan variance (``1/m`` for white
  angle noise, about ``3 ln(256/27) / (2 (1.038 + 3 ln(pi m)))`` for flicker angle noise);
* with fewer than :data:`MIN_B1_AVERAGES` averages (two averages hold no information on
  the type), the type of the nearest shorter tau that was identified is carried over.

Where the evidence is thin (fewer than :data:`MONOTONE_BELOW_POINTS` decimated points),
a type is taken no shallower than the type of the tau before it: the dominant type of a
sum of power-law noises can only get steeper with tau, and a short series that reads
white angle noise at the end of a white-rate record would otherwise give that tau the
white-angle edf (about N/2) and an interval far too narrow. Measured on white rate noise
(4096 samples, octave taus, 300 seeds): the +-1 sigma intervals of the overlapping
estimator hold the truth in 70.4 % of cells with this rule, 66.7 % without it (61-62 % at
the taus of 4 to 16 averages); 69.8 % with the slope-based types used before.

Alpha is the exponent of the rate's power spectrum (S ~ f^alpha): 2 white angle
(quantization), 1 flicker angle, 0 white rate (ARW), -1 flicker rate (bias instability),
-2 rate random walk; steeper types (identified by the Hadamard family's third difference)
are reported as -2, the steepest the edf computation knows.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial
from types import ModuleType
from typing import Literal

import numpy as np
from numpy.typing import NDArray

import analysis.allan.blocks as blocks
import analysis.allan.kernels as kernels
from analysis.allan.long_sums import box_square_sum, second_differences

#: Decimated angle points the lag-1 method needs (Riley and Greenhall: about 30).
MIN_ACF_POINTS = 30
#: Rate averages the B1 ratio needs: with two, the variance and the Allan variance agree.
MIN_B1_AVERAGES = 3
#: Below this many decimated points, a tau's type is taken no shallower than the type of
#: the tau before it.
MONOTONE_BELOW_POINTS = 100
#: Estimate below which the lag-1 method reads rate random walk rather than flicker rate.
#: Rounding would put it at -1.5, but the angle of flicker rate noise decimated by m >> 1
#: gives an expected estimate of -1.45 (its structure function ``-t^2 ln t`` sampled at
#: whole taus: ``r1 = -0.217`` after two differences), so 40 % of flicker-rate taus of a
#: simulated record read as rate random walk; rate random walk gives -2.40. The boundary
#: is the midpoint of the two. Stable32's references hold neither type where this applies.
FLICKER_RATE_BOUNDARY = -1.92
#: Most decimated points the lag-1 autocorrelation reads at one tau. A tau with more (the
#: shortest taus of a long record: every m below N / 2^16) reads :data:`ACF_PIECES` runs of
#: consecutive decimated points spread evenly over the record instead: the standard error
#: of ``r1`` is about ``1 / sqrt(n)``, 0.004 here, against 0.25 in ``delta`` between two
#: types, and the cost of the shortest taus no longer grows with the record (the whole
#: series was 3.5 N points over a log grid of 100 taus, half the time the overlapping
#: sums took at N = 2e6). ``python benchmarks/check_lag1_runs.py``: on simulated white and
#: flicker angle, white and flicker rate, white plus random-walk rate and mixed records,
#: the runs give the whole series' type in 162 of 162 cells at N = 6e5 (3 seeds) and 250
#: of 252 at N = 3e6 (2 seeds). The two sit on a boundary: a flicker-angle record's
#: estimate 1.507 from the whole series (white angle) against 1.496 from the runs (flicker
#: angle, the simulated type), and a mixture's delta 0.259 against 0.242 at the 0.25 that
#: decides whether to difference again.
ACF_MAX_POINTS = 1 << 16
#: Runs the :data:`ACF_MAX_POINTS` points of a long series are read in.
ACF_PIECES = 16
#: Noise exponents reported (white angle .. rate random walk).
ALPHA_RANGE = (-2, 2)
#: Above this many taus, the type is identified at this many log-spaced ones and the rest
#: take the type of the nearest one (in log tau).
ID_EXACT_POINTS = 160

IdMethod = Literal["acf", "b1", "rn", "carried"]
_METHODS: tuple[IdMethod, ...] = ("acf", "b1", "rn", "carried")


@dataclass(frozen=True)
class NoiseIdentification:
    """Dominant noise type per averaging factor (and axis).

    Attributes
    ----------
    m : ndarray of int, shape (n_tau,)
        Averaging factors.
    alpha : ndarray of int, shape (n_tau,) or (n_tau, k)
        Rate-noise exponent per tau: 2, 1, 0, -1 or -2.
    method : ndarray of str, same shape as ``alpha``
        How each was found: ``"acf"`` (lag-1 autocorrelation), ``"b1"``, ``"rn"`` (B1 then
        R(n)), or ``"carried"`` from the nearest shorter tau.
    """

    m: NDArray[np.int64]
    alpha: NDArray[np.int64]
    method: NDArray[np.str_]


def lag1_autocorrelation(z: NDArray[np.float64]) -> float:
    """Lag-1 autocorrelation ``sum (z_i - zbar)(z_{i+1} - zbar) / sum (z_i - zbar)^2``
    (Riley and Greenhall 2004, eq. 2); 0 for a constant series."""
    d = z - z.mean()
    den = float(np.einsum("i,i->", d, d))  # einsum: BLAS dot is slower on a busy machine
    return float(np.einsum("i,i->", d[:-1], d[1:])) / den if den > 0 else 0.0


def _decimated_differences(angle: NDArray[np.float64], m: int, d: int
                           ) -> tuple[int, Iterator[NDArray[np.float64]]]:
    """(length, blocks of) the ``d``-th difference of ``angle[::m]``, for a long record."""
    n_y = (len(angle) - 1) // m + 1
    length = n_y - d

    def gen() -> Iterator[NDArray[np.float64]]:
        # a block of decimated samples strides over m times as many angle samples: keep
        # the pages it maps in at about one block (every page is touched for m < 512)
        for a, b in blocks.spans(0, length, max(1, blocks.BLOCK_SAMPLES // m)):
            y = np.asarray(angle[a * m: (b + d - 1) * m + 1: m], dtype=float)
            yield np.diff(y, n=d)
            blocks.release(angle)

    return length, gen()


def _lag1_long(angle: NDArray[np.float64], m: int, d: int) -> tuple[float, int]:
    """(lag-1 autocorrelation, length) of the ``d``-th difference of ``angle[::m]``, two
    passes over a long record (mean, then the centred sums)."""
    n, parts = _decimated_differences(angle, m, d)
    mean = sum(float(z.sum()) for z in parts) / n
    den = num = 0.0
    last = None
    for z in _decimated_differences(angle, m, d)[1]:
        c = z - mean
        den += float(np.einsum("i,i->", c, c))
        num += float(np.einsum("i,i->", c[:-1], c[1:]))
        if last is not None:
            num += last * float(c[0])
        last = float(c[-1])
    return (num / den if den > 0 else 0.0), n


def _lag1_pieces(y: NDArray[np.float64], d: int) -> tuple[float, int]:
    """(lag-1 autocorrelation about the common mean, length) of the ``d``-th differences
    of each row of ``y`` (runs of decimated angles, :func:`_acf_runs`), the pairs taken
    within a row: ``r1 = (n - 1)/(n - P) sum_pairs / sum (z - zbar)^2`` over ``n`` terms in
    ``P`` rows, the normalisation of :func:`lag1_autocorrelation` over one series."""
    z = np.diff(y, n=d, axis=1)
    c = z - z.mean()
    den = float(np.einsum("ij,ij->", c, c))
    num = float(np.einsum("ij,ij->", c[:, :-1], c[:, 1:]))
    n, rows = z.size, z.shape[0]
    return (num * (n - 1) / (n - rows) / den if den > 0 else 0.0), n


def _acf_runs(angle: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """:data:`ACF_PIECES` runs of ``ACF_MAX_POINTS / ACF_PIECES`` consecutive points of
    ``angle[::m]``, spread evenly from its first point to its last, shape (pieces, run)."""
    n_points = (len(angle) - 1) // m + 1
    run = ACF_MAX_POINTS // ACF_PIECES
    starts = np.rint(np.linspace(0, n_points - run, ACF_PIECES)).astype(np.int64) * m
    y = np.empty((ACF_PIECES, run))
    for row, start in zip(y, starts, strict=True):
        row[:] = angle[start: start + (run - 1) * m + 1: m]  # a strided copy, no index array
    blocks.release(angle)
    return y


def lag1_alpha(angle: NDArray[np.float64], m: int, *, d_max: int = 2) -> int:
    """Noise exponent at averaging factor m by the lag-1 autocorrelation method.

    Parameters
    ----------
    angle : ndarray, shape (N + 1,)
        Angle (phase) samples of one axis, any unit. A long record (a memmap) is read a
        block at a time (:mod:`analysis.allan.blocks`).
    m : int
        Averaging factor; the angle is decimated by m.
    d_max : int
        Largest number of differences: 2 for the Allan family, 3 for the Hadamard one.

    Returns
    -------
    int
        alpha, clipped to :data:`ALPHA_RANGE`: the estimate ``-2 (delta + d) + 2`` rounded,
        but split between flicker rate and rate random walk at
        :data:`FLICKER_RATE_BOUNDARY` instead of -1.5. A series of more than
        :data:`ACF_MAX_POINTS` decimated points is read in :data:`ACF_PIECES` runs.
    """
    if (len(angle) - 1) // m + 1 > ACF_MAX_POINTS:
        return _alpha_from_lag1(partial(_lag1_pieces, _acf_runs(angle, m)), d_max)
    long = blocks.is_long((len(angle) - 1) // m)
    z = None if long else np.diff(blocks.decimated(angle, m))

    def lag1(d: int) -> tuple[float, int]:
        nonlocal z
        if z is None:
            return _lag1_long(angle, m, d)
        if d > 1:
            z = np.diff(z)
        return lag1_autocorrelation(z), len(z)

    return _alpha_from_lag1(lag1, d_max)


def lag1_from_moments(moments: NDArray[np.float64]) -> tuple[float, int]:
    """(lag-1 autocorrelation about the mean, length) of a series from its sums about its
    first value (one row of :func:`analysis.allan.kernels_numba.lag1_moments`:
    ``n, S1, S2, S11, y_last``): the centred sums of :func:`lag1_autocorrelation`
    rewritten, ``sum (y - s)^2 = S2 - n s^2`` and ``sum (y_i - s)(y_(i+1) - s) = S11 -
    s (2 S1 - y_last) + (n - 1) s^2`` with ``s = S1 / n`` (``y_0 = 0``); they agree with
    it to rounding."""
    n = int(moments[0])
    if n < 1:
        return 0.0, n
    s1, s2, s11, y_last = (float(v) for v in moments[1:5])
    shift = s1 / n
    den = s2 - n * shift * shift
    num = s11 - shift * (2.0 * s1 - y_last) + (n - 1) * shift * shift
    return (num / den if den > 0 else 0.0), n


def _moments_lag1(rows: NDArray[np.float64], d: int) -> tuple[float, int]:
    """:func:`lag1_from_moments` of the ``d``-th difference's row."""
    return lag1_from_moments(rows[d - 1])


def _alpha_from_lag1(lag1: Callable[[int], tuple[float, int]], d_max: int) -> int:
    """alpha from the lag-1 autocorrelations ``lag1(d)`` (with the series' length) of the
    1st, 2nd, ... differences, as :func:`lag1_alpha` describes."""
    d = 1
    while True:
        r1, length = lag1(d)
        delta = r1 / (1.0 + r1) if r1 > -1.0 else -np.inf
        if delta < 0.25 or d >= d_max or length < 4:
            break
        d += 1
    if not np.isfinite(delta):
        return ALPHA_RANGE[1]
    estimate = -2.0 * (delta + d) + 2.0
    if -2.5 < estimate < -0.5:  # flicker rate or rate random walk: their own boundary
        return -1 if estimate > FLICKER_RATE_BOUNDARY else -2
    return int(np.clip(np.rint(estimate), *ALPHA_RANGE))


def b1_expected(n: int, mu: float) -> float:
    """Expected B1 ratio (n-sample over Allan variance) for an Allan variance slope ``mu``.

    ``B1(n, mu) = n (1 - n^mu) / (2 (n - 1)(1 - 2^mu))``, with its limit
    ``n ln n / (2 (n - 1) ln 2)`` at ``mu = 0`` (Barnes 1969; NIST SP 1065, section 5.6).
    """
    if mu == 0:
        return float(n * np.log(n) / (2.0 * (n - 1) * np.log(2.0)))
    return float(n * (1.0 - n**mu) / (2.0 * (n - 1) * (1.0 - 2.0**mu)))


#: Allan-variance slope mu of each noise exponent the B1 ratio can separate.
_MU_OF_ALPHA = {2: -2, 0: -1, -1: 0, -2: 1}


def b1_ratio(angle: NDArray[np.float64], m: int) -> float:
    """B1: sample variance (ddof 1) of the ``N/m`` rate averages over their Allan variance."""
    n = (len(angle) - 1) // m
    means = np.diff(blocks.decimated(angle[: n * m + 1], m))
    avar = float(np.sum(np.diff(means) ** 2)) / (2.0 * (n - 1))
    return float(np.var(means, ddof=1)) / avar if avar > 0 else 1.0


def rn_ratio(angle: NDArray[np.float64], m: int, compiled: ModuleType | None = None) -> float:
    """R(n): modified over overlapping Allan variance at averaging factor m (same scale).

    A long record (a memmap) is read a block at a time, with the same sums. With
    ``compiled`` (the numba kernels the record's Allan sums ran on), the two sums are
    taken in one pass (:func:`analysis.allan.kernels_numba.rn_sums`; the same sums, to
    rounding) instead of five numpy passes and two record-long temporaries."""
    x = np.asarray(angle, dtype=float)
    length = len(x) - 2 * m
    if compiled is not None:
        d_square, box_square = compiled.rn_sums(np.ascontiguousarray(x), m)
        avar = d_square / length
        n_box = length + 1 - m
        mvar = box_square / n_box if n_box > 0 else avar
        return float(mvar / avar) if avar > 0 else 1.0
    if blocks.is_long(length):
        return _rn_ratio_long(x, m, length)
    d2 = x[2 * m:] - 2.0 * x[m:-m] + x[: len(x) - 2 * m]
    avar = float(np.einsum("i,i->", d2, d2)) / len(d2)
    sums = np.concatenate([[0.0], np.cumsum(d2)])
    box = (sums[m:] - sums[:-m]) / m
    mvar = float(np.einsum("i,i->", box, box)) / len(box) if len(box) else avar
    return mvar / avar if avar > 0 else 1.0


def _rn_ratio_long(x: NDArray[np.float64], m: int, length: int) -> float:
    total = 0.0
    for a, b in blocks.spans(0, length):
        d2 = second_differences(x, m, a, b)
        total += float(np.einsum("i,i->", d2, d2))
        blocks.release(x)
    avar = total / length
    n_box = length + 1 - m
    mvar = box_square_sum(x, m, divisor=m) / n_box if n_box > 0 else avar
    return mvar / avar if avar > 0 else 1.0


def _rn_expected_flicker_angle(m: int) -> float:
    """R(n) of flicker angle noise with the bandwidth at half the sample rate (NIST SP 1065,
    Table 10: MVAR and AVAR of flicker PM, ``f_h tau = m / 2``)."""
    mvar = 3.0 * np.log(256.0 / 27.0) / (8.0 * np.pi**2)
    avar = (1.038 + 3.0 * np.log(np.pi * m)) / (4.0 * np.pi**2)
    return float(mvar / avar)


def b1_alpha(angle: NDArray[np.float64], m: int, compiled: ModuleType | None = None, *,
             split_angle: bool = True) -> tuple[int, IdMethod]:
    """Noise exponent from the B1 ratio, white against flicker angle split by R(n)
    (:func:`rn_ratio`, compiled with ``compiled``). With ``split_angle=False`` angle noise
    reads as white angle (2) without R(n), a pass over the whole record: for a caller that
    takes the type no shallower than a flicker-angle or steeper one anyway."""
    n = (len(angle) - 1) // m
    b1 = b1_ratio(angle, m)
    alphas = sorted(_MU_OF_ALPHA, key=lambda a: _MU_OF_ALPHA[a])  # mu ascending: 2, 0, -1, -2
    expected = [b1_expected(n, _MU_OF_ALPHA[a]) for a in alphas]
    alpha = alphas[-1]
    for a, lo, hi in zip(alphas, expected[:-1], expected[1:], strict=False):
        if b1 < np.sqrt(lo * hi):
            alpha = a
            break
    if alpha != 2 or m < 2 or not split_angle:
        return alpha, "b1"
    rn = rn_ratio(angle, m, compiled)
    boundary = np.sqrt(_rn_expected_flicker_angle(m) / m)
    return (2 if rn < boundary else 1), "rn"


def identify_noise(
    angle: NDArray[np.float64], m: NDArray[np.int64], *, d_max: int = 2,
    backend: kernels.Backend = "auto",
) -> NoiseIdentification:
    """Dominant noise exponent at each averaging factor, for one axis or several.

    Parameters
    ----------
    angle : ndarray, shape (N + 1,) or (N + 1, k)
        Cumulative angle (phase) of each axis, e.g. :func:`analysis.allan.cumulative_angle`.
    m : ndarray of int, shape (n_tau,)
        Averaging factors, increasing.
    d_max : int
        2 for the Allan family, 3 for the Hadamard one (one more difference).
    backend : {"auto", "numpy", "numba"}
        Where the overlapping Allan sums of this record and grid run compiled
        (:func:`analysis.allan.kernels.overlapping_backend`), the lag-1 sums of every
        tau are taken in one compiled pass per tau (:func:`lag1_from_moments`; the same
        types, the autocorrelations agreeing to rounding); else in numpy, tau by tau.

    Returns
    -------
    NoiseIdentification
        ``alpha`` shaped (n_tau,) for a 1-D ``angle``, else (n_tau, k).

    Notes
    -----
    Cost: one pass over ``N/m`` decimated points per identified tau, at most
    :data:`ACF_MAX_POINTS` of them; grids of more than :data:`ID_EXACT_POINTS` taus are
    identified at that many log-spaced ones.

    References
    ----------
    W. J. Riley and C. A. Greenhall, Proc. 18th EFTF (2004); W. J. Riley, Handbook of
    Frequency Stability Analysis, NIST SP 1065 (2008), section 5.6 (B1, R(n)).
    """
    x = np.asarray(angle, dtype=float)
    squeeze = x.ndim == 1
    x = x[:, None] if squeeze else x
    m = np.asarray(m, dtype=np.int64)
    if len(m) > ID_EXACT_POINTS:
        picks = np.unique(np.geomspace(1, len(m), ID_EXACT_POINTS).astype(int) - 1)
    else:
        picks = np.arange(len(m))
    n_points = (x.shape[0] - 1) // m[picks] + 1
    alpha = np.zeros((len(picks), x.shape[1]), dtype=np.int64)
    method = np.empty((len(picks), x.shape[1]), dtype="<U7")
    acf = n_points >= MIN_ACF_POINTS
    # the shortest taus of a long record read runs of their series (ACF_MAX_POINTS);
    # they come first, n_points falling with m
    runs = n_points > ACF_MAX_POINTS
    n_runs = int(runs.sum())
    # a long memory-mapped record keeps the block-wise reads below (pages handed back)
    long_mapped = blocks.is_mapped(angle) and blocks.is_long(x.shape[0])
    compiled = None if long_mapped else kernels.overlapping_backend(
        x.shape[0], m, x.shape[1], backend)
    for col in range(x.shape[1]):
        moments = None
        if compiled is not None and (acf & ~runs).any():
            moments = kernels.lag1_moments(x[:, col], m[picks][acf & ~runs], d_max, compiled)
        last: int | None = None
        for i, mi in enumerate(m[picks]):
            if acf[i] and not runs[i] and moments is not None:
                # the acf taus come first (n_points falls with m), the read-in-runs ones
                # before them: row i - n_runs is this tau's
                a, how = _alpha_from_lag1(partial(_moments_lag1, moments[i - n_runs]),
                                          d_max), "acf"
            elif acf[i]:
                a, how = lag1_alpha(x[:, col], int(mi), d_max=d_max), "acf"
            elif n_points[i] - 1 >= MIN_B1_AVERAGES:
                # R(n) splits white from flicker angle only; where the type is capped
                # below at the previous tau's (thin evidence) and that is flicker angle
                # or steeper, the split cannot change it: its record-long pass is skipped
                split = (last is None or last >= 2
                         or n_points[i] >= MONOTONE_BELOW_POINTS)
                a, how = b1_alpha(x[:, col], int(mi), compiled, split_angle=split)
            else:
                a, how = (last if last is not None else 0), "carried"
            blocks.release(x)  # a decimated read of a memmap maps in every page it strides over
            if last is not None and n_points[i] < MONOTONE_BELOW_POINTS:
                a = min(a, last)  # a sum of power laws never turns back to a shallower type
            alpha[i, col], method[i, col], last = a, how, a
    if len(picks) < len(m):
        # every tau takes the type of the nearest identified one in log tau
        logp = np.log(m[picks].astype(float))
        nearest = np.clip(np.searchsorted(logp, np.log(m.astype(float))), 1, len(picks) - 1)
        left = np.log(m) - logp[nearest - 1] < logp[nearest] - np.log(m)
        index = np.where(left, nearest - 1, nearest)
        alpha, method = alpha[index], method[index]
    if squeeze:
        alpha, method = alpha[:, 0], method[:, 0]
    return NoiseIdentification(m=m, alpha=alpha, method=method)
