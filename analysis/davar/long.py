"""Dynamic Allan variance of a long record, a group of windows at a time, in bounded memory.

The fast DAVAR (:func:`analysis.davar.dynamic_allan_variance`) gathers blocks of three
windows of every axis, with centred copies and their angle: for a 24 h run at 1 kHz and
windows of an hour that is several hundred MB, and a memory-mapped record's pages stay
mapped in as it goes. Here each axis is taken apart, and its windows in groups of
consecutive starts spanning about three windows (:func:`group_span`): the group's
cumulative angle, its own mean removed as the fast DAVAR removes each block's, is walked
a block of the record at a time into a buffer the caller may map to a file; the window
sums of the group are the fast DAVAR's (:func:`analysis.allan.kernels.window_sums`, Zhang 2015
eq. 6 with the O(1) window sums of eq. 15); then the pages of the record and of the
buffer are handed back (:mod:`analysis.allan.blocks`). Memory stays about one group of one axis
whatever the length of the record, the work is the fast DAVAR's, and the numbers are
its numbers to rounding (its groups of windows may be cut elsewhere).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import blocks, kernels
from analysis.allan.estimators import ONE_SIGMA, Missing, TauGrid
from analysis.allan.kernels import Backend
from analysis.allan.partial_clusters import partial_window_sums
from analysis.davar.estimators import (
    DavarPlan,
    DavarResult,
    finish_davar,
    plan_davar,
    window_starts,
)
from analysis.errors import NonFiniteSamplesError


def group_span(plan: DavarPlan) -> int:
    """Samples of record one group of consecutive windows spans at most: about three
    windows (the fast DAVAR's block), at least four blocks. The angle buffer of
    :func:`dynamic_allan_variance_long` holds one more."""
    span = max(3 * plan.window, 4 * blocks.BLOCK_SAMPLES)
    return (span - plan.window) // plan.step * plan.step + plan.window


def dynamic_allan_variance_long(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    window_s: float,
    step_s: float | None = None,
    taus: TauGrid | ArrayLike = "log",
    confidence: float = ONE_SIGMA,
    missing: Missing = "raise",
    backend: Backend = "auto",
    angle_out: NDArray[np.float64] | None = None,
) -> DavarResult:
    """Dynamic Allan variance of a long rate record (e.g. a memmap), a group of windows
    of one axis at a time (Zhang 2015, eq. 6).

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate samples (e.g. deg/s); NaN marks a missing sample with ``missing="gap"``. A
        memmap is read a block at a time (an axis-major one, ``x[:, c]`` contiguous,
        reads only the axis at hand).
    sample_rate_hz, window_s, step_s, taus, confidence, missing, backend
        As for :func:`analysis.davar.dynamic_allan_variance`: a window missing at most a
        tenth of an axis' samples gets partial clusters there
        (:func:`analysis.allan.partial_clusters.partial_window_sums`), one missing more NaN.
    angle_out : ndarray, shape (M,), M >= group_span(plan) + 1, optional
        Where to keep a group's cumulative angle (a memmap keeps it out of memory; its
        pages are handed back after each group); ``plan`` is
        :func:`analysis.davar.plan_davar` of the same arguments.

    Returns
    -------
    DavarResult
        Always 3-D (windows, taus, axes), as the streamed DAVAR's.

    Raises
    ------
    InvalidWindowError, TooFewSamplesError, InvalidSampleRateError, InvalidTauError
        As for :func:`analysis.davar.dynamic_allan_variance`.
    NonFiniteSamplesError
        An infinite sample, or NaN with ``missing="raise"``.
    ValueError
        ``angle_out`` too short, ``samples`` not 1-D or 2-D, ``missing`` unknown.

    References
    ----------
    Zhang et al., Acta Optica Sinica 35(4), 2015, eq. 6, 15.
    """
    if missing not in ("raise", "gap"):
        raise ValueError(f"missing must be 'raise' or 'gap', got {missing!r}")
    x = samples if isinstance(samples, np.ndarray) else np.asarray(samples, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    if x.ndim != 2:
        raise ValueError(f"samples must be 1-D (N) or 2-D (N x axes), got shape {x.shape}")
    plan = plan_davar(sample_rate_hz, window_s, step_s, taus)
    starts = window_starts(x.shape[0], plan)
    span = group_span(plan)
    angle = np.empty(span + 1) if angle_out is None else angle_out
    if angle.shape[0] < span + 1:
        raise ValueError(f"angle_out must hold {span + 1} values, got {angle.shape[0]}")
    per_group = (span - plan.window) // plan.step + 1
    sums = np.empty((len(starts), len(plan.m), x.shape[1]))
    present = np.ones((len(starts), x.shape[1]))
    for c in range(x.shape[1]):
        column = x[:, c]
        for g in range(0, len(starts), per_group):
            group = starts[g : g + per_group]
            a, b = int(group[0]), int(group[-1]) + plan.window
            theta = angle[: b - a + 1]
            lost = _group_angle(column, a, b, 1.0 / plan.fs, theta, missing == "gap")
            sums[g : g + len(group), :, c] = kernels.window_sums(
                theta, plan.m, group - a, plan.window, backend=backend)
            blocks.release(theta)
            if len(lost):  # windows holding a missing sample: partial, as the fast DAVAR's
                after = np.searchsorted(lost[:, 1], group, side="right")
                held = after < len(lost)
                held[held] = lost[after[held], 0] < group[held] + plan.window
                for w in np.flatnonzero(held):
                    s = int(group[w])
                    sums[g + w, :, c], present[g + w, c] = partial_window_sums(
                        column[s : s + plan.window], plan.fs, plan.m)
    return finish_davar(sums, starts, plan, x.shape[0], confidence=confidence, squeeze=False,
                        edf_scale=present)


def _group_angle(column: NDArray[np.float64], a: int, b: int, scale: float,
                 out: NDArray[np.float64], gap: bool) -> NDArray[np.int64]:
    """The cumulative angle of ``column[a:b]`` (mean removed, times ``scale``) into ``out``
    (``b - a + 1`` values, a leading zero), a block at a time; a missing sample (NaN, with
    ``gap``) adds nothing. Returns the runs of missing samples, ``[start, stop)`` record
    indices (shape (runs, 2))."""
    mean = blocks.nan_mean(column[a:b]) if gap else blocks.pairwise_sum(column, a, b) / (b - a)
    out[0] = 0.0
    carry = 0.0
    runs = []
    for p, q in blocks.spans(a, b):
        v = np.asarray(column[p:q], dtype=np.float64)
        blocks.release(column)
        bad = ~np.isfinite(v)
        nan = np.isnan(v) if bad.any() else None
        if nan is not None and (not gap or not nan[bad].all()):
            first = p + int(np.argmax(bad))
            raise NonFiniteSamplesError(
                f"non-finite sample {first} ({column[first]}); remove or interpolate it "
                f"first" + ("" if gap else ", or read NaN as missing (missing='gap')"))
        increments = (v - mean) * scale
        if nan is not None:
            edges = np.flatnonzero(np.diff(np.concatenate(([0], nan.view(np.int8), [0]))))
            runs.append(edges.reshape(-1, 2) + p)
            increments[nan] = 0.0
        increments[0] += carry  # one running sum over the group, as np.cumsum of it all
        np.cumsum(increments, out=increments)
        out[p - a + 1 : q - a + 1] = increments
        blocks.release(out)  # a memmap's written pages stay in its file, not in this process
        carry = float(increments[-1])
    return np.concatenate(runs) if runs else np.zeros((0, 2), dtype=np.int64)
