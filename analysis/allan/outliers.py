"""Isolated spikes in a rate record: a robust detector, the removal rule, and the repair.

Detector: two residuals of each sample, both zero for a smooth record,

* ``r_lin = x[k] - (x[k-1] + x[k+1]) / 2``, a linear filter, so for any Gaussian noise
  (white, flicker, random walk, quantization) it is exactly Gaussian and the threshold
  below holds its false-alarm rate whatever the noise type;
* ``r_med = x[k] - median(x[k-w..k+w] without x[k])``, which a spike does not pull along
  (the median of its neighbours ignores it) and which stays large across a short burst.

Each is scaled by its median absolute deviation times 1.4826 (a normal variable's
standard deviation; half the samples can be spikes before it moves), never below the
record's resolution (a quantized output whose residuals are mostly zero would otherwise
have a zero scale). A sample is a spike where both residuals exceed ``t`` scales with the
same sign (a spike's innocent neighbours have a large ``r_lin`` of the other sign and a
small ``r_med``), and a spike extends to the adjacent samples whose ``r_med`` exceeds
``t`` scales with that sign (the inside of a burst). ``t`` is chosen so that a clean
Gaussian record of N samples shows a false spike with probability ``false_alarm``
(Bonferroni over the N samples: ``t = Phi^-1(1 - false_alarm / (2 N))``, 5.73 for
N = 1e6 at 1 %). The median residual alone is not calibrated: on a record whose
sample-to-sample change is a pure rate random walk its tails are heavy (about 50 times
the Gaussian rate of 5-sigma excursions), the linear one is.

Rule: the spikes are removed when they are few and isolated: at most
:data:`MAX_REMOVED_SHARE` of the samples, in runs of at most :data:`MAX_SPIKE_SAMPLES`
consecutive samples. More than that is not a handful of glitches but the noise itself
(heavy tails, bursts): it is reported and kept, since removing it would bias every figure.

Repair: a removed sample is replaced by the straight line between the nearest kept
samples on either side (the angle is interpolated across it), not turned into a gap.
A gap would cost every Allan difference that straddles it, 2m - 1 per spike at each
averaging factor m, so ten spikes spread evenly over a record leave no difference at all
beyond a twentieth of its length (the MTi-G record's 286 spikes, turned into gaps, would
leave no difference beyond tau = 59 s of its 5000 s, and half its stretches none
beyond 6 s).
The line puts back a value of the order of one sample's noise where the spike was: its
bias on the Allan variance is of the order of the share of samples replaced (at most
0.1 % under the rule) and its scatter a small part of the confidence interval (20 spikes
of 20-40 sigma in 50 000 samples: the repaired curve stays within 0.14 of the clean
record's 1-sigma half-width at every tau, where the curve with the spikes left in is
57-67 half-widths off; ``tests/test_outliers.py``).

Detection limit (white noise, ``false_alarm`` 1 %, records of 20 000 samples, measured
by ``benchmarks/bench_records.py``): a one-sample spike is found with probability 0.41
at 6 sigma, 0.94 at 8 and 1 from 10 sigma; a two-sample one (whose linear residual is
halved) 0.29 at 10, 0.72 at 12 and 1 from 14 sigma.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

import analysis.allan.blocks as blocks
from analysis.distributions import normal_isf

#: Probability that a clean Gaussian record shows one false spike (any length).
FALSE_ALARM = 0.01
#: Neighbours each side in the running median.
HALF_WINDOW = 8
#: Spikes are removed only when at most this share of the samples is flagged ...
MAX_REMOVED_SHARE = 1e-3
#: ... and no run of consecutive flagged samples is longer than this.
MAX_SPIKE_SAMPLES = 3
#: Samples at which the median residual's scale is estimated.
SCALE_SAMPLES = 100_000
#: MAD of a standard normal variable times this is its standard deviation.
MAD_TO_SIGMA = 1.482602218505602


@dataclass(frozen=True)
class Spike:
    """One run of consecutive flagged samples.

    Attributes
    ----------
    index : int
        Position of its first sample in the analysed samples.
    n_samples : int
        Consecutive samples flagged.
    size : float
        The largest residual of the run (sample minus the median of its neighbours), with
        its sign, in the input unit (e.g. deg/s).
    z : float
        ``size`` in scales of that residual (the threshold is ``threshold_z``).
    """

    index: int
    n_samples: int
    size: float
    z: float


@dataclass(frozen=True)
class SpikeDetection:
    """What :func:`detect_spikes` found in one record.

    Attributes
    ----------
    flagged : ndarray of int, shape (n_flagged,)
        Index of each flagged sample, increasing (:attr:`flags` is the mask).
    spikes : tuple of Spike
        The runs of flagged samples, in time order.
    scale : float
        Scale of the median residual (input unit), the one spike sizes are given in:
        1.4826 MAD, or the record's resolution if larger.
    scale_linear : float
        Scale of the linear residual (input unit), likewise.
    threshold_z : float
        Residuals beyond ``threshold_z * scale`` are flagged.
    false_alarm : float
        The false-alarm probability the threshold was set for.
    n_samples : int
        Samples examined.
    """

    flagged: NDArray[np.int64]
    spikes: tuple[Spike, ...]
    scale: float
    scale_linear: float
    threshold_z: float
    false_alarm: float
    n_samples: int

    @property
    def flags(self) -> NDArray[np.bool_]:
        """True at each flagged sample, shape (N,) (built on each call: a long record's mask
        is as long as the record)."""
        mask = np.zeros(self.n_samples, dtype=bool)
        mask[self.flagged] = True
        return mask

    @property
    def count(self) -> int:
        """Samples flagged."""
        return len(self.flagged)

    @property
    def share(self) -> float:
        """Fraction of the samples flagged."""
        return self.count / self.n_samples if self.n_samples else 0.0

    @property
    def longest_run(self) -> int:
        """Longest run of consecutive flagged samples (0 when none)."""
        return max((s.n_samples for s in self.spikes), default=0)

    @property
    def removable(self) -> bool:
        """Few and isolated enough to remove (see the module docstring for the rule)."""
        return (0 < self.count <= MAX_REMOVED_SHARE * self.n_samples
                and self.longest_run <= MAX_SPIKE_SAMPLES)

    def rule_text(self) -> str:
        """Why the spikes can be removed or must be kept (a clause for a report)."""
        if self.count == 0:
            return "no spikes"
        if self.removable:
            return (f"few and isolated (at most {MAX_REMOVED_SHARE:.1%} of the samples, runs of "
                    f"at most {MAX_SPIKE_SAMPLES})")
        if self.count > MAX_REMOVED_SHARE * self.n_samples:
            return (
                f"{self.share:.2%} of the samples are beyond the threshold (more than "
                f"{MAX_REMOVED_SHARE:.1%}): the record's own heavy-tailed noise, not isolated "
                "spikes"
            )
        return (
            f"runs of up to {self.longest_run} samples (more than {MAX_SPIKE_SAMPLES}): bursts, "
            f"not isolated spikes"
        )


def min_samples(half_window: int = HALF_WINDOW) -> int:
    """Fewest samples :func:`detect_spikes` looks for spikes in (one full neighbourhood)."""
    return 2 * half_window + 1


def spike_threshold(n_samples: int, false_alarm: float = FALSE_ALARM) -> float:
    """Residual threshold, in scales, for a false-alarm probability over ``n_samples``."""
    if not 0 < false_alarm < 1:
        raise ValueError(f"false_alarm must be in (0, 1), got {false_alarm}")
    return float(normal_isf(false_alarm / (2.0 * max(n_samples, 1))))


def resolution(x: NDArray[np.float64]) -> float:
    """Smallest step between distinct values of a record (its quantum if quantized)."""
    values = np.unique(x)
    if len(values) < 2:
        return 0.0
    return float(np.min(np.diff(values)))


def _robust_scale(r: NDArray[np.float64]) -> float:
    return MAD_TO_SIGMA * float(np.median(np.abs(r - np.median(r))))


def neighbour_residuals(x: NDArray[np.float64], positions: NDArray[np.int64] | None = None,
                        half_window: int = HALF_WINDOW) -> NDArray[np.float64]:
    """Each sample minus the median of its ``2 * half_window`` neighbours (itself left out).

    Only at ``positions`` when given (the detector needs it at a sample of positions and
    next to candidate spikes, not everywhere); the record is mirrored at its ends.
    """
    w, n = half_window, len(x)
    at = np.arange(n) if positions is None else np.asarray(positions, dtype=np.int64)
    # the neighbours gathered by index, mirrored at the ends as np.pad's "symmetric" mode
    # (x[-1 - k] before the start, x[n - 1 - k] after the end; w < n): the values and their
    # order of a padded sliding window, without copying the record for every call (the
    # burst growth calls this once a sample)
    offsets = np.concatenate((np.arange(-w, 0), np.arange(1, w + 1)))
    index = at[:, None] + offsets[None, :]
    index = np.where(index < 0, -1 - index, index)
    index = np.where(index >= n, 2 * n - 1 - index, index)
    return x[at] - _row_medians(x[index])


def _row_medians(neighbours: NDArray[np.float64]) -> NDArray[np.float64]:
    """Median of each row of an even number of values: the mean of the middle two of the
    sorted row, as ``np.median(neighbours, axis=1)`` takes it (bit for bit), 5-7x faster
    than its partition on rows this short."""
    w = neighbours.shape[1] // 2
    ordered = np.sort(neighbours, axis=1)
    return (ordered[:, w - 1] + ordered[:, w]) / 2.0


def _grow(
    seeds: NDArray[np.int64],
    x: NDArray[np.float64],
    signs: NDArray[np.float64],
    limit: float,
    half_window: int,
) -> NDArray[np.bool_]:
    """Flags: the seeds, extended to adjacent samples whose median residual exceeds ``limit``
    with the seed's sign (the inside of a burst)."""
    flags = np.zeros(len(x), dtype=bool)
    flags[seeds] = True
    for k, sign in zip(seeds, signs, strict=True):
        for step in (-1, 1):
            j = int(k) + step
            while 0 <= j < len(x) and not flags[j]:
                r = float(neighbour_residuals(x, np.array([j]), half_window)[0])
                if sign * r <= limit:
                    break
                flags[j] = True
                j += step
    return flags


def detect_spikes(
    samples: ArrayLike, *, false_alarm: float = FALSE_ALARM, half_window: int = HALF_WINDOW
) -> SpikeDetection:
    """Find isolated spikes in a 1-D rate record (see the module docstring).

    Parameters
    ----------
    samples : array_like, shape (N,)
        Rate samples (e.g. deg/s), finite, in time order (samples missing in gaps left out).
    false_alarm : float
        Probability that a clean Gaussian record of N samples shows a spike.
    half_window : int
        Neighbours each side in the running median.

    Returns
    -------
    SpikeDetection

    Raises
    ------
    ValueError
        Not 1-D, non-finite samples, or fewer than ``2 * half_window + 1`` samples.
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 1:
        raise ValueError(f"samples must be 1-D, got shape {x.shape}")
    if (blocks.first_non_finite(x) >= 0) if blocks.is_long(len(x)) else not np.isfinite(x).all():
        raise ValueError("samples must be finite (leave missing samples out)")
    if len(x) < min_samples(half_window):
        raise ValueError(
            f"{len(x)} samples are too few to look for spikes (need {min_samples(half_window)})"
        )
    if blocks.is_long(len(x)):
        return _detect_long(x, false_alarm, half_window)
    lin = np.empty_like(x)
    lin[1:-1] = x[1:-1] - 0.5 * (x[:-2] + x[2:])
    lin[0], lin[-1] = x[0] - x[1], x[-1] - x[-2]
    quantum = resolution(x)
    threshold = spike_threshold(len(x), false_alarm)
    scale = max(_robust_scale(lin), quantum)
    # the median residual's scale from an even sample of the record (its MAD to ~0.5 %)
    sampled = np.arange(0, len(x), max(1, len(x) // SCALE_SAMPLES))
    scale_med = max(_robust_scale(neighbour_residuals(x, sampled, half_window)), quantum)
    if scale == 0.0 or scale_med == 0.0:  # a constant record has no spike
        flags = np.zeros(len(x), dtype=bool)
    else:
        candidates = np.flatnonzero(np.abs(lin) > threshold * scale)
        med_at = neighbour_residuals(x, candidates, half_window)
        seed = (np.abs(med_at) > threshold * scale_med) & (
            np.sign(med_at) == np.sign(lin[candidates])
        )
        flags = _grow(
            candidates[seed], x, np.sign(med_at[seed]), threshold * scale_med, half_window
        )
    starts = np.flatnonzero(flags & ~np.concatenate(([False], flags[:-1])))
    stops = np.flatnonzero(flags & ~np.concatenate((flags[1:], [False]))) + 1
    med = neighbour_residuals(x, np.flatnonzero(flags), half_window)
    spikes, done = [], 0
    for a, b in zip(starts.tolist(), stops.tolist(), strict=True):
        run = med[done:done + b - a]
        done += b - a
        j = int(np.argmax(np.abs(run)))
        spikes.append(Spike(int(a), int(b - a), float(run[j]), float(run[j] / scale_med)))
    return SpikeDetection(np.flatnonzero(flags), tuple(spikes), scale_med, scale, threshold,
                          false_alarm, len(x))


def replace_spikes(samples: ArrayLike, flags: ArrayLike, positions: ArrayLike | None = None
                   ) -> NDArray[np.float64]:
    """Samples with each flagged one replaced by the line between its nearest kept neighbours.

    Parameters
    ----------
    samples : array_like, shape (N,)
        Rate samples.
    flags : array_like of bool, shape (N,)
        True where a sample is replaced.
    positions : array_like, shape (N,), optional
        Time (or grid index) of each sample, for records with gaps; default ``0 .. N - 1``.

    Returns
    -------
    ndarray, shape (N,)
        A copy; a flagged sample at either end takes the nearest kept value.
    """
    x = np.array(samples, dtype=np.float64)
    f = np.asarray(flags, dtype=bool)
    if not f.any():
        return x
    if f.all():
        raise ValueError("every sample is flagged: nothing to interpolate from")
    t = np.arange(len(x), dtype=float) if positions is None else np.asarray(positions, dtype=float)
    x[f] = np.interp(t[f], t[~f], x[~f])
    return x


# ------------------------------------------------------------------ long records, in blocks


def _linear_residuals(x: NDArray[np.float64], a: int, b: int) -> NDArray[np.float64]:
    """``r_lin`` of samples ``a .. b - 1`` (the detector's linear residual), from one block."""
    n = len(x)
    lo = max(a - 1, 0)
    v = np.asarray(x[lo:min(b + 1, n)], dtype=np.float64)
    out = np.empty(b - a)
    i0, i1 = max(a, 1), min(b, n - 1)  # samples with a neighbour on each side
    if i1 > i0:
        out[i0 - a: i1 - a] = v[i0 - lo: i1 - lo] - 0.5 * (v[i0 - lo - 1: i1 - lo - 1]
                                                           + v[i0 - lo + 1: i1 - lo + 1])
    if a == 0:
        out[0] = v[0] - v[1]
    if b == n:
        out[-1] = v[-1] - v[-2]
    blocks.release(x)
    return out


def _neighbour_residuals_long(x: NDArray[np.float64], positions: NDArray[np.int64],
                              half_window: int) -> NDArray[np.float64]:
    """:func:`neighbour_residuals` at increasing ``positions`` of a long record, a block of
    the record at a time (mirrored at its ends as there)."""
    w, n = half_window, len(x)
    out = np.empty(len(positions))
    for a, b in blocks.spans(0, n):
        i0, i1 = np.searchsorted(positions, [a, b])
        if i0 == i1:
            continue
        lo, hi = max(a - w, 0), min(b + w, n)
        local = np.pad(np.asarray(x[lo:hi], dtype=np.float64),
                       (w if lo == 0 else 0, w if hi == n else 0), mode="symmetric")
        shift = lo - (w if lo == 0 else 0)  # record index of local[0]
        at = positions[i0:i1] - shift
        windows = np.lib.stride_tricks.sliding_window_view(local, 2 * w + 1)[at - w]
        neighbours = np.concatenate((windows[:, :w], windows[:, w + 1:]), axis=1)
        out[i0:i1] = local[at] - _row_medians(neighbours)
        blocks.release(x)
    return out


def _resolution_long(x: NDArray[np.float64], cap: int = 1 << 16) -> float:
    """:func:`resolution` of a long record: exact while its distinct values number at most
    ``cap`` (a quantized record); beyond, the smallest step inside a block, an upper
    bound of the true one that only matters when larger than the noise scale it floors
    (it is not: a record with that many distinct values is not quantized coarsely)."""
    values: NDArray[np.float64] | None = np.zeros(0)
    bound = np.inf
    for a, b in blocks.spans(0, len(x)):
        u = np.unique(np.asarray(x[a:b]))
        if len(u) > 1:
            bound = min(bound, float(np.min(np.diff(u))))
        if values is not None:
            values = np.union1d(values, u)
            if len(values) > cap:
                values = None
        blocks.release(x)
    if values is not None:
        return float(np.min(np.diff(values))) if len(values) > 1 else 0.0
    return bound


def _grow_sparse(seeds: NDArray[np.int64], x: NDArray[np.float64], signs: NDArray[np.float64],
                 limit: float, half_window: int) -> NDArray[np.int64]:
    """:func:`_grow` of a long record, flags kept as a set of indices."""
    flagged = {int(k) for k in seeds}
    for k, sign in zip(seeds, signs, strict=True):
        for step in (-1, 1):
            j = int(k) + step
            while 0 <= j < len(x) and j not in flagged:
                r = float(_neighbour_residuals_long(x, np.array([j]), half_window)[0])
                if sign * r <= limit:
                    break
                flagged.add(j)
                j += step
    return np.array(sorted(flagged), dtype=np.int64)


def _detect_long(x: NDArray[np.float64], false_alarm: float, half_window: int) -> SpikeDetection:
    """:func:`detect_spikes` of a long record (a memmap), a block at a time: the same
    residuals, medians and thresholds, never a temporary as long as the record."""
    n = len(x)

    def lin(a: int, b: int) -> NDArray[np.float64]:
        return _linear_residuals(x, a, b)

    quantum = _resolution_long(x)
    threshold = spike_threshold(n, false_alarm)
    centre = blocks.median(lin, n)
    scale = max(MAD_TO_SIGMA * blocks.median(lambda a, b: np.abs(lin(a, b) - centre), n), quantum)
    sampled = np.arange(0, n, max(1, n // SCALE_SAMPLES))
    scale_med = max(_robust_scale(_neighbour_residuals_long(x, sampled, half_window)), quantum)
    flagged = np.zeros(0, dtype=np.int64)
    if scale > 0.0 and scale_med > 0.0:  # a constant record has no spike
        found = [np.flatnonzero(np.abs(lin(a, b)) > threshold * scale) + a
                 for a, b in blocks.spans(0, n)]
        blocks.release(x)
        candidates = np.concatenate(found)
        med_at = _neighbour_residuals_long(x, candidates, half_window)
        lin_at = np.array([lin(int(c), int(c) + 1)[0] for c in candidates])
        seed = (np.abs(med_at) > threshold * scale_med) & (np.sign(med_at) == np.sign(lin_at))
        flagged = _grow_sparse(candidates[seed], x, np.sign(med_at[seed]), threshold * scale_med,
                               half_window)
    breaks = np.flatnonzero(np.diff(flagged) != 1) + 1
    none = np.zeros(0, dtype=np.int64)
    starts = np.concatenate(([0], breaks)) if len(flagged) else none
    stops = np.concatenate((breaks, [len(flagged)])) if len(flagged) else none
    med = _neighbour_residuals_long(x, flagged, half_window)
    spikes = []
    for a, b in zip(starts, stops, strict=True):
        run = med[a:b]
        j = int(np.argmax(np.abs(run)))
        spikes.append(Spike(int(flagged[a]), int(b - a), float(run[j]), float(run[j] / scale_med)))
    return SpikeDetection(flagged, tuple(spikes), scale_med, scale, threshold, false_alarm, n)


def replace_flagged(samples: NDArray[np.float64], flagged: NDArray[np.int64],
                    positions: NDArray[np.int64] | None = None, *,
                    out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """:func:`replace_spikes` with the flagged samples given by index, written into ``out``
    (e.g. a memmap) a block at a time: each run of flagged samples takes the line between
    its two kept neighbours, the values :func:`replace_spikes` gives.

    Raises
    ------
    ValueError
        Every sample flagged.
    """
    n = len(samples)
    flagged = np.asarray(flagged, dtype=np.int64)
    if len(flagged) >= n:
        raise ValueError("every sample is flagged: nothing to interpolate from")
    result = np.empty(n) if out is None else out
    for a, b in blocks.spans(0, n):
        result[a:b] = samples[a:b]
        blocks.release(samples)
        blocks.release(result)
    if not len(flagged):
        return result
    breaks = np.flatnonzero(np.diff(flagged) != 1) + 1
    for run in np.split(flagged, breaks):
        left, right = int(run[0]) - 1, int(run[-1]) + 1
        kept = [i for i in (left, right) if 0 <= i < n]
        t_kept = np.array([float(i if positions is None else positions[i]) for i in kept])
        t_run = run.astype(float) if positions is None else np.asarray(positions[run], dtype=float)
        result[run] = np.interp(t_run, t_kept, np.array([float(samples[i]) for i in kept]))
    return result
