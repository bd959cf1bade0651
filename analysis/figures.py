"""Spec-sheet figures of a static gyro run: bias, bias stability, and the IEEE 952 read-offs.

Every figure carries its unit in its name. The read-offs follow IEEE Std 952-1997,
Annex C: the angle random walk is the value at tau = 1 h of the -1/2-slope line through
the Allan deviation (equivalently ``sigma(tau) sqrt(tau)`` on that line), and the bias
instability is the flat minimum of the Allan deviation divided by ``sqrt(2 ln 2 / pi)``
(0.664).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import AllanResult, as_samples, check_sample_rate, chi2_interval
from analysis.fit import NoiseCoefficients
from analysis.fog import measure_bias_stability
from analysis.units import S_PER_H

#: Local log-log slope of the Allan deviation accepted as "the -1/2 line".
ARW_SLOPE_TOLERANCE = 0.15
BIAS_INSTABILITY_FACTOR = 0.664


@dataclass(frozen=True)
class BiasStability:
    """Standard deviation of consecutive non-overlapping averages of ``average_s`` seconds.

    The definition of bias stability used by the FOG simulation paper (Lv 2014) and by
    most FOG data sheets. ``ci_low_deg_h``/``ci_high_deg_h`` is the +-1 sigma chi-square
    interval with ``n_averages - 1`` degrees of freedom (exact for independent averages).
    """

    average_s: float
    value_deg_h: float | None
    n_averages: int
    ci_low_deg_h: float | None = None
    ci_high_deg_h: float | None = None


def bias_stability(
    rate_deg_s: ArrayLike, sample_rate_hz: float, average_s: float
) -> BiasStability:
    """Bias stability (deg/h): std (ddof=1) of ``average_s``-second means of a 1-D rate record.

    NaN marks a missing sample (a record with gaps on its time grid): an average that
    would include one is left out. Returns a value of ``None`` when the record holds
    fewer than 3 whole averages.
    """
    fs = check_sample_rate(sample_rate_hz)
    x, gapped = _rate_column(rate_deg_s)
    m = int(round(average_s * fs))
    if m < 1:
        raise ValueError(f"averaging time {average_s} s is shorter than one sample at {fs} Hz")
    count = len(x) // m
    if gapped:
        means = x[: count * m].reshape(count, m).mean(axis=1)
        means = means[np.isfinite(means)]
        count = len(means)
    if count < 3:
        return BiasStability(average_s, None, count)
    if gapped:
        std = float(np.std(means, ddof=1)) * S_PER_H
    else:
        std = float(measure_bias_stability(x, fs, average_s=average_s))
    low, high = chi2_interval(std**2, count - 1)
    return BiasStability(average_s, std, count, math.sqrt(float(low)), math.sqrt(float(high)))


def _rate_column(rate_deg_s: ArrayLike) -> tuple[NDArray[np.float64], bool]:
    """A 1-D rate record and whether it has missing samples (NaN); infinities are refused."""
    x = np.asarray(rate_deg_s, dtype=np.float64)
    x = x.reshape(-1) if x.ndim == 2 and x.shape[1] == 1 else x
    missing = np.isnan(x)
    if not missing.any():
        return as_samples(x)[:, 0], False
    if x.ndim != 1 or np.isinf(x).any() or missing.all():
        raise ValueError("a rate record with gaps must be 1-D with NaN only where samples are missing")
    return x, True


@dataclass(frozen=True)
class ReadOff:
    """A figure read off the Allan deviation curve, with the tau range it came from (s)."""

    value: float | None
    tau_low_s: float | None
    tau_high_s: float | None
    note: str = ""


def local_adev_slope(tau_s: NDArray[np.float64], adev: NDArray[np.float64]) -> NDArray[np.float64]:
    """Log-log slope of the Allan deviation at each tau, over about an octave either side."""
    logt, loga = np.log(tau_s), np.log(adev)
    if len(logt) < 2:
        return np.full(len(logt), np.nan)
    lo = np.maximum(logt - math.log(2), logt[0])
    hi = np.minimum(logt + math.log(2), logt[-1])
    return (np.interp(hi, logt, loga) - np.interp(lo, logt, loga)) / np.where(hi > lo, hi - lo, 1.0)


def arw_readoff(result: AllanResult) -> ReadOff:
    """Angle random walk (deg/sqrt(h)) read off the -1/2 slope region of a 1-D Allan curve.

    The taus whose local slope is within ``ARW_SLOPE_TOLERANCE`` of -1/2 form the white
    rate region; the -1/2 line is fitted there (geometric mean of ``sigma sqrt(tau)``,
    weighted by edf) and read at tau = 1 h. When no tau qualifies, the tau whose slope is
    closest to -1/2 is used and the note says so.
    """
    tau, adev = result.tau_s, np.sqrt(result.avar)
    slope = local_adev_slope(tau, adev)
    near = np.abs(slope + 0.5) <= ARW_SLOPE_TOLERANCE
    note = ""
    if not near.any():
        near = np.zeros(len(tau), dtype=bool)
        near[int(np.nanargmin(np.abs(slope + 0.5)))] = True
        note = f"no -1/2 slope region; nearest slope {slope[near][0]:.2f}"
    else:
        # keep the first contiguous run: the white-rate region sits left of the minimum
        first = int(np.argmax(near))
        stop = first + int(np.argmin(near[first:])) if not near[first:].all() else len(near)
        near = np.zeros(len(tau), dtype=bool)
        near[first:stop] = True
    w = np.asarray(result.edf, dtype=float)[near]
    log_n = np.average(np.log(adev[near] * np.sqrt(tau[near])), weights=w)
    value = math.exp(log_n) * math.sqrt(S_PER_H)  # deg/s*sqrt(s) = deg/sqrt(s) -> deg/sqrt(h)
    return ReadOff(value, float(tau[near][0]), float(tau[near][-1]), note)


def bias_instability_readoff(result: AllanResult) -> ReadOff:
    """Bias instability (deg/h): minimum of the Allan deviation / 0.664 (IEEE 952 Annex C).

    When the minimum is at the longest tau the curve had not flattened yet: the value
    is then an upper bound and the note says so.
    """
    adev = np.sqrt(result.avar)
    i = int(np.argmin(adev))
    note = ""
    if i == len(adev) - 1:
        note = "minimum at the longest tau: upper bound, record longer"
    value = float(adev[i]) / BIAS_INSTABILITY_FACTOR * S_PER_H
    tau = float(result.tau_s[i])
    return ReadOff(value, tau, tau, note)


@dataclass(frozen=True)
class SpecFigures:
    """The spec-sheet figures of one axis, each in the unit its name ends with."""

    bias_deg_h: float
    bias_stability_10s_deg_h: float | None
    bias_stability_100s_deg_h: float | None
    arw_deg_rt_h: float | None
    arw_tau_range_s: tuple[float | None, float | None]
    arw_fit_deg_rt_h: float | None
    bias_instability_deg_h: float | None
    bias_instability_tau_s: float | None
    bias_instability_fit_deg_h: float | None
    quantization_fit_urad: float | None
    rrw_deg_h_1_5: float | None
    rate_ramp_deg_h2: float | None
    notes: tuple[str, ...] = ()
    #: Earth-rate projection taken off the bias (deg/h); None when it was not removed.
    earth_rate_removed_deg_h: float | None = None

    def as_dict(self) -> dict[str, object]:
        """JSON form (tuples become lists)."""
        out = asdict(self)
        out["arw_tau_range_s"] = list(self.arw_tau_range_s)
        out["notes"] = list(self.notes)
        return out


def spec_figures(
    rate_deg_s: ArrayLike, sample_rate_hz: float, result: AllanResult, fit: NoiseCoefficients
) -> SpecFigures:
    """Every spec figure of one axis: bias, bias stability (10 s, 100 s), read-offs and fit.

    Parameters
    ----------
    rate_deg_s : array_like, shape (N,)
        The axis' rate record in deg/s, NaN where a sample is missing (a record with gaps).
    sample_rate_hz : float
        Sample rate in Hz.
    result : AllanResult
        The axis' Allan variance (1-D).
    fit : NoiseCoefficients
        The axis' five-term fit.
    """
    x, _ = _rate_column(rate_deg_s)
    bs10 = bias_stability(x, sample_rate_hz, 10.0)
    bs100 = bias_stability(x, sample_rate_hz, 100.0)
    arw = arw_readoff(result)
    bi = bias_instability_readoff(result)
    notes = tuple(
        f"{name}: {r.note}" for name, r in (("ARW read-off", arw), ("bias instability read-off", bi)) if r.note
    )
    if bs100.value_deg_h is None:
        notes += (f"bias stability 100 s: only {bs100.n_averages} averages, needs 3",)
    return SpecFigures(
        bias_deg_h=float(np.nanmean(x)) * S_PER_H,
        bias_stability_10s_deg_h=bs10.value_deg_h,
        bias_stability_100s_deg_h=bs100.value_deg_h,
        arw_deg_rt_h=arw.value,
        arw_tau_range_s=(arw.tau_low_s, arw.tau_high_s),
        arw_fit_deg_rt_h=fit.values["N"],
        bias_instability_deg_h=bi.value,
        bias_instability_tau_s=bi.tau_low_s,
        bias_instability_fit_deg_h=fit.values["B"],
        quantization_fit_urad=fit.values["Q"],
        rrw_deg_h_1_5=fit.values["K"],
        rate_ramp_deg_h2=fit.values["R"],
        notes=notes,
    )
