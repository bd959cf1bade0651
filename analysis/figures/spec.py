"""Spec-sheet figures of a static gyro run: bias, bias stability, read-offs, fit, and review.

Every figure carries its unit in its name. The read-offs (:mod:`analysis.figures.readoffs`)
follow IEEE Std 952-1997, Annex C; each has an interval from the edf of the Allan values
it was read from. The angle random walk and the bias instability are each measured twice,
read off the curve and fitted (:mod:`analysis.fit`); when the two disagree by more than
their combined intervals, :func:`review_notes` says so and why, so that neither is
silently believed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import blocks
from analysis.allan.estimators import AllanResult, as_samples, check_sample_rate, chi2_interval
from analysis.allan.partial_clusters import (
    MAX_MISSING_SHARE,
    corrected_mean_variance,
    partial_means,
    white_level,
)
from analysis.distributions import normal_ppf
from analysis.figures.readoffs import (
    BIAS_INSTABILITY_FACTOR,
    ReadOff,
    arw_readoff,
    bias_instability_readoff,
    white_share,
)
from analysis.figures.zones import TauZone
from analysis.fit.least_squares import NoiseCoefficients, log_tau_share
from analysis.models.fog import measure_bias_stability
from analysis.units.conversions import S_PER_H

#: Confidence level at which read-off and fit are compared for ``review``.
REVIEW_CONFIDENCE = 0.95
#: A misfit of the model (or a share of other terms) smaller than this is not named as a cause.
CAUSE_THRESHOLD = 0.02
#: The fitted curve this far (in deviation) from the smoothed minimum is named as the cause.
MISFIT_THRESHOLD = 0.1


@dataclass(frozen=True)
class BiasStability:
    """Standard deviation of consecutive non-overlapping averages of ``average_s`` seconds.

    The definition of bias stability used by the FOG simulation paper (Lv 2014) and by
    most FOG data sheets. ``ci_low_deg_h``/``ci_high_deg_h`` is the +-1 sigma chi-square
    interval with ``edf`` degrees of freedom: ``n_averages - 1`` (exact for independent
    averages), reduced by the share of samples missing from partial averages
    (:mod:`analysis.allan.partial_clusters`; ``missing_share`` of the kept averages' samples).
    """

    average_s: float
    value_deg_h: float | None
    n_averages: int
    ci_low_deg_h: float | None = None
    ci_high_deg_h: float | None = None
    edf: float | None = None
    missing_share: float = 0.0


def bias_stability(
    rate_deg_s: ArrayLike, sample_rate_hz: float, average_s: float, *,
    white_level: float | None = None, max_missing_share: float = MAX_MISSING_SHARE,
) -> BiasStability:
    """Bias stability (deg/h): std (ddof=1) of ``average_s``-second means of a 1-D rate record.

    NaN marks a missing sample (a record with gaps on its time grid): an average missing
    at most ``max_missing_share`` of its samples is the mean of the present ones, its
    white-noise excess removed with ``white_level`` (``N^2`` in (deg/s)^2 s,
    :func:`analysis.allan.partial_clusters.white_level`) and the edf reduced for what is missing;
    one missing more is left out (:mod:`analysis.allan.partial_clusters`; a long record, a
    memmap, keeps only complete averages). Returns a value of ``None`` when the record
    holds fewer than 3 kept averages.
    """
    fs = check_sample_rate(sample_rate_hz)
    x, gapped = _rate_column(rate_deg_s)
    m = int(round(average_s * fs))
    if m < 1:
        raise ValueError(f"averaging time {average_s} s is shorter than one sample at {fs} Hz")
    count = len(x) // m
    if gapped and not blocks.is_long(len(x)):
        partial = partial_means(x, m, max_missing_share=max_missing_share)
        n = len(partial.means)
        if n < 3:
            return BiasStability(average_s, None, n)
        variance = corrected_mean_variance(partial, fs, white_level)
        edf = (n - 1) * (1.0 - partial.missing_share)
        low, high = chi2_interval(variance, edf)
        return BiasStability(average_s, math.sqrt(variance) * S_PER_H, n,
                             math.sqrt(float(low)) * S_PER_H, math.sqrt(float(high)) * S_PER_H,
                             edf, partial.missing_share)
    if gapped:
        means = blocks.group_means(x, m, count)
        means = means[np.isfinite(means)]
        count = len(means)
    if count < 3:
        return BiasStability(average_s, None, count)
    if gapped:
        std = float(np.std(means, ddof=1)) * S_PER_H
    else:
        std = float(measure_bias_stability(x, fs, average_s=average_s))
    low, high = chi2_interval(std**2, count - 1)
    return BiasStability(average_s, std, count, math.sqrt(float(low)), math.sqrt(float(high)),
                         float(count - 1))


def _rate_column(rate_deg_s: ArrayLike) -> tuple[NDArray[np.float64], bool]:
    """A 1-D rate record and whether it has missing samples (NaN); infinities are refused."""
    x = np.asarray(rate_deg_s, dtype=np.float64)
    x = x.reshape(-1) if x.ndim == 2 and x.shape[1] == 1 else x
    if blocks.is_long(len(x)):  # a long record (a memmap): checked a block at a time
        if not blocks.any_where(x, np.isnan):
            return as_samples(x)[:, 0], False
        if x.ndim != 1 or blocks.any_where(x, np.isinf) or not blocks.any_where(x, np.isfinite):
            raise ValueError(
                "a rate record with gaps must be 1-D with NaN only where samples are missing"
            )
        return x, True
    missing = np.isnan(x)
    if not missing.any():
        return as_samples(x)[:, 0], False
    if x.ndim != 1 or np.isinf(x).any() or missing.all():
        raise ValueError(
            "a rate record with gaps must be 1-D with NaN only where samples are missing"
        )
    return x, True


@dataclass(frozen=True)
class SpecFigures:
    """The spec-sheet figures of one axis, each in the unit its name ends with.

    ``arw_ci_deg_rt_h`` and ``bias_instability_ci_deg_h`` are the read-offs' intervals
    at the Allan result's confidence level (+-1 sigma by default); ``review`` lists why
    read-off and fit disagree (empty when they agree).
    """

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
    arw_ci_deg_rt_h: tuple[float | None, float | None] | None = None
    bias_instability_ci_deg_h: tuple[float | None, float | None] | None = None
    review: tuple[str, ...] = ()
    #: Earth-rate projection taken off the bias (deg/h); None when it was not removed.
    earth_rate_removed_deg_h: float | None = None
    #: The ARW read-off bounds N from above and does not measure it (no -1/2 region the
    #: curve allows white noise in: :func:`analysis.figures.readoffs.white_noise_bound`).
    arw_upper_bound: bool = False

    def as_dict(self) -> dict[str, object]:
        """JSON form (tuples become lists)."""
        out = asdict(self)
        for key in (
            "arw_tau_range_s",
            "notes",
            "arw_ci_deg_rt_h",
            "bias_instability_ci_deg_h",
            "review",
        ):
            value = getattr(self, key)
            out[key] = None if value is None else list(value)
        return out


def _disagree(read: ReadOff, value: float | None, stderr: float | None, confidence: float
              ) -> tuple[str, str] | None:
    """(how far apart, how far the intervals allow) when read-off and fit disagree, else None.

    Positive values compare in logs: ``|log(r / f)| > z sqrt(s_r^2 + s_f^2)``. A fit of
    exactly zero (the bound held) disagrees when the read-off's lower bound exceeds the
    fit's upper bound ``z stderr``. Not comparable (None): either figure missing.
    """
    if read.value is None or read.edf is None or read.value <= 0 or value is None:
        return None
    z = float(normal_ppf(0.5 + confidence / 2))
    known = stderr is not None and math.isfinite(stderr)
    if value <= 0:
        low, _ = read.interval(confidence)
        if not known or low is None or low <= z * (stderr or 0.0):
            return None
        return "the fit finds none", f"fit at most {z * (stderr or 0.0):.3g}"
    gap = abs(math.log(read.value / value))
    allowed = z * math.hypot(read.log_sd() or 0.0, (stderr / value) if known else 0.0)  # type: ignore[operator]
    if gap <= allowed:
        return None
    return f"differ by {math.expm1(gap):.0%}", f"{math.expm1(allowed):.1%}"


def _fit_text(value: float, stderr: float | None, unit: str) -> str:
    return (
        f"{value:.3g} +- {stderr:.2g} {unit}"
        if stderr is not None
        else f"{value:.3g} {unit} (no standard error)"
    )


def _region(result: AllanResult, read: ReadOff) -> NDArray[np.bool_]:
    tau = result.tau_s
    return (tau >= (read.tau_low_s or 0.0)) & (tau <= (read.tau_high_s or 0.0))


def fitted_arw_readoff_factor(result: AllanResult, fit: NoiseCoefficients, read: ReadOff) -> float:
    """What the fitted model's own curve would read off the ARW region, over its N (>= 1).

    The read-off takes ``sigma sqrt(tau)`` where white noise holds at least 95 % of the
    fitted curve; the rest (flicker, quantization) is in it too. Read the same way, the
    fitted model gives ``N`` times this factor: that, not ``N``, is what the read-off is
    compared with, so that a few per cent of other terms do not flag a unit.
    """
    share = white_share(result, fit)
    region = _region(result, read)
    if share is None or not region.any() or np.any(share[region] <= 0):
        return 1.0
    weights = (log_tau_share(result.tau_s) * np.asarray(result.edf, dtype=float))[region]
    return math.exp(0.5 * float(np.average(-np.log(share[region]), weights=weights)))


def _arw_cause(result: AllanResult, fit: NoiseCoefficients, read: ReadOff) -> str:
    region = _region(result, read)
    model = fit.model_avar(result.tau_s[region])
    if read.note:
        return read.note
    if np.all(model > 0):
        misfit = (
            math.exp(float(np.mean(np.log(np.asarray(result.avar)[region] / model))) / 2.0) - 1.0
        )
        if abs(misfit) > CAUSE_THRESHOLD:
            return (
                f"the fitted model lies {abs(misfit):.0%} {'below' if misfit > 0 else 'above'} the "
                "measured "
                f"curve at tau {read.tau_low_s:.3g}-{read.tau_high_s:.3g} s, where the read-off is "
                "taken: "
                "the five terms do not follow the curve there"
            )
    return "the difference is beyond both figures' statistical intervals; check the Allan plot"


def _bias_instability_cause(fit: NoiseCoefficients, read: ReadOff) -> str:
    causes = [read.note] if read.note else []
    tau = np.array([read.tau_low_s or 0.0])
    model = float(fit.model_avar(tau)[0])
    if model > 0 and read.value is not None:
        measured = (read.value * BIAS_INSTABILITY_FACTOR / S_PER_H) ** 2
        misfit = math.sqrt(model / measured) - 1.0
        shares = {t: float(fit.term_avar(t, tau)[0]) / model for t in "QNKR"}
        flicker = float(fit.term_avar("B", tau)[0]) / model
        if abs(misfit) > MISFIT_THRESHOLD:
            causes.append(
                f"the fitted model lies {abs(misfit):.0%} {'above' if misfit > 0 else 'below'} the "
                f"smoothed curve at tau {tau[0]:.3g} s: the five terms do not follow the curve "
                "around "
                "its minimum (station reconcile names what they miss)"
            )
        elif flicker < 1.0 - CAUSE_THRESHOLD:
            names = {
                "Q": "quantization",
                "N": "white rate noise",
                "K": "rate random walk",
                "R": "rate ramp",
            }
            listed = [
                names[t]
                for t, v in sorted(shares.items(), key=lambda kv: -kv[1])
                if v > CAUSE_THRESHOLD
            ]
            others = " and ".join(
                [", ".join(listed[:-1]), listed[-1]] if len(listed) > 1 else listed
            )
            causes.append(
                f"the Allan minimum at tau {tau[0]:.3g} s is not a flicker floor: the fitted "
                f"{others} "
                f"{'hold' if len(listed) > 1 else 'holds'} {1.0 - flicker:.0%} of it, and "
                "sigma_min / 0.664 assumes flicker noise alone"
            )
    return (
        "; ".join(causes)
        or "the smoothed minimum and the fitted flicker floor differ beyond both intervals"
    )


def review_notes(
    result: AllanResult,
    fit: NoiseCoefficients,
    arw: ReadOff,
    bias_instability: ReadOff,
    *,
    confidence: float = REVIEW_CONFIDENCE,
    which: tuple[str, ...] = ("arw", "bias_instability"),
) -> tuple[str, ...]:
    """Why read-off and fit of ARW and bias instability disagree, one line each (empty: they agree).

    They disagree when ``|log(read-off / fit)|`` exceeds ``z sqrt(s_r^2 + s_f^2)``: ``z``
    the two-sided normal quantile of ``confidence``, ``s_r = 1 / sqrt(2 edf)`` the
    read-off's and ``s_f = stderr / value`` the fit's relative standard error (0 when the
    fit gives none); a fit of zero disagrees when the read-off's lower bound is above
    ``z stderr``. A term the fit could not estimate (``None``) is not compared. The ARW
    read-off is compared with the fitted curve read the same way (N times
    :func:`fitted_arw_readoff_factor`), the bias-instability read-off with B itself: the
    flicker floor is what sigma_min / 0.664 claims to measure. ``which`` names the pairs.
    """
    notes = []
    pairs: dict[str, tuple[ReadOff, str, str, str, Callable[[], str]]] = {
             "arw": (arw, "N", "ARW", "deg/sqrt(h)", lambda: _arw_cause(result, fit, arw)),
             "bias_instability": (bias_instability, "B", "bias instability", "deg/h",
                                  lambda: _bias_instability_cause(fit, bias_instability))}
    for key in which:
        read, term, label, unit, cause = pairs[key]
        value, stderr = fit.values.get(term), fit.stderr.get(term)
        factor = fitted_arw_readoff_factor(result, fit, read) if key == "arw" else 1.0
        apart = _disagree(read, None if value is None else value * factor,
                          None if stderr is None else stderr * factor, confidence)
        if apart is None:
            continue
        assert read.value is not None and value is not None
        low, high = read.interval(confidence)
        as_read = (
            f" ({value * factor:.3g} read off the fitted curve the same way)"
            if factor > 1.001
            else ""
        )
        notes.append(
            f"{label}: read-off {read.value:.3g} [{low:.3g}, {high:.3g}] and fit "
            f"{_fit_text(value, stderr, unit)}{as_read} {apart[0]}, more than their combined "
            f"{confidence:.0%} intervals allow ({apart[1]}): {cause()}"
        )
    return tuple(notes)


def spec_figures(
    rate_deg_s: ArrayLike, sample_rate_hz: float, result: AllanResult, fit: NoiseCoefficients, *,
    zones: tuple[TauZone, ...] = (),
) -> SpecFigures:
    """Every spec figure of one axis: bias, bias stability (10 s, 100 s), read-offs, fit, review.

    Parameters
    ----------
    rate_deg_s : array_like, shape (N,)
        The axis' rate record in deg/s, NaN where a sample is missing (a record with gaps).
    sample_rate_hz : float
        Sample rate in Hz.
    result : AllanResult
        The axis' Allan variance (1-D).
    fit : NoiseCoefficients
        The axis' five-term fit (made without ``zones``:
        :func:`analysis.figures.zones.fit_outside_zones`).
    zones : tuple of TauZone
        Tau ranges the five-term model does not describe; no read-off is taken there.
    """
    x, _ = _rate_column(rate_deg_s)
    white = white_level(result)
    bs10 = bias_stability(x, sample_rate_hz, 10.0, white_level=white)
    bs100 = bias_stability(x, sample_rate_hz, 100.0, white_level=white)
    arw = arw_readoff(result, fit, zones=zones)
    bi = bias_instability_readoff(result, zones=zones)
    notes = tuple(
        f"fit and read-offs leave out tau {z.tau_low_s:.3g}-{z.tau_high_s:.3g} s: {z.reason}"
        for z in zones
    )
    notes += tuple(
        f"{name}: {r.note}"
        for name, r in (("ARW read-off", arw), ("bias instability read-off", bi))
        if r.note
    )
    if bs100.value_deg_h is None:
        notes += (f"bias stability 100 s: only {bs100.n_averages} averages, needs 3",)
    return SpecFigures(
        bias_deg_h=S_PER_H
        * (blocks.nan_mean(x) if blocks.is_long(len(x)) else float(np.nanmean(x))),
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
        arw_ci_deg_rt_h=arw.interval(result.confidence) if arw.value is not None else None,
        bias_instability_ci_deg_h=bi.interval(result.confidence) if bi.value is not None else None,
        review=review_notes(result, fit, arw, bi),
        arw_upper_bound=arw.upper_bound,
    )
