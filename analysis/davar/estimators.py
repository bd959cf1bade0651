"""Dynamic Allan variance (DAVAR): the overlapping Allan variance over a sliding window.

For a window of ``Nw`` samples starting at sample ``s`` (angle points ``theta[s .. s+Nw]``)
and an averaging factor ``m``, Zhang 2015 eq. 6 reads

``avar(s, m) = sum_{k=s}^{s+L-1} Delta_m(k)^2 / (2 tau^2 L)``,
``Delta_m(k) = theta[k+2m] - 2 theta[k+m] + theta[k]``, ``L = Nw + 1 - 2m``, ``tau = m/fs``,

i.e. :func:`analysis.allan.overlapping_allan_variance` of the window (the same phase
convention: a leading zero angle, ``L`` terms). Three implementations give the same
numbers (the tests hold them to 1e-9 relative):

* :func:`davar_plain` recomputes every window from its samples (a reference for tests);
* :func:`davar_recursive` slides the window one sample at a time with eq. 17-19;
* :func:`dynamic_allan_variance` (what everything else calls) takes every window sum in
  O(1) from block prefix and suffix sums of ``Delta_m^2``
  (:func:`analysis.allan.kernels.window_sums`), streaming the record through in blocks so memory
  stays bounded however long it is (:func:`dynamic_allan_variance_stream`,
  :func:`dynamic_allan_variance_slices`).

Each cell gets a chi-square confidence interval with the equivalent degrees of freedom of
the overlapping estimator over ``Nw`` samples for the noise type seen at that tau
(:func:`analysis.allan.overlapping_edf`, :func:`analysis.allan.chi2_interval`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import kernels
from analysis.allan.estimators import (
    ONE_SIGMA,
    AllanDeviationMixin,
    InputKind,
    Missing,
    TauGrid,
    as_samples,
    check_sample_rate,
    chi2_interval,
    cumulative_angle,
    local_noise_alpha,
    overlapping_edf,
    resolve_m,
)
from analysis.allan.kernels import Backend
from analysis.allan.partial_clusters import partial_windows
from analysis.errors import InvalidWindowError, TooFewSamplesError


@dataclass(frozen=True)
class DavarResult(AllanDeviationMixin):
    """Dynamic Allan variance: one Allan curve per window position.

    Attributes
    ----------
    t_s : ndarray, shape (n_windows,)
        Window centre times in s from the start of the record, ``(s + Nw/2) / fs``.
    tau_s : ndarray, shape (n_tau,)
        Averaging times in s.
    m : ndarray of int, shape (n_tau,)
        Averaging factors (samples).
    avar : ndarray, shape (n_windows, n_tau) or (n_windows, n_tau, k)
        Allan variance per window and tau in (input unit)^2, e.g. (deg/s)^2; the last
        axis holds the gyro axes when the input had several.
    edf : ndarray, same shape as ``avar``
        Equivalent degrees of freedom of each cell: the overlapping estimator's over
        ``Nw`` samples (:func:`analysis.allan.overlapping_edf`) for ``noise_alpha``.
    ci_low, ci_high : ndarray, same shape as ``avar``
        Chi-square confidence interval of each cell at level ``confidence``.
    noise_alpha : ndarray of int, shape (n_tau,) or (n_tau, k)
        Dominant noise exponent per tau (and axis), read off the mean curve of all windows
        by :func:`analysis.allan.local_noise_alpha`.
    n_terms : ndarray of int, shape (n_tau,)
        Squared second differences per window, ``L = Nw + 1 - 2m``.
    confidence : float
        Two-sided level of ``ci_low``/``ci_high``.
    window_samples, step_samples : int
        Window length Nw and window step in samples.
    sample_rate_hz : float
        Sample rate in Hz.
    n_samples : int
        Samples per axis in the whole record.
    """

    t_s: NDArray[np.float64]
    tau_s: NDArray[np.float64]
    m: NDArray[np.int64]
    avar: NDArray[np.float64]
    edf: NDArray[np.float64]
    ci_low: NDArray[np.float64]
    ci_high: NDArray[np.float64]
    noise_alpha: NDArray[np.int64]
    n_terms: NDArray[np.int64]
    confidence: float
    window_samples: int
    step_samples: int
    sample_rate_hz: float
    n_samples: int

    @property
    def window_s(self) -> float:
        """Window length in s."""
        return self.window_samples / self.sample_rate_hz

    @property
    def step_s(self) -> float:
        """Step between window starts in s."""
        return self.step_samples / self.sample_rate_hz

    @property
    def window_start_s(self) -> NDArray[np.float64]:
        """Window start times in s from the start of the record."""
        return self.t_s - self.window_s / 2.0

    @property
    def n_axes(self) -> int:
        """Number of gyro axes (1 for a single-axis result)."""
        return 1 if self.avar.ndim == 2 else int(self.avar.shape[2])

    def axis(self, index: int) -> DavarResult:
        """The single-axis result of axis ``index`` (``avar`` shaped (n_windows, n_tau))."""
        if self.avar.ndim == 2:
            if index != 0:
                raise IndexError(f"a single-axis result has no axis {index}")
            return self
        pick = (slice(None), slice(None), index)
        return DavarResult(
            t_s=self.t_s, tau_s=self.tau_s, m=self.m, avar=self.avar[pick], edf=self.edf[pick],
            ci_low=self.ci_low[pick], ci_high=self.ci_high[pick],
            noise_alpha=self.noise_alpha[:, index], n_terms=self.n_terms,
            confidence=self.confidence, window_samples=self.window_samples,
            step_samples=self.step_samples, sample_rate_hz=self.sample_rate_hz,
            n_samples=self.n_samples,
        )


# ------------------------------------------------------------------------- plan and finish


@dataclass(frozen=True)
class DavarPlan:
    """The windows of a DAVAR: sample rate ``fs`` (Hz), window ``window`` and ``step``
    (samples), averaging factors ``m`` (samples)."""

    fs: float
    window: int
    step: int
    m: NDArray[np.int64]


def plan_davar(
    sample_rate_hz: float, window_s: float, step_s: float | None, taus: TauGrid | ArrayLike
) -> DavarPlan:
    """The plan of a DAVAR's windows (see :func:`dynamic_allan_variance` for the arguments).

    Raises
    ------
    InvalidWindowError
        If the window or step is under one sample, or too short for the tau grid.
    InvalidSampleRateError
        If the sample rate is not a finite positive number.
    """
    fs = check_sample_rate(sample_rate_hz)
    window = _whole_samples("window", window_s, fs)
    step = max(1, window // 10) if step_s is None else _whole_samples("step", step_s, fs)
    try:
        m = resolve_m(taus, window, fs)
    except TooFewSamplesError as exc:
        raise InvalidWindowError(f"window of {window} samples: {exc}") from exc
    return DavarPlan(fs, window, step, m)


def _whole_samples(what: str, seconds: float, fs: float) -> int:
    try:
        value = float(seconds)
    except (TypeError, ValueError) as exc:
        raise InvalidWindowError(f"{what} {seconds!r} is not a number of seconds") from exc
    samples = int(round(value * fs)) if np.isfinite(value) else 0
    if samples < 1:
        raise InvalidWindowError(
            f"{what} of {seconds} s is less than one sample at {fs} Hz; give a longer {what}"
        )
    return samples


def window_starts(n_samples: int, plan: DavarPlan) -> NDArray[np.int64]:
    """Sample index of each window's start in a record of ``n_samples``.

    Raises
    ------
    TooFewSamplesError
        If the record is shorter than one window.
    """
    if n_samples < plan.window:
        raise TooFewSamplesError(
            f"the record has {n_samples} samples ({n_samples / plan.fs:g} s), fewer than one "
            f"window of {plan.window} ({plan.window / plan.fs:g} s); shorten the window"
        )
    return np.arange(0, n_samples - plan.window + 1, plan.step, dtype=np.int64)


def finish_davar(sums: NDArray[np.float64], starts: NDArray[np.int64], plan: DavarPlan,
                 n_samples: int, *, confidence: float, squeeze: bool,
                 edf_scale: NDArray[np.float64] | None = None) -> DavarResult:
    """The DAVAR of window sums of ``Delta_m^2`` (n_windows, n_tau, k), scaled to Allan
    variances in place (Zhang 2015, eq. 6), with each cell's edf and interval; ``squeeze``
    drops the axis dimension of a one-axis record; ``edf_scale`` (n_windows, k) reduces
    the edf of windows with missing samples."""
    m = plan.m
    n_terms = plan.window + 1 - 2 * m
    tau = m / plan.fs
    avar = np.divide(sums, 2.0 * tau[:, None] ** 2 * n_terms[:, None], out=sums)  # in place
    # The noise type per tau comes from the mean curve over the windows: one window's
    # curve is too noisy at long tau for a local slope (a slope of -2 read off noise would
    # give the white-angle edf, ~Nw/2, and intervals far too narrow).
    if np.isnan(avar).any():  # windows across gaps; an axis may have none left (all NaN)
        counts = np.sum(~np.isnan(avar), axis=0)
        mean_curve = np.nansum(avar, axis=0) / np.maximum(counts, 1)
    else:
        mean_curve = avar.mean(axis=0)
    alpha = local_noise_alpha(m, np.nan_to_num(mean_curve, nan=1.0))
    edf_tau = overlapping_edf(plan.window, m[:, None], alpha)
    low_f, high_f = chi2_interval(np.ones_like(edf_tau), edf_tau, confidence)
    edf = np.broadcast_to(edf_tau, avar.shape)  # read-only view: the same for every window
    low, high = avar * low_f, avar * high_f
    if edf_scale is not None and (edf_scale < 1).any():
        edf = np.maximum(edf * edf_scale[:, None, :], 1.0)
        low, high = chi2_interval(avar, edf, confidence)
    if squeeze:
        avar, edf, low, high = avar[..., 0], edf[..., 0], low[..., 0], high[..., 0]
        alpha = alpha[:, 0]
    return DavarResult(
        t_s=np.asarray((starts + plan.window / 2.0) / plan.fs, dtype=np.float64),
        tau_s=tau,
        m=m,
        avar=avar,
        edf=edf,
        ci_low=low,
        ci_high=high,
        noise_alpha=alpha,
        n_terms=n_terms.astype(np.int64),
        confidence=confidence,
        window_samples=plan.window,
        step_samples=plan.step,
        sample_rate_hz=plan.fs,
        n_samples=n_samples,
    )


# ------------------------------------------------------------------ reference implementations


def davar_plain(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    window_s: float,
    step_s: float | None = None,
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
) -> DavarResult:
    """DAVAR by recomputing the overlapping Allan variance of every window (Zhang 2015, eq. 6).

    O(N Nw / step) work per tau: a reference for tests, not for use on long records.
    Parameters, result and errors are those of :func:`dynamic_allan_variance`.
    """
    plan = plan_davar(sample_rate_hz, window_s, step_s, taus)
    arr = as_samples(samples)
    starts = window_starts(arr.shape[0], plan)
    sums = np.empty((len(starts), len(plan.m), arr.shape[1]))
    for j, s in enumerate(starts):
        theta = cumulative_angle(arr[s : s + plan.window], plan.fs, input_kind=input_kind)
        sums[j] = kernels.overlapping_sums_reference(theta, plan.m)
    return finish_davar(sums, starts, plan, arr.shape[0], confidence=confidence,
                   squeeze=np.ndim(samples) == 1)


def davar_recursive(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    window_s: float,
    step_s: float | None = None,
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
) -> DavarResult:
    """DAVAR by the recursive update of Zhang 2015, eq. 15-19 (after Galleani and Tavella 2010).

    The first window is summed in full (eq. 15); each one-sample move adds the term that
    enters, ``Delta_m(s + L)`` (eq. 18), and takes away the one that leaves,
    ``Delta_m(s)`` (eq. 19), per eq. 17, for all taus and axes at once. The running sums
    are compensated (Neumaier), so a large early transient leaves no rounding residue
    in the small sums that follow it. O(N) steps of O(n_tau) work whatever the step.
    Parameters, result and errors are those of :func:`dynamic_allan_variance`.
    """
    plan = plan_davar(sample_rate_hz, window_s, step_s, taus)
    theta = cumulative_angle(samples, plan.fs, input_kind=input_kind)
    n_samples = theta.shape[0] - 1
    starts = window_starts(n_samples, plan)
    n_terms = plan.window + 1 - 2 * plan.m

    def delta_sq(k: NDArray[np.int64]) -> NDArray[np.float64]:
        d = theta[k + 2 * plan.m] - 2.0 * theta[k + plan.m] + theta[k]
        return np.asarray(d * d, dtype=np.float64)

    acc = np.zeros((len(plan.m), theta.shape[1]))
    comp = np.zeros_like(acc)

    def add(x: NDArray[np.float64]) -> None:
        # Neumaier's compensated addition, for every (tau, axis) at once.
        nonlocal acc
        total = acc + x
        comp[...] += np.where(np.abs(acc) >= np.abs(x), (acc - total) + x, (x - total) + acc)
        acc = total

    # First window, eq. 15, summed exactly (math.fsum) into the same two-part sum, so that
    # what the later steps take away cancels exactly.
    for i, m_i in enumerate(plan.m):
        for c in range(theta.shape[1]):
            terms = kernels.second_difference_squares(theta[: plan.window + 1, c], int(m_i))
            acc[i, c] = math.fsum(terms)
            comp[i, c] = math.fsum(np.append(terms, -acc[i, c]))
    sums = np.empty((len(starts), len(plan.m), theta.shape[1]))
    sums[0] = acc + comp
    record = iter(range(1, len(starts)))
    next_j = next(record, None)
    for s in range(1, int(starts[-1]) + 1):
        # Eq. 17: add the entering term (eq. 18), take away the leaving one (eq. 19), as
        # two additions: din^2 - dout^2 formed first would round at the size of the larger
        # term, which may dwarf the window sum that is left.
        add(delta_sq(s - 1 + n_terms))
        add(-delta_sq(np.full_like(n_terms, s - 1)))
        if next_j is not None and s == starts[next_j]:
            sums[next_j] = acc + comp
            next_j = next(record, None)
    return finish_davar(sums, starts, plan, n_samples, confidence=confidence,
                   squeeze=np.ndim(samples) == 1)


# ---------------------------------------------------------------------- fast, streaming


def _samples(samples: ArrayLike, missing: Missing) -> NDArray[np.float64]:
    """Samples as (N, k) float64: NaN allowed as missing with ``missing="gap"``, inf never."""
    if missing != "gap":
        return as_samples(samples)
    arr = np.asarray(samples, dtype=np.float64)
    as_samples(np.where(np.isnan(arr), 0.0, arr))  # refuses inf, and a shape that is not (N, k)
    return arr[:, None] if arr.ndim == 1 else arr


def _iter_array(arr: NDArray[np.float64], chunk: int) -> Iterator[NDArray[np.float64]]:
    for a in range(0, arr.shape[0], chunk):
        yield arr[a : a + chunk]


def dynamic_allan_variance(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    window_s: float,
    step_s: float | None = None,
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
    block_samples: int | None = None,
    backend: Backend = "auto",
    missing: Missing = "raise",
) -> DavarResult:
    """Dynamic Allan variance of a record in memory (Zhang 2015, eq. 6), the fast way.

    Every window sum of ``Delta_m^2`` is O(1) (:func:`analysis.allan.kernels.window_sums`), so
    the work is O(N) per tau whatever the window and the step.

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate samples (e.g. deg/s), or angle increments per sample with
        ``input_kind="angle_increment"``.
    sample_rate_hz : float
        Sample rate in Hz.
    window_s : float
        Window length in s, rounded to whole samples ``Nw``.
    step_s : float, optional
        Step between window starts in s (whole samples); default ``Nw / 10``.
    taus : {"log", "octave", "all"} or array_like
        Tau grid of one window: log-spaced with at least 9 clusters (Zhang 2015, eq. 20,
        the default), octaves, every m, or explicit taus in s (at most ``window_s / 2``).
    input_kind : {"rate", "angle_increment"}
        What the samples are.
    confidence : float
        Two-sided level of each cell's chi-square interval (default +-1 sigma).
    block_samples : int, optional
        Samples processed at once (memory bound); default ``max(3 Nw, 2^20)``.
    backend : {"auto", "numpy", "numba"}
        Kernel for the window sums.
    missing : {"raise", "gap"}
        ``"gap"`` reads NaN samples as missing ones on the record's time grid (a gap of a
        recorded run): a window missing at most a tenth of an axis' samples gets partial
        clusters there, its edf reduced (:func:`analysis.allan.partial_clusters.partial_windows`),
        one missing more gets NaN, every other window is exact, and window times stay true
        time. The default refuses NaN
        (:class:`NonFiniteSamplesError`).

    Returns
    -------
    DavarResult

    Raises
    ------
    InvalidWindowError
        If the window or step is under one sample, or too short for the tau grid.
    TooFewSamplesError
        If the record is shorter than one window.
    NonFiniteSamplesError, InvalidSampleRateError, InvalidTauError
        As for :func:`analysis.allan.overlapping_allan_variance`.

    References
    ----------
    Zhang et al., Acta Optica Sinica 35(4), 2015, eq. 6, 15-20; L. Galleani and P. Tavella,
    "The dynamic Allan variance", IEEE Trans. UFFC 56(3), 2009.
    """
    arr = _samples(samples, missing)
    result = dynamic_allan_variance_stream(
        _iter_array(arr, 1 << 20), sample_rate_hz, window_s=window_s, step_s=step_s, taus=taus,
        input_kind=input_kind, confidence=confidence, block_samples=block_samples, backend=backend,
        missing=missing,
    )
    return result.axis(0) if np.ndim(samples) == 1 else result


def dynamic_allan_variance_slices(
    read_slice: Callable[[int, int], ArrayLike],
    n_samples: int,
    sample_rate_hz: float,
    *,
    window_s: float,
    step_s: float | None = None,
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
    chunk_samples: int = 1 << 18,
    block_samples: int | None = None,
    backend: Backend = "auto",
    missing: Missing = "raise",
) -> DavarResult:
    """DAVAR of a long record read piece by piece with ``read_slice(start, stop)``.

    ``read_slice(a, b)`` returns samples ``a .. b-1`` (shape (b - a,) or (b - a, k)), e.g.
    ``lambda a, b: dataset[a:b]`` on an HDF5 dataset or a numpy memmap. Only about
    ``block_samples + chunk_samples`` samples are held at a time, so a 24 h run at 1 kHz
    fits in a few tens of MB; the result is always 3-D (windows, taus, axes).

    Parameters
    ----------
    read_slice : callable
        Reader of samples ``[start, stop)`` (rate in e.g. deg/s, or angle increments).
    n_samples : int
        Samples per axis in the record.
    chunk_samples : int
        Samples asked of ``read_slice`` per call.
    sample_rate_hz, window_s, step_s, taus, input_kind, confidence, block_samples, backend, missing
        As for :func:`dynamic_allan_variance`.

    Returns
    -------
    DavarResult
    """
    if chunk_samples < 1:
        raise ValueError(f"chunk_samples must be >= 1, got {chunk_samples}")
    chunks = (read_slice(a, min(a + chunk_samples, n_samples))
              for a in range(0, int(n_samples), chunk_samples))
    return dynamic_allan_variance_stream(
        chunks, sample_rate_hz, window_s=window_s, step_s=step_s, taus=taus,
        input_kind=input_kind, confidence=confidence, block_samples=block_samples, backend=backend,
        missing=missing,
    )


def dynamic_allan_variance_stream(
    chunks: Iterable[ArrayLike],
    sample_rate_hz: float,
    *,
    window_s: float,
    step_s: float | None = None,
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
    block_samples: int | None = None,
    backend: Backend = "auto",
    missing: Missing = "raise",
) -> DavarResult:
    """DAVAR of a record that arrives as consecutive chunks of samples (any sizes).

    The chunks are gathered into blocks of about ``block_samples``; each block yields the
    windows that lie wholly inside it, then everything before the next window start is
    dropped. Each block takes its own cumulative angle with its own mean removed (a
    constant rate cancels in every second difference), so precision does not degrade
    along a long run. The result is always 3-D (windows, taus, axes).

    Parameters
    ----------
    chunks : iterable of array_like
        Consecutive pieces of the record, each (n_i,) or (n_i, k) with the same k.
    sample_rate_hz, window_s, step_s, taus, input_kind, confidence, block_samples, backend, missing
        As for :func:`dynamic_allan_variance`.

    Returns
    -------
    DavarResult
    """
    if missing not in ("raise", "gap"):
        raise ValueError(f"missing must be 'raise' or 'gap', got {missing!r}")
    plan = plan_davar(sample_rate_hz, window_s, step_s, taus)
    block = max(3 * plan.window, 1 << 20) if block_samples is None else int(block_samples)
    if block < plan.window:
        raise InvalidWindowError(
            f"block_samples {block} must hold a window ({plan.window} samples)"
        )
    if input_kind not in ("rate", "angle_increment"):
        raise ValueError(f"input_kind must be 'rate' or 'angle_increment', got {input_kind!r}")
    scale = 1.0 / plan.fs if input_kind == "rate" else 1.0
    pending: list[NDArray[np.float64]] = []
    n_pending = 0
    pending_start = 0  # record index of the first pending sample
    consumed = 0  # record index just after the last sample seen
    next_start = 0  # record index of the next window start
    n_axes: int | None = None
    out_sums: list[NDArray[np.float64]] = []
    out_starts: list[NDArray[np.int64]] = []
    out_scale: list[NDArray[np.float64]] = []

    def flush() -> None:
        nonlocal pending, n_pending, pending_start, next_start
        buf = np.concatenate(pending) if len(pending) > 1 else pending[0]
        last = pending_start + n_pending - plan.window
        if next_start <= last:
            starts = np.arange(next_start, last + 1, plan.step, dtype=np.int64)
            local = starts - starts[0]
            seg = buf[starts[0] - pending_start : starts[-1] - pending_start + plan.window]
            theta = np.empty((seg.shape[0] + 1, seg.shape[1]))
            theta[0] = 0.0
            lost = np.isnan(seg) if missing == "gap" else None
            if lost is not None and lost.any():
                # a missing sample adds nothing to the angle: a window without one sees the
                # same second differences as a record without gaps (the angle after a gap is
                # only offset by a constant, which cancels)
                centred = np.where(lost, 0.0, seg - np.nanmean(seg, axis=0))
            else:
                centred, lost = seg - seg.mean(axis=0), None
            np.cumsum(centred * scale, axis=0, out=theta[1:])
            sums = np.empty((len(starts), len(plan.m), seg.shape[1]))
            for c in range(seg.shape[1]):
                sums[:, :, c] = kernels.window_sums(theta[:, c], plan.m, local, plan.window,
                                                    backend=backend)
            present = np.ones((len(starts), seg.shape[1]))
            if lost is not None:  # windows with gaps: partial clusters, or NaN past the share
                present = partial_windows(seg * (scale * plan.fs), local, plan.window, plan.m,
                                          plan.fs, sums)
            out_scale.append(present)
            out_sums.append(sums)
            out_starts.append(starts)
            next_start = int(starts[-1]) + plan.step
        drop = next_start - pending_start
        pending = [buf[drop:]] if drop < n_pending else []
        n_pending = max(0, n_pending - drop)
        pending_start = next_start if pending else consumed

    for chunk in chunks:
        arr = _samples(chunk, missing)
        if n_axes is None:
            n_axes = arr.shape[1]
        elif arr.shape[1] != n_axes:
            raise ValueError(f"chunk has {arr.shape[1]} axes, earlier chunks had {n_axes}")
        chunk_start, consumed = consumed, consumed + arr.shape[0]
        if not pending:
            skip = min(max(0, next_start - chunk_start), arr.shape[0])
            arr, pending_start = arr[skip:], chunk_start + skip
        if arr.shape[0]:
            pending.append(arr)
            n_pending += arr.shape[0]
        if n_pending >= block:
            flush()
    if pending:
        flush()
    window_starts(consumed, plan)  # raises when the record is shorter than one window
    starts = np.concatenate(out_starts)
    sums = out_sums[0] if len(out_sums) == 1 else np.concatenate(out_sums)
    return finish_davar(sums, starts, plan, consumed, confidence=confidence, squeeze=False,
                        edf_scale=np.concatenate(out_scale))
