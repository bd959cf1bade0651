"""Dynamic Allan variance of a long record, one window at a time, in bounded memory.

The fast DAVAR (:func:`analysis.davar.dynamic_allan_variance`) gathers blocks of three
windows; a spec sheet's heat map has windows of a twentieth of the record, so for a 24 h
run at 1 kHz a block is 100 MB a column and grows with the run. Here each window's sums
of squared second differences are those of its own fully overlapping Allan variance
(Zhang 2015, eq. 6 is eq. 5 applied to a window): its cumulative angle
(:func:`analysis.allan.cumulative_angle`, in a buffer the caller may map to a file) and
:func:`analysis.allan.overlapping_sums`, both of which walk a long window a block at a
time (:mod:`analysis.blocks`). The numbers are those of the fast DAVAR to rounding (its
angle is taken per block with the block's mean removed, here per window).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis import blocks
from analysis.allan import ONE_SIGMA, Missing, TauGrid, cumulative_angle, overlapping_sums
from analysis.davar import DavarResult, _finish, _plan, _window_starts


def dynamic_allan_variance_by_window(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    window_s: float,
    step_s: float | None = None,
    taus: TauGrid | ArrayLike = "log",
    confidence: float = ONE_SIGMA,
    missing: Missing = "raise",
    angle_out: NDArray[np.float64] | None = None,
) -> DavarResult:
    """Dynamic Allan variance of a rate record (e.g. a memmap), one window at a time.

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate samples (e.g. deg/s); NaN marks a missing sample with ``missing="gap"``.
    sample_rate_hz, window_s, step_s, taus, confidence, missing
        As for :func:`analysis.davar.dynamic_allan_variance`: a window holding a missing
        sample of an axis gets NaN there.
    angle_out : ndarray, shape (Nw + 1, 1), optional
        Where to keep a window's cumulative angle when the window is long
        (:func:`analysis.blocks.is_long`): a memmap keeps it out of memory.

    Returns
    -------
    DavarResult
        Always 3-D (windows, taus, axes), as the streamed DAVAR's.

    Raises
    ------
    InvalidWindowError, TooFewSamplesError, NonFiniteSamplesError, InvalidSampleRateError
        As for :func:`analysis.davar.dynamic_allan_variance`.

    References
    ----------
    Zhang et al., Acta Optica Sinica 35(4), 2015, eq. 5-6.
    """
    if missing not in ("raise", "gap"):
        raise ValueError(f"missing must be 'raise' or 'gap', got {missing!r}")
    x = np.asarray(samples)
    x = x[:, None] if x.ndim == 1 else x
    plan = _plan(sample_rate_hz, window_s, step_s, taus)
    starts = _window_starts(x.shape[0], plan)
    angle = angle_out if blocks.is_long(plan.window) else None
    sums = np.empty((len(starts), len(plan.m), x.shape[1]))
    for j, start in enumerate(starts):
        for c in range(x.shape[1]):
            seg = x[start : start + plan.window, c]
            if missing == "gap" and blocks.any_where(seg, np.isnan):
                sums[j, :, c] = np.nan
                continue
            theta = cumulative_angle(seg, plan.fs, out=angle)
            sums[j, :, c] = overlapping_sums(theta, plan.m)[:, 0]
            blocks.release(x)
            blocks.release(theta)
    return _finish(sums, starts, plan, x.shape[0], confidence=confidence, squeeze=False)
