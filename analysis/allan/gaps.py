"""Allan variance of records with gaps: missing samples are NaN, nothing straddles a gap.

A record whose device dropped samples (an outage, lost frames) holds gap-free stretches
separated by gaps of known length. Concatenating the stretches, as if no time had passed,
joins two unrelated angles (the angle across a rate gap is unknown) and puts a step into
any drift: a rate ramp, a sinusoid or a bias walk then inflate the Allan variance at
every tau whose differences cross the seam. Here the record is laid on its true time
grid with NaN where samples are missing, and

* overlapping estimator: only the second differences
  ``theta[n+2m] - 2 theta[n+m] + theta[n]`` whose ``2m`` samples all lie in one gap-free
  stretch are summed, and the sum is divided by their count (allantools' ``gradev``
  skips NaN differences of the phase the same way; on a rate record the whole stretch
  between gaps has to be skipped because the angle after a gap has an unknown offset);
* cluster estimator: clusters sit on the true time grid (``tau = m / fs`` of true time);
  a cluster with a missing sample is incomplete, and only differences of two adjacent
  complete clusters are summed.

The gap-free stretches are found once; each stretch's sum is a span of the fused kernel
of :mod:`analysis.allan.kernels`, so the cost stays one pass over the samples per tau.

Confidence: the differences of two stretches share no sample, so their sums are
(nearly, exactly for white rate noise) independent; the edf of the whole estimate is
``L^2 / sum_j (L_j^2 / edf_j)`` with ``L_j`` the differences of stretch j and ``edf_j``
its own edf (:func:`analysis.allan.confidence.allan_edf`): fewer and shorter stretches give
fewer degrees of freedom, never more.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

import analysis.allan.blocks as blocks
import analysis.allan.kernels as kernels
from analysis.allan.confidence import ONE_SIGMA, allan_edf, chi2_interval, local_noise_alpha
from analysis.allan.estimators import AllanResult, TauGrid, check_sample_rate, resolve_m
from analysis.allan.noise_id import identify_noise
from analysis.errors import NonFiniteSamplesError, TooFewSamplesError

#: At most this many distinct stretch lengths get an exact edf per (tau, noise type); the
#: others are interpolated in log-log (the edf of a stretch is smooth in its length).
EDF_LENGTH_POINTS = 24
#: At most this many taus get an exact edf; the rest are interpolated in log m.
EDF_TAU_POINTS = 64


@dataclass(frozen=True)
class GapSummary:
    """Where a record's samples are missing.

    Attributes
    ----------
    count : int
        Number of gaps (runs of consecutive missing samples inside the record).
    missing_samples : int
        Samples missing in total.
    span_samples : int
        Length of the record on its time grid, missing samples included.
    starts : ndarray of int
        Grid index of the first missing sample of each gap.
    lengths : ndarray of int
        Missing samples of each gap.
    """

    count: int
    missing_samples: int
    span_samples: int
    starts: NDArray[np.int64]
    lengths: NDArray[np.int64]

    @property
    def share(self) -> float:
        """Fraction of the record's time that is missing (0 .. 1)."""
        return self.missing_samples / self.span_samples if self.span_samples else 0.0


def valid_stretches(valid: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Start and stop (exclusive) grid indices of each run of True in a 1-D mask."""
    v = np.asarray(valid, dtype=bool).reshape(-1)
    edges = np.diff(np.concatenate(([False], v, [False])).astype(np.int8))
    return np.flatnonzero(edges == 1).astype(np.int64), np.flatnonzero(edges == -1).astype(np.int64)


def gap_summary(valid: ArrayLike) -> GapSummary:
    """Count the gaps of a record from its mask of present samples (True = present).

    Leading and trailing missing samples count as gaps too (a record cut to a time slice
    that starts inside an outage).
    """
    v = np.asarray(valid, dtype=bool).reshape(-1)
    starts, stops = valid_stretches(~v)
    return GapSummary(len(starts), int((~v).sum()), len(v), starts, stops - starts)


def gap_summary_of_index(sample_index: NDArray[np.int64]) -> GapSummary:
    """:func:`gap_summary` of a record given by the grid index of each present sample
    (increasing, from 0), read a block at a time: no mask as long as the record."""
    starts: list[NDArray[np.int64]] = []
    lengths: list[NDArray[np.int64]] = []
    previous = -1
    for a, b in blocks.spans(0, len(sample_index)):
        index = np.asarray(sample_index[a:b], dtype=np.int64)
        step = np.diff(np.concatenate(([previous], index)))
        where = np.flatnonzero(step > 1)
        starts.append(index[where] - step[where] + 1)
        lengths.append(step[where] - 1)
        previous = int(index[-1])
        blocks.release(sample_index)
    s = np.concatenate(starts) if starts else np.zeros(0, np.int64)
    n = np.concatenate(lengths) if lengths else np.zeros(0, np.int64)
    return GapSummary(len(s), int(n.sum()), previous + 1, s, n)


def _stretches_in_samples(valid: NDArray[np.bool_]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Gap-free stretches as (start, stop) indices into the concatenated present samples."""
    starts, stops = valid_stretches(valid)
    lengths = stops - starts
    ends = np.cumsum(lengths)
    return (ends - lengths).astype(np.int64), ends.astype(np.int64)


def _shared_mask(arr: NDArray[np.float64], offset: int = 0) -> NDArray[np.bool_]:
    finite = np.isfinite(arr)
    if np.isinf(arr).any():
        r, c = np.argwhere(np.isinf(arr))[0]
        raise NonFiniteSamplesError(
            f"sample {offset + r} axis {c} is infinite; only NaN marks a missing sample"
        )
    valid = finite[:, 0]
    if not (finite == valid[:, None]).all():
        raise ValueError("the axes are missing different samples; analyze them one at a time")
    return valid


def _combined_edf(lengths: NDArray[np.int64], m: int, alpha: int, stride: int) -> float:
    """edf of the sum over independent stretches holding ``lengths`` differences each."""
    lengths = lengths[lengths > 0]
    total = float(lengths.sum())
    if total <= 0:
        return 1.0
    unique, counts = np.unique(lengths, return_counts=True)
    if len(unique) > EDF_LENGTH_POINTS:
        picks = np.unique(np.geomspace(unique[0], unique[-1], EDF_LENGTH_POINTS).astype(np.int64))
        picks = np.union1d(picks, unique[[0, -1]])
        exact = np.array([allan_edf(int(n), m, alpha, stride=stride) for n in picks])
        edf = np.exp(np.interp(np.log(unique), np.log(picks), np.log(exact)))
    else:
        edf = np.array([allan_edf(int(n), m, alpha, stride=stride) for n in unique])
    spread = float(np.sum(counts * unique.astype(float) ** 2 / edf))
    return float(min(max(total**2 / spread, 1.0), total))


def _edf_grid(m: NDArray[np.int64], alpha: NDArray[np.int64],
              lengths_of: Callable[[int], NDArray[np.int64]], stride_of: Callable[[int], int]
              ) -> NDArray[np.float64]:
    """edf per (tau, axis), exact at up to :data:`EDF_TAU_POINTS` taus, interpolated between."""
    if len(m) > EDF_TAU_POINTS:
        picks = np.unique(np.geomspace(1, len(m), EDF_TAU_POINTS).astype(int) - 1)
    else:
        picks = np.arange(len(m))
    out = np.empty(alpha.shape)
    for a in np.unique(alpha):
        exact = np.array([_combined_edf(lengths_of(i), int(m[i]), int(a), stride_of(int(m[i])))
                          for i in picks])
        full = exact if len(picks) == len(m) else np.exp(
            np.interp(np.log(m), np.log(m[picks]), np.log(exact)))
        mask = alpha == a
        out[mask] = np.broadcast_to(full[:, None], alpha.shape)[mask]
    return out


@dataclass(frozen=True)
class _Gapped:
    """A gapped record prepared for the estimators."""

    theta: NDArray[np.float64]  # angle of the concatenated present samples, (n_valid + 1, k)
    positions: NDArray[np.int64]  # grid index of each present sample
    starts: NDArray[np.int64]  # stretches, indices into the present samples
    stops: NDArray[np.int64]
    n_grid: int
    fs: float


def _prepare(samples: ArrayLike, fs: float, input_kind: str) -> _Gapped:
    arr = np.asarray(samples, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ValueError(f"samples must be 1-D (N) or 2-D (N x axes), got shape {arr.shape}")
    valid = _shared_mask(arr)
    present = arr[valid]
    if present.shape[0] < 2:
        raise TooFewSamplesError(
            f"{present.shape[0]} present samples are too few for an Allan variance"
        )
    increments = present - present.mean(axis=0)
    if input_kind == "rate":
        increments = increments / fs
    elif input_kind != "angle_increment":
        raise ValueError(f"input_kind must be 'rate' or 'angle_increment', got {input_kind!r}")
    theta = np.empty((present.shape[0] + 1, arr.shape[1]))
    theta[0] = 0.0
    np.cumsum(increments, axis=0, out=theta[1:])
    starts, stops = _stretches_in_samples(valid)
    return _Gapped(theta, np.flatnonzero(valid).astype(np.int64), starts, stops, arr.shape[0], fs)


def _prepare_long(samples: NDArray[np.float64], fs: float, input_kind: str,
                  angle_out: NDArray[np.float64]) -> _Gapped:
    """:func:`_prepare` of a long record (a memmap), a block at a time: the angle of the
    present samples goes to ``angle_out`` (shape (present + 1, k)); the present samples'
    grid positions are not kept (the overlapping estimator does not need them)."""
    arr = samples[:, None] if samples.ndim == 1 else samples
    if input_kind not in ("rate", "angle_increment"):
        raise ValueError(f"input_kind must be 'rate' or 'angle_increment', got {input_kind!r}")
    total = np.zeros(arr.shape[1])
    count = 0
    edges: list[int] = []  # grid indices where presence flips
    was_present = False
    for a, b in blocks.spans(0, arr.shape[0]):
        block = np.asarray(arr[a:b], dtype=np.float64)
        valid = _shared_mask(block, a)
        total += block[valid].sum(axis=0)
        count += int(valid.sum())
        flips = np.flatnonzero(np.diff(np.concatenate(([was_present], valid)).astype(np.int8)))
        edges.extend((a + flips).tolist())
        was_present = bool(valid[-1])
        blocks.release(arr)
    if count < 2:
        raise TooFewSamplesError(f"{count} present samples are too few for an Allan variance")
    if angle_out.shape != (count + 1, arr.shape[1]):
        raise ValueError(f"angle_out must have shape {(count + 1, arr.shape[1])}, "
                         f"got {angle_out.shape}")
    bounds = np.asarray([*edges, *([arr.shape[0]] if was_present else [])], dtype=np.int64)
    lengths = bounds[1::2] - bounds[0::2]
    stops = np.cumsum(lengths).astype(np.int64)
    mean = total / count
    angle_out[0] = 0.0
    carry, done = np.zeros(arr.shape[1]), 0
    for a, b in blocks.spans(0, arr.shape[0]):
        block = np.asarray(arr[a:b], dtype=np.float64)
        increments = block[np.isfinite(block[:, 0])] - mean
        if input_kind == "rate":
            increments = increments / fs
        if len(increments):
            increments[0] += carry
            np.cumsum(increments, axis=0, out=angle_out[done + 1 : done + 1 + len(increments)])
            carry = np.array(angle_out[done + len(increments)])
            done += len(increments)
        blocks.release(arr)
        blocks.release(angle_out)
    return _Gapped(angle_out, np.zeros(0, np.int64), stops - lengths, stops, arr.shape[0], fs)


def _keep_usable(m: NDArray[np.int64], n_terms: NDArray[np.int64], explicit: bool, g: _Gapped
                 ) -> NDArray[np.bool_]:
    usable = n_terms > 0
    if explicit and not usable.all():
        bad = int(m[~usable][0])
        longest = int(np.max(g.stops - g.starts))
        raise TooFewSamplesError(
            f"tau {bad / g.fs} s needs {2 * bad} samples without a gap; the longest gap-free "
            f"stretch has {longest}")
    if not usable.any():
        raise TooFewSamplesError("no tau of the grid fits in a gap-free stretch; the gaps leave "
                                 f"stretches of at most {int(np.max(g.stops - g.starts))} samples")
    return usable


def _overlapping(g: _Gapped, m: NDArray[np.int64]
                 ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """(differences summed, whole clusters in the stretches, differences per stretch) per m."""
    lengths = g.stops - g.starts
    per_stretch = np.maximum(lengths[None, :] + 1 - 2 * m[:, None], 0)
    n_terms = per_stretch.sum(axis=1).astype(np.int64)
    n_clusters = (lengths[None, :] // m[:, None]).sum(axis=1).astype(np.int64)
    return n_terms, n_clusters, per_stretch


def _cluster_terms(g: _Gapped, m_values: NDArray[np.int64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Sums of squared differences of adjacent complete clusters on the time grid, per m.

    Returns (sums (n_m, k), differences summed (n_m,), complete clusters (n_m,)). The m
    values are gathered in blocks ``[a, 2a)`` as :func:`analysis.allan.cluster_sums` does.
    """
    n = g.n_grid
    order = np.argsort(m_values)
    ms = np.asarray(m_values, dtype=np.int64)[order]
    sums = np.empty((len(ms), g.theta.shape[1]))
    terms = np.empty(len(ms), dtype=np.int64)
    clusters = np.empty(len(ms), dtype=np.int64)
    start = 0
    while start < len(ms):
        stop = int(np.searchsorted(ms, 2 * ms[start], side="left"))
        block = ms[start:stop]
        k = np.arange(n // block[0] + 1)
        # grid position -> count of present samples before it -> angle there
        edge = np.searchsorted(g.positions, np.minimum(block[:, None] * k[None, :], n))
        complete = np.diff(edge, axis=1) == block[:, None]
        angles = np.diff(g.theta[edge], axis=1)
        d = np.diff(angles, axis=1)
        ok = complete[:, 1:] & complete[:, :-1]
        sums[start:stop] = np.einsum("bjk,bjk,bj->bk", d, d, ok.astype(float))
        terms[start:stop] = ok.sum(axis=1)
        clusters[start:stop] = complete.sum(axis=1)
        start = stop
    out_s, out_t, out_c = np.empty_like(sums), np.empty_like(terms), np.empty_like(clusters)
    out_s[order], out_t[order], out_c[order] = sums, terms, clusters
    return out_s, out_t, out_c


def _cluster_runs(g: _Gapped, m: int) -> NDArray[np.int64]:
    """Lengths of the runs of consecutive valid cluster differences at one m."""
    k = np.arange(g.n_grid // m + 1)
    edge = np.searchsorted(g.positions, np.minimum(m * k, g.n_grid))
    complete = np.diff(edge) == m
    ok = complete[1:] & complete[:-1]
    starts, stops = valid_stretches(ok)
    return stops - starts


def gap_allan_variance(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    estimator: str = "overlapping",
    taus: TauGrid | ArrayLike = "log",
    input_kind: str = "rate",
    confidence: float = ONE_SIGMA,
    angle_out: NDArray[np.float64] | None = None,
) -> AllanResult:
    """Allan variance of a record whose missing samples are NaN (see the module docstring).

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate (e.g. deg/s) on the record's true time grid, NaN where a sample is missing;
        every axis must miss the same samples. Angle increments per sample with
        ``input_kind="angle_increment"``.
    sample_rate_hz : float
        Sample rate in Hz: ``tau = m / sample_rate_hz`` is true time.
    estimator : {"overlapping", "clusters"}
        As :func:`analysis.allan.allan_variance`.
    taus : {"log", "octave", "all"} or array_like
        Tau grid of the record's span (missing samples included); taus that fit in no
        gap-free stretch are left out of a named grid and refused when given explicitly.
    input_kind : {"rate", "angle_increment"}
        What the samples are.
    confidence : float
        Two-sided level of the chi-square interval.
    angle_out : ndarray, shape (present samples + 1, k), optional
        Overlapping estimator of a long record (:func:`analysis.allan.blocks.is_long`, e.g. a
        memmap): the angle of the present samples is written here (e.g. a memmap) and the
        record walked a block at a time, in bounded memory; the same numbers to rounding.

    Returns
    -------
    AllanResult
        ``n_terms``: differences summed (only complete ones); ``n_clusters``: complete
        clusters (overlapping: whole clusters inside the gap-free stretches);
        ``n_samples``: present samples; ``edf`` from the stretches as described above.
        Without any NaN the values equal the gap-free estimators' to rounding.

    Raises
    ------
    NonFiniteSamplesError
        An infinite sample (only NaN marks a missing one).
    ValueError
        The axes miss different samples, or an unknown estimator.
    TooFewSamplesError
        No tau fits in a gap-free stretch (or an explicit one does not).

    References
    ----------
    IEEE Std 952-1997, Annex C; NIST SP 1065, section 5.2.4 (overlapping ADEV);
    C. A. Greenhall and W. J. Riley, Proc. 35th PTTI (2003) for the edf of each stretch.
    """
    fs = check_sample_rate(sample_rate_hz)
    long = (angle_out is not None and estimator == "overlapping"
            and blocks.is_long(np.shape(samples)[0]))
    g = (_prepare_long(np.asarray(samples), fs, input_kind, angle_out) if long and angle_out
         is not None else _prepare(samples, fs, input_kind))
    explicit = not isinstance(taus, str)
    m = resolve_m(taus, g.n_grid, fs)
    if estimator == "overlapping":
        n_terms, n_clusters, per_stretch = _overlapping(g, m)
        keep = _keep_usable(m, n_terms, explicit, g)
        m, n_terms, n_clusters, per_stretch = (
            m[keep],
            n_terms[keep],
            n_clusters[keep],
            per_stretch[keep],
        )
        sums = kernels.overlapping_stretch_sums(g.theta, m, g.starts, g.stops)

        def lengths_of(i: int) -> NDArray[np.int64]:
            return np.asarray(per_stretch[i], dtype=np.int64)

        def stride_of(mm: int) -> int:
            return 1
    elif estimator == "clusters":
        sums, n_terms, n_clusters = _cluster_terms(g, m)
        keep = _keep_usable(m, n_terms, explicit, g)
        m, sums, n_terms, n_clusters = m[keep], sums[keep], n_terms[keep], n_clusters[keep]

        def lengths_of(i: int) -> NDArray[np.int64]:
            return _cluster_runs(g, int(m[i]))

        def stride_of(mm: int) -> int:
            return mm
    else:
        raise ValueError(f"estimator must be 'overlapping' or 'clusters', got {estimator!r}")
    avar = sums / (2.0 * (m[:, None].astype(float) / fs) ** 2 * n_terms[:, None])
    n_present = g.theta.shape[0] - 1
    if len(g.starts) == 1:  # no gap: the type per tau of the gap-free estimators
        alpha = identify_noise(g.theta, m).alpha
    else:
        alpha = local_noise_alpha(m, avar, n_present)
    edf = np.clip(_edf_grid(m, alpha, lengths_of, stride_of), 1.0, np.maximum(n_terms, 1)[:, None])
    low, high = chi2_interval(avar, edf, confidence)
    if np.ndim(samples) == 1:
        avar, edf, low, high, alpha = avar[:, 0], edf[:, 0], low[:, 0], high[:, 0], alpha[:, 0]
    return AllanResult(
        tau_s=m / fs,
        m=m,
        avar=avar,
        n_clusters=n_clusters,
        n_terms=n_terms,
        edf=edf,
        ci_low=low,
        ci_high=high,
        confidence=confidence,
        estimator=estimator,
        sample_rate_hz=fs,
        n_samples=n_present,
        noise_alpha=alpha,
    )
