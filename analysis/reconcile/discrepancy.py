"""Model versus measurement, step 1: the gap statistic and the Monte Carlo band.

The measured record's overlapping Allan variance ``a_i`` (Zhang 2015 eq. 5) is taken on a
log grid of averaging factors (``points_per_octave`` per octave, at least ``min_clusters``
clusters at the longest tau) and compared with a model's theoretical curve ``A_i``
(:meth:`analysis.models.NoiseModel.avar`, the sum of its terms, Zhang 2015 eq. 12).

**Gap statistic.** If the model is right, ``a_i = A_i X_i / nu_i`` with ``X_i`` chi-square
with ``nu_i`` equivalent degrees of freedom (the edf of :mod:`analysis.allan.confidence`,
computed once for the noise type the measured curve shows at each tau, its local slope,
so that every model compared with the curve gets the same weights and the gaps before
and after a change compare). ``log X/nu`` has mean
``c_i = psi(nu/2) - log(nu/2)`` and variance ``v_i = psi'(nu/2)`` (digamma, trigamma), so

    z_i = (log a_i - c_i - log A_i) / sqrt(v_i + f^2)                             (G1)

is a standardized log-ratio, about N(0, 1) per tau. ``f`` (``floor``, default 0.05) is
the relative accuracy a library curve is trusted to (5 % in Allan variance): without it
a record of a million samples, whose short-tau estimates have edf near a million, would
let a 1 % departure of a real sensor from the ideal white-noise slope (an anti-alias
filter, quantization) outweigh every other tau. The gap is the octave-weighted mean

    G = sum_i s_i z_i^2 / sum_i s_i                                               (G2)

with ``s_i`` each tau's share of an octave (:func:`analysis.fit.log_tau_share`), so that
every octave of tau counts once however densely it is sampled. G is about 1 when the model
holds and grows with the squared log-ratio where it does not; it is dimensionless and does
not depend on the units or level of the noise.

**Null distribution and band.** The z_i of neighbouring taus are correlated and the
chi-square law is only approximate at long tau, so G's distribution under the model is
simulated: ``runs`` records of the same length, rate and tau grid are generated from the
model with :mod:`analysis.models.simulation` and their G computed the same way. A scaled
chi-square ``g chi2_h / h`` matched to the mean and variance of those G values (two
moments are well estimated from a few tens of runs, where a 99 % quantile is not) gives
the p-value of the measured G. The same runs give the per-tau band: the mean and spread
of ``log a`` over the runs, ``exp(mean +- 1.96 sd)`` (95 %). The tau ranges where the
measured curve leaves the band say where the disagreement is.

**Cost.** The runs are generated as the axes of one simulator call (one pass per batch
of at most ``BATCH_SAMPLES`` values), and only the Allan sums of the grid are computed
for them (the edf is the curve's, computed once). With a :class:`ComparisonCache`, the
runs of each term are kept (up to ``TERM_CACHE_VALUES`` values) and a model's runs are
their sum: exact, since the simulator keys each term's generator by seed and term name,
so re-checking the model with one more effect simulates only that effect. Records longer
than ``max_samples`` are decimated before anything else, measured and simulated alike
(block means of d samples
are exactly the samples of the same gyro at ``fs / d``, every simulated sample being the
mean rate over its period), so the measured curve and its simulated band are still of
the same estimator on the same record length; only taus below ``d / fs`` are given up.
The tau grid stops at ``N / min_clusters`` (4 clusters): the last octaves have few edf,
which the simulated null accounts for.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import blocks
from analysis.allan.confidence import allan_edf_grid, local_noise_alpha
from analysis.allan.estimators import check_sample_rate, cumulative_angle, log_m, overlapping_sums
from analysis.distributions import chi2_ppf, chi2_sf, normal_ppf
from analysis.errors import ReconcileError
from analysis.fit.least_squares import log_tau_share
from analysis.models.simulation import simulate
from analysis.models.terms import NoiseModel
from analysis.reconcile.options import MODEL_FLOOR as MODEL_FLOOR

#: Rate samples (per axis times axes) generated per simulator call of the Monte Carlo.
BATCH_SAMPLES = 1 << 21
#: Largest run set (samples times runs) whose per-term runs are kept in a ComparisonCache.
TERM_CACHE_VALUES = 1 << 23
#: Two-sided level of the per-tau Monte Carlo band.
BAND_LEVEL = 0.95


def block_means(x: ArrayLike, block: int) -> NDArray[np.float64]:
    """Means of consecutive blocks of ``block`` samples (axis 0); a trailing part is dropped.

    A memory-mapped record (a long run's scratch array) is read a few blocks at a time and
    its pages handed back (:func:`analysis.allan.blocks.group_means`: the same means, bit for bit).
    """
    arr = np.asarray(x, dtype=np.float64)
    if block <= 1:
        return arr
    if blocks.is_mapped(arr):
        return blocks.group_means(arr, block, arr.shape[0] // block)
    n = (arr.shape[0] // block) * block
    return np.asarray(arr[:n].reshape(n // block, block, *arr.shape[1:]).mean(axis=1),
                      dtype=np.float64)


def reconcile_grid(
    n_samples: int, *, points_per_octave: int = 4, min_clusters: int = 4
) -> NDArray[np.int64]:
    """Averaging factors of the comparison: ``points_per_octave`` per octave, ``m <= N /
    min_clusters``.

    Raises
    ------
    ReconcileError
        If the record is too short for a grid of at least 8 taus.
    """
    m = log_m(n_samples, ratio=2.0 ** (1.0 / points_per_octave), min_clusters=min_clusters)
    if m.size < 8:
        raise ReconcileError(
            f"{n_samples} samples give only {m.size} averaging times; record at least "
            f"{8 * min_clusters * 4} samples"
        )
    return m


def allan_on_grid(
    rate: ArrayLike, sample_rate_hz: float, m: NDArray[np.int64]
) -> NDArray[np.float64]:
    """Overlapping Allan variance (Zhang 2015 eq. 5) of each column at factors ``m``, (n_tau, k).

    Only the sums: no edf, no interval (see :func:`analysis.allan.overlapping_allan_variance`).
    """
    fs = check_sample_rate(sample_rate_hz)
    theta = cumulative_angle(rate, fs)
    n = theta.shape[0] - 1
    sums = overlapping_sums(theta, m)
    tau = m / fs
    return np.asarray(sums / (2.0 * tau[:, None] ** 2 * (n + 1 - 2 * m)[:, None]), dtype=np.float64)


@dataclass(frozen=True)
class LogPrecision:
    """Per-tau law of ``log(a/A)`` under a model (G1): edf, mean offset, variance, weight."""

    edf: NDArray[np.float64]
    offset: NDArray[np.float64]
    variance: NDArray[np.float64]
    share: NDArray[np.float64]

    @property
    def weight(self) -> NDArray[np.float64]:
        """Weight of a squared log residual in the fit: ``s_i / v_i``."""
        return self.share / self.variance


def log_precision(avar: NDArray[np.float64], m: NDArray[np.int64], n_samples: int,
                  tau_s: NDArray[np.float64], *, floor: float = MODEL_FLOOR) -> LogPrecision:
    """edf of each tau for the noise type a curve shows (its local slope), and the G1 constants."""
    from scipy import special
    alpha = local_noise_alpha(m, np.maximum(avar, np.finfo(float).tiny), n_samples)
    edf = allan_edf_grid(n_samples, m, alpha[:, None], overlapping=True)[:, 0]
    half = edf / 2.0
    return LogPrecision(edf=edf, offset=special.digamma(half) - np.log(half),
                        variance=special.polygamma(1, half) + floor**2, share=log_tau_share(tau_s))


@dataclass(frozen=True)
class MeasuredCurve:
    """The measured record as the comparison sees it (after any decimation).

    Attributes
    ----------
    rate_deg_s : ndarray, shape (n,)
        Rate in deg/s at ``sample_rate_hz``.
    sample_rate_hz : float
        Sample rate in Hz after decimation.
    m : ndarray of int
        Averaging factors of the grid.
    tau_s : ndarray
        Averaging times in s.
    avar : ndarray
        Overlapping Allan variance in (deg/s)^2.
    precision : LogPrecision
        edf of each tau (for the noise type the measured curve shows) and the G1 constants;
        the same for every model compared with this curve, so that gaps compare.
    decimation : int
        Samples of the original record per sample here.
    temperature_c : ndarray or None
        Temperature in degC per sample, decimated like the rate; None also when the channel
        is constant (it says nothing of a temperature sensitivity).
    """

    rate_deg_s: NDArray[np.float64]
    sample_rate_hz: float
    m: NDArray[np.int64]
    tau_s: NDArray[np.float64]
    avar: NDArray[np.float64]
    precision: LogPrecision
    decimation: int = 1
    temperature_c: NDArray[np.float64] | None = None

    @property
    def n_samples(self) -> int:
        """Samples in the (decimated) record."""
        return int(self.rate_deg_s.shape[0])

    @property
    def duration_s(self) -> float:
        """Record length in s."""
        return self.n_samples / self.sample_rate_hz


def measure_curve(
    rate_deg_s: ArrayLike, sample_rate_hz: float, *, temperature_c: ArrayLike | None = None,
    max_samples: int = 1 << 20, points_per_octave: int = 4, min_clusters: int = 4,
    floor: float = MODEL_FLOOR,
) -> MeasuredCurve:
    """Decimate (if longer than ``max_samples``) and take the Allan variance on the comparison grid.

    Raises
    ------
    ReconcileError
        A rate that is not one axis, a temperature channel of another length, or a record
        too short for the grid.
    """
    fs = check_sample_rate(sample_rate_hz)
    rate = np.asarray(rate_deg_s, dtype=np.float64)
    if rate.ndim == 2 and rate.shape[1] == 1:
        rate = rate[:, 0]
    if rate.ndim != 1:
        raise ReconcileError(f"reconcile one axis at a time; got a rate of shape {rate.shape}")
    temp = None
    if temperature_c is not None:
        temp = np.asarray(temperature_c, dtype=np.float64).reshape(-1)
        if temp.shape[0] != rate.shape[0]:
            raise ReconcileError(
                f"temperature has {temp.shape[0]} samples, the rate {rate.shape[0]}"
            )
    d = max(1, math.ceil(rate.shape[0] / max_samples))
    rate = block_means(rate, d)
    temp = None if temp is None else block_means(temp, d)
    if temp is not None and not np.ptp(temp) > 0:  # constant (or NaN): no slope to regress on
        temp = None
    fs_d = fs / d
    m = reconcile_grid(
        rate.shape[0], points_per_octave=points_per_octave, min_clusters=min_clusters
    )
    avar = allan_on_grid(rate, fs_d, m)[:, 0]
    tau = m / fs_d
    precision = log_precision(avar, m, rate.shape[0], tau, floor=floor)
    return MeasuredCurve(rate, fs_d, m, tau, avar, precision, d, temp)


# -------------------------------------------------------------------------- statistic


def standardized_log_ratio(
    avar: ArrayLike, model_avar: ArrayLike, precision: LogPrecision
) -> NDArray[np.float64]:
    """z of eq. G1 for each tau (and each column of ``avar`` when 2-D)."""
    a = np.asarray(avar, dtype=np.float64)
    model = np.maximum(np.asarray(model_avar, dtype=np.float64), np.finfo(float).tiny)
    offset, scale = precision.offset, np.sqrt(precision.variance)
    if a.ndim == 2:
        offset, scale, model = offset[:, None], scale[:, None], model[:, None]
    return (np.log(np.maximum(a, np.finfo(float).tiny)) - offset - np.log(model)) / scale


def gap_statistic(z: ArrayLike, share: ArrayLike) -> NDArray[np.float64] | float:
    """G of eq. G2: octave-weighted mean of ``z^2`` (one value per column when 2-D)."""
    zz = np.asarray(z, dtype=np.float64)
    s = np.asarray(share, dtype=np.float64)
    if zz.ndim == 2:
        return np.asarray((s[:, None] * zz**2).sum(axis=0) / s.sum(), dtype=np.float64)
    return float((s * zz**2).sum() / s.sum())


@dataclass(frozen=True)
class GapNull:
    """Distribution of G under the model: the simulated values and a moment-matched chi-square.

    ``G ~ mean * chi2_h / h`` with ``h = 2 mean^2 / var`` (Satterthwaite).
    """

    values: NDArray[np.float64]

    @property
    def mean(self) -> float:
        """Mean of the simulated G values."""
        return float(np.mean(self.values))

    @property
    def std(self) -> float:
        """Standard deviation (ddof=1) of the simulated G values."""
        return float(np.std(self.values, ddof=1))

    @property
    def dof(self) -> float:
        """h of the matched chi-square."""
        return 2.0 * self.mean**2 / max(self.std**2, 1e-300)

    def p_value(self, gap: float) -> float:
        """Probability of a gap at least ``gap`` if the model is right."""
        h = self.dof
        return float(chi2_sf(h * gap / self.mean, h))

    def quantile(self, q: float) -> float:
        """The ``q`` quantile of the matched chi-square."""
        h = self.dof
        return float(self.mean * chi2_ppf(q, h) / h)


@dataclass(frozen=True)
class MonteCarloBand:
    """Simulated runs of a model on the measured record's length, rate and tau grid.

    Attributes
    ----------
    avar : ndarray, shape (n_tau, runs)
        Allan variance of each run in (deg/s)^2.
    low, high, centre : ndarray
        Per-tau band (``BAND_LEVEL``) and geometric mean of the simulated Allan variance,
        (deg/s)^2.
    trend_slopes : ndarray
        Least-squares slope (deg/s^2) of each run's rate against time.
    temperature_slopes : ndarray or None
        Slope (deg/s per degC) of each run's rate against the *measured* temperature.
    runs, seed : int
        Number of runs and the seed they came from.
    """

    avar: NDArray[np.float64]
    low: NDArray[np.float64]
    high: NDArray[np.float64]
    centre: NDArray[np.float64]
    trend_slopes: NDArray[np.float64]
    temperature_slopes: NDArray[np.float64] | None
    runs: int
    seed: int


def regression_slopes(y: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least-squares slope of each column of ``y`` (n, k) on ``x`` (n,), with an intercept."""
    xc = x - x.mean()
    return np.asarray((xc @ (y - y.mean(axis=0))) / float(xc @ xc), dtype=np.float64)


def _simulated_runs(model: NoiseModel, n: int, fs: float, k: int, seed: int,
                    cache: ComparisonCache | None) -> NDArray[np.float64]:
    """``k`` runs (n, k) of the model: one simulator call, or the sum of cached term runs.

    The simulator draws each term from a generator keyed by the seed and the term's name,
    so the runs of a model are exactly the sums of the runs of its terms alone with the
    same seed; with a cache (and ``n k <= TERM_CACHE_VALUES``) each term is simulated once
    and a model that differs by one added term costs only that term.
    """
    if not model.terms:
        return np.zeros((n, k))
    if cache is None or n * k > TERM_CACHE_VALUES:
        return simulate(model, n / fs, fs, n_axes=k, seed=seed).rate_deg_s
    total = np.zeros((n, k))
    for term in model.terms:
        total += cache.get(
            ("term-runs", term, n, fs, k, seed),
            lambda term=term: (
                simulate(NoiseModel(terms=(term,)), n / fs, fs, n_axes=k, seed=seed).rate_deg_s
            ),
        )
    return total


def monte_carlo_band(model: NoiseModel, curve: MeasuredCurve, *, runs: int = 20, seed: int = 0,
                     known: NDArray[np.float64] | None = None,
                     cache: ComparisonCache | None = None) -> MonteCarloBand:
    """Simulate ``runs`` records of the model like the measured one and summarize them.

    Each batch is one :func:`analysis.models.simulation.simulate` call with the runs as axes (or
    the sum of cached runs of each term, see :func:`_simulated_runs`); run seeds come
    from ``numpy.random.SeedSequence(seed)``. ``known`` (deg/s, one value per sample) is
    added to every run: effects located in the time series (bias steps) enter as the
    realization that was found, not as a random draw.
    """
    if runs < 4:
        raise ReconcileError(f"the Monte Carlo band needs at least 4 runs, got {runs}")
    n, fs = curve.n_samples, curve.sample_rate_hz
    per_batch = max(1, min(runs, BATCH_SAMPLES // n))
    seeds = np.random.SeedSequence(seed).generate_state(
        math.ceil(runs / per_batch), dtype=np.uint64
    )
    t = np.arange(n) / fs
    avars, trends, temps = [], [], []
    done = 0
    for batch_seed in seeds:
        k = min(per_batch, runs - done)
        rate = _simulated_runs(model, n, fs, k, int(batch_seed), cache)
        if known is not None:
            rate = rate + known[:, None]
        avars.append(allan_on_grid(rate, fs, curve.m))
        trends.append(regression_slopes(rate, t))
        if curve.temperature_c is not None:
            temps.append(regression_slopes(rate, curve.temperature_c))
        done += k
    a = np.concatenate(avars, axis=1)
    loga = np.log(np.maximum(a, np.finfo(float).tiny))
    mu, sd = loga.mean(axis=1), loga.std(axis=1, ddof=1)
    k95 = normal_ppf(0.5 + BAND_LEVEL / 2)
    return MonteCarloBand(
        avar=a, low=np.exp(mu - k95 * sd), high=np.exp(mu + k95 * sd), centre=np.exp(mu),
        trend_slopes=np.concatenate(trends),
        temperature_slopes=np.concatenate(temps) if temps else None,
        runs=runs, seed=seed,
    )


def ranges_outside(tau_s: NDArray[np.float64], avar: NDArray[np.float64], low: NDArray[np.float64],
                   high: NDArray[np.float64]) -> tuple[tuple[float, float, str], ...]:
    """Contiguous tau ranges where ``avar`` leaves ``[low, high]``: (lo_s, hi_s,
    "above"|"below")."""
    side = np.where(avar > high, 1, np.where(avar < low, -1, 0))
    out = []
    i = 0
    while i < len(side):
        if side[i] == 0:
            i += 1
            continue
        j = i
        while j + 1 < len(side) and side[j + 1] == side[i]:
            j += 1
        out.append((float(tau_s[i]), float(tau_s[j]), "above" if side[i] > 0 else "below"))
        i = j + 1
    return tuple(out)


# ------------------------------------------------------------------------- comparison


@dataclass(frozen=True)
class Comparison:
    """A model compared with the measured curve (step 1 of reconcile).

    Attributes
    ----------
    model : NoiseModel
    model_avar : ndarray
        Theoretical Allan variance in (deg/s)^2 on the grid (for the record's length).
    z : ndarray
        Standardized log-ratio per tau (G1).
    gap : float
        G (G2).
    p_value : float
        Probability of a gap this large if the model is right (simulated null).
    band : MonteCarloBand
    gap_null : GapNull
        G of each simulated run against the model.
    outside : tuple
        Tau ranges where the measured curve leaves the band.
    """

    model: NoiseModel
    model_avar: NDArray[np.float64]
    z: NDArray[np.float64]
    gap: float
    p_value: float
    band: MonteCarloBand
    gap_null: GapNull
    outside: tuple[tuple[float, float, str], ...]

    def significant(self, alpha: float) -> bool:
        """Whether the gap is significant at level ``alpha``."""
        return self.p_value < alpha


@dataclass
class ComparisonCache:
    """Memo of the model-dependent parts of a comparison (edf, Monte Carlo band), passed in
    explicitly so that repeated comparisons of one model on records of the same length
    (seeds of a test, axes of a run) simulate the model once."""

    entries: dict[Any, Any] = field(default_factory=dict)

    def get(self, key: Any, make: Any) -> Any:
        """The cached value of ``key``, made by ``make()`` the first time."""
        if key not in self.entries:
            self.entries[key] = make()
        return self.entries[key]


def compare(
    curve: MeasuredCurve, model: NoiseModel, *, runs: int = 20, seed: int = 0,
    cache: ComparisonCache | None = None, known: Mapping[str, NDArray[np.float64]] | None = None,
) -> Comparison:
    """Compare a model with the measured curve: theory, G, its simulated null and the band.

    ``known`` maps term names of the model to their realization located in the record
    (rate in deg/s per sample, e.g. the steps the change-point test found): those terms
    enter the theoretical curve as the Allan variance of that realization, and every
    simulated run carries it, i.e. the comparison is conditional on the located events.

    Raises
    ------
    ReconcileError
        If the model has no Allan variance on the grid (no stochastic term).
    """
    cache = cache if cache is not None else ComparisonCache()
    realized = {k: v for k, v in (known or {}).items() if k in model}
    random_part = model
    known_rate = None
    for name in realized:
        random_part = random_part.without_term(name)
    model_avar = random_part.avar(curve.tau_s, duration_s=curve.duration_s)
    if realized:
        known_rate = np.sum(list(realized.values()), axis=0)
        model_avar = model_avar + allan_on_grid(known_rate, curve.sample_rate_hz, curve.m)[:, 0]
    if not np.all(model_avar > 0):
        raise ReconcileError(
            "the model has no Allan variance at some taus; give it a noise term (e.g. [arw])"
        )
    temp_key = None if curve.temperature_c is None else hash(curve.temperature_c.tobytes())
    known_key = None if known_rate is None else hash(known_rate.tobytes())
    key = (
        random_part,
        curve.n_samples,
        curve.sample_rate_hz,
        curve.m.tobytes(),
        runs,
        seed,
        temp_key,
        known_key,
    )
    band = cache.get(
        key,
        lambda: monte_carlo_band(
            random_part, curve, runs=runs, seed=seed, known=known_rate, cache=cache
        ),
    )
    precision = curve.precision
    z = standardized_log_ratio(curve.avar, model_avar, precision)
    gap = float(gap_statistic(z, precision.share))
    null = GapNull(
        np.asarray(
            gap_statistic(standardized_log_ratio(band.avar, model_avar, precision), precision.share)
        )
    )
    return Comparison(model=model, model_avar=model_avar, z=z, gap=gap,
                      p_value=null.p_value(gap), band=band, gap_null=null,
                      outside=ranges_outside(curve.tau_s, curve.avar, band.low, band.high))
