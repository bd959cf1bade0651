"""What a rate word of LSB q can resolve: the quantization floor of each graded figure.

A rate output rounded to steps of q (deg/s) carries a rounding error that is uniform on
+-q/2 (variance q^2/12) and independent from sample to sample as long as the gyro's own
noise moves the output across several steps (Widrow's quantization theorem: a noise of at
least about q/2 a sample). That error is white rate noise, so its Allan deviation is

    sigma_Q(tau) = q / sqrt(12 f tau)          (f the sample rate, tau >= 1/f)

and its angle random walk ``N_Q = q / sqrt(12 f)`` (deg/sqrt(s); x 60 for deg/sqrt(h)).
(IEEE Std 952-1997 Annex C's quantization term, sigma^2 = 3 Q^2 / tau^2 with
Q = step / sqrt(12), is the same rounding of an *angle* output, a delta-angle word whose
remainder is carried: its error does not add up. A rate word's does, sample after sample,
hence the slope -1/2 here.) A record of such a word holds this noise on top of the gyro's:
its Allan deviation never lies below sigma_Q. A figure whose upper confidence bound lies
below sigma_Q at the tau it is read from (its *floor*) therefore was not measured: the
output did not move across its steps (a stuck output, a noise far under one LSB), and
the figure says nothing about the gyro. :mod:`station.evaluation.resolution` grades such
a figure indeterminate; :func:`unresolvable_limits` refuses a profile whose limits lie
below the floor of its own transport (a unit meeting them could not be seen doing so).

Floors per figure (canonical units: deg/h, deg/sqrt(h)):

==============================  ==========================================================
``arw``, ``arw_fit``            ``60 q / sqrt(12 f)``
``bias_instability[_fit]``      ``sigma_Q(tau_B) / 0.664`` (tau_B: where the minimum is read)
``adev_min``                    ``sigma_Q(tau_min)``
``bias_stability_<T>s``         ``sigma_Q(T)`` (the std of T-second averages of the error)
``bias``                        the half-width of its batch-means interval with the error
                                alone: ``t(9) sigma_Q(T_batch) / sqrt(10)``, T_batch one
                                tenth of the record; compared with the interval's width
==============================  ==========================================================
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Protocol

from analysis.distributions import t_ppf
from analysis.figures.readoffs import BIAS_INSTABILITY_FACTOR
from analysis.units.conversions import S_PER_H
from devices.resolution import safe_url_resolution
from devices.url_text import url_keys
from station.model.figure_names import bias_stability_average_s

#: Batches of the bias' batch-means interval (station.evaluation.figure_intervals).
BIAS_BATCHES = 10


def quantization_adev_deg_s(lsb_deg_s: float, rate_hz: float, tau_s: float) -> float:
    """Allan deviation (deg/s) of the rounding error of a rate word of step ``lsb_deg_s``
    (deg/s) sampled at ``rate_hz`` (Hz), at ``tau_s`` (s; at least one sample)."""
    n = max(1.0, rate_hz * tau_s)
    return lsb_deg_s / math.sqrt(12.0 * n)


def arw_floor_deg_rt_h(lsb_deg_s: float, rate_hz: float) -> float:
    """The angle random walk of the rounding error alone, deg/sqrt(h): 60 q / sqrt(12 f)."""
    return math.sqrt(S_PER_H) * lsb_deg_s / math.sqrt(12.0 * rate_hz)


def bias_floor_deg_h(lsb_deg_s: float, rate_hz: float, record_s: float,
                     confidence: float) -> float:
    """Half-width (deg/h) of the bias' batch-means interval that the rounding error alone
    gives a record of ``record_s`` seconds."""
    t = float(t_ppf(0.5 + confidence / 2, BIAS_BATCHES - 1))
    sigma = quantization_adev_deg_s(lsb_deg_s, rate_hz, record_s / BIAS_BATCHES)
    return t * sigma * S_PER_H / math.sqrt(BIAS_BATCHES)


def figure_floor(name: str, lsb_deg_s: float, rate_hz: float, tau_s: float | None, *,
                 record_s: float, confidence: float) -> float | None:
    """The quantization floor of figure ``name`` in its canonical unit (module docstring);
    ``tau_s``: the tau its Allan read-off is taken at (bias instability, Allan minimum;
    None: the longest, half the record); None for a figure without one (fitted Q, K, R,
    accelerometer figures)."""
    average_s = bias_stability_average_s(name)
    if average_s is not None:
        return quantization_adev_deg_s(lsb_deg_s, rate_hz, average_s) * S_PER_H
    if name in ("arw", "arw_fit"):
        return arw_floor_deg_rt_h(lsb_deg_s, rate_hz)
    if name == "bias":
        return bias_floor_deg_h(lsb_deg_s, rate_hz, record_s, confidence)
    if name in ("bias_instability", "bias_instability_fit", "adev_min"):
        tau = tau_s if tau_s is not None and tau_s > 0 else record_s / 2
        level = quantization_adev_deg_s(lsb_deg_s, rate_hz, tau) * S_PER_H
        return level if name == "adev_min" else level / BIAS_INSTABILITY_FACTOR
    return None


class LimitedFigure(Protocol):
    """A profile's figure with its limits (:class:`station.model.profiles.FigureSpec`)."""

    @property
    def name(self) -> str: ...
    @property
    def unit(self) -> str: ...
    @property
    def limits(self) -> dict[str, float]: ...
    @property
    def unit_factor(self) -> float: ...


@dataclass(frozen=True)
class UnresolvableLimit:
    """A profile limit below what its transport resolves (canonical unit)."""

    figure: str
    grade: str
    limit: float
    floor: float


def unresolvable_limits(limits: Iterable[tuple[str, str, float]], lsb_deg_s: float,
                        rate_hz: float, record_s: float, confidence: float
                        ) -> list[UnresolvableLimit]:
    """The limits (figure, grade, limit in the canonical unit) below their figure's floor
    for a test of ``record_s`` seconds (after the warm-up) at ``rate_hz``; the floors of
    level figures at the longest tau, half the record (the most a test could resolve)."""
    out = []
    for name, grade, limit in limits:
        floor = figure_floor(name, lsb_deg_s, rate_hz, None, record_s=record_s,
                             confidence=confidence)
        if floor is not None and limit < floor:
            out.append(UnresolvableLimit(name, grade, limit, floor))
    return out


def check_limits_resolved(figures: Iterable[LimitedFigure], url: object, rate_hz: float | None,
                          record_s: float, confidence: float,
                          fail: Callable[[tuple[str, ...], str], Exception]) -> None:
    """Refuse a profile whose transport ``url`` cannot resolve one of its limits (a
    fixed-point rate word whose floor lies above the limit, :func:`unresolvable_limits`).

    ``rate_hz`` is the profile's sample rate (None: the URL's ``rate``); ``record_s`` the
    test after its warm-up, s. ``fail(key, message)`` builds the error raised.
    """
    if not isinstance(url, str):
        return
    resolution = safe_url_resolution(url)
    rate = rate_hz or _url_rate(url)
    if resolution is None or not resolution.lsb_deg_s > 0 or rate is None:
        return
    limits = [(f, g, limit * f.unit_factor) for f in figures for g, limit in f.limits.items()]
    by_name = {f.name: f for f, _, _ in limits}
    for bad in unresolvable_limits(((f.name, g, v) for f, g, v in limits),
                                   resolution.lsb_deg_s, rate, record_s, confidence):
        spec = by_name[bad.figure]
        raise fail(("figures", bad.figure, "limits", bad.grade),
                   f"limit {bad.limit / spec.unit_factor:.3g} {spec.unit} ({bad.grade}) is "
                   f"below what the transport resolves: its rate word's LSB "
                   f"{resolution.lsb_deg_s:.3g} deg/s at {rate:g} Hz leaves a quantization "
                   f"floor of {bad.floor / spec.unit_factor:.3g} {spec.unit} "
                   f"(docs/grading.md, \"Resolution\"); give [transport] a protocol "
                   f"with a finer LSB, or a looser limit")


def _url_rate(url: str) -> float | None:
    try:
        rate = float(url_keys(url).get("rate", ""))
    except ValueError:
        return None
    return rate if rate > 0 and math.isfinite(rate) else None
