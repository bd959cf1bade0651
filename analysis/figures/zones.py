"""Tau zones where the five-term model does not describe the Allan curve: tones and an output
filter.

The five IEEE terms (Lv 2015 eq. 3) describe a gyro's noise, not everything a real record
holds. Two things are common on MEMS parts and are recognised here, so that neither the
fit nor a read-off is taken inside them:

* **A tone** (:mod:`analysis.figures.tones`): a narrow-band line adds a bump and then a -1 slope to
  the Allan deviation at taus of a few periods, which the fit would report as
  quantization noise. Its zone is the taus where the Allan variance of the lines found
  (computed from their excess power) is more than :data:`TONE_SHARE` of the measured one.
* **An output filter**: a low-pass filter (a MEMS part's digital filter) removes variance
  at the shortest taus, so the curve there lies *below* white noise: ``sigma sqrt(tau)``
  rises with tau toward the white-noise level instead of falling from a quantization
  excess. Its zone is the run of shortest taus where the measured Allan variance is below
  the fitted model by more than :data:`FILTER_TOLERANCE` (and by more than three times
  the value's own relative error) with a local slope shallower than -1/2.

:func:`fit_outside_zones` fits the model without the zones, re-detects the filter zone
with the new fit, and repeats until the zones settle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.allan.estimators import AllanResult
from analysis.figures.tones import Tone, tones_avar
from analysis.fit.least_squares import TERMS, FitMethod, NoiseCoefficients, fit_noise_terms

#: A tone's zone: taus where its Allan variance exceeds this share of the measured one.
TONE_SHARE = 0.05
#: An output filter's zone: taus where the curve is this far (relative) below the fitted model.
FILTER_TOLERANCE = 0.05
#: Most refits while the filter zone settles.
MAX_REFITS = 3


@dataclass(frozen=True)
class TauZone:
    """A closed tau range (s) left out of the fit and the read-offs, and why.

    ``kind`` is ``"tone"`` or ``"output filter"``; ``reason`` says it in a sentence.
    """

    tau_low_s: float
    tau_high_s: float
    kind: str
    reason: str

    def contains(self, tau_s: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which of ``tau_s`` lie in the zone."""
        return (tau_s >= self.tau_low_s) & (tau_s <= self.tau_high_s)

    def as_dict(self) -> dict[str, object]:
        """JSON form."""
        return {"tau_low_s": self.tau_low_s, "tau_high_s": self.tau_high_s, "kind": self.kind,
                "reason": self.reason}


def outside_zones(tau_s: NDArray[np.float64], zones: Sequence[TauZone]) -> NDArray[np.bool_]:
    """Which taus lie outside every zone."""
    keep = np.ones(len(tau_s), dtype=bool)
    for zone in zones:
        keep &= ~zone.contains(tau_s)
    return keep


def tone_zone(
    result: AllanResult, tones: Sequence[Tone], *, share: float = TONE_SHARE
) -> TauZone | None:
    """The taus where the tones' Allan variance exceeds ``share`` of the measured (None if none)."""
    if not tones:
        return None
    tone_var = tones_avar(tuple(tones), result.tau_s, result.sample_rate_hz)
    over = np.flatnonzero(tone_var > share * np.asarray(result.avar))
    if over.size == 0:
        return None
    lo, hi = float(result.tau_s[over[0]]), float(result.tau_s[over[-1]])
    freqs = ", ".join(f"{t.freq_hz:.3g} Hz" for t in tones)
    return TauZone(
        lo,
        hi,
        "tone",
        f"tone at {freqs} makes more than {share:.0%} of the Allan variance "
        f"at tau {lo:.3g}-{hi:.3g} s",
    )


def filter_zone(result: AllanResult, fit: NoiseCoefficients, *, skip: Sequence[TauZone] = (),
                tolerance: float = FILTER_TOLERANCE) -> TauZone | None:
    """The shortest taus where the curve lies below the fitted model: an output filter (or None).

    Only taus outside ``skip`` are looked at; the zone starts at the shortest of them and
    ends at the last of the leading run that is more than ``tolerance`` (and three of its
    own relative errors) below the model with a local Allan-deviation slope above -1/2.
    """
    if not fit.values.get("N"):
        return None
    tau = result.tau_s
    avar = np.asarray(result.avar)
    model = fit.model_avar(tau)
    edf = np.asarray(result.edf, dtype=float)
    below = (avar < model * (1.0 - np.maximum(tolerance, 3.0 * np.sqrt(2.0 / edf)))) & (model > 0)
    logt, loga = np.log(tau), np.log(avar)
    rising = np.gradient(loga, logt) > -1.0 if len(tau) > 1 else np.zeros(len(tau), dtype=bool)
    candidates = np.flatnonzero(outside_zones(tau, skip))
    run = []
    for i in candidates:
        if not (below[i] and rising[i]):
            break
        run.append(i)
    if not run:
        return None
    lo, hi = float(tau[run[0]]), float(tau[run[-1]])
    depth = 1.0 - math.sqrt(float(avar[run[0]] / model[run[0]]))
    return TauZone(
        lo,
        hi,
        "output filter",
        f"the curve lies below white noise at tau {lo:.3g}-{hi:.3g} s "
        f"({depth:.0%} below the fitted model at {lo:.3g} s): an output filter",
    )


def fit_outside_zones(
    result: AllanResult,
    tones: Sequence[Tone] = (),
    *,
    method: FitMethod = "logwls",
    terms: str = TERMS,
    select: bool | None = None,
) -> tuple[NoiseCoefficients, tuple[TauZone, ...]]:
    """The five-term fit without the tone and output-filter zones, and the zones.

    The tone zone comes from the tones found in the time series; the filter zone from
    the fit, so the fit is repeated (at most :data:`MAX_REFITS` times) until no further
    short taus fall below it. ``select`` is :func:`analysis.fit.fit_noise_terms`'.
    """
    zones: list[TauZone] = []
    tz = tone_zone(result, tones)
    if tz is not None:
        zones.append(tz)

    def fit() -> NoiseCoefficients:
        ranges = tuple((z.tau_low_s, z.tau_high_s) for z in zones)
        return fit_noise_terms(
            result, method=method, terms=terms, exclude_tau_s=ranges, select=select
        )

    coefficients = fit()
    others = list(zones)
    current: TauZone | None = None
    for _ in range(MAX_REFITS):
        fz = filter_zone(result, coefficients, skip=others)
        if fz == current or fz is None and current is None:
            break
        current = fz
        zones = others + ([fz] if fz is not None else [])
        coefficients = fit()
    return coefficients, tuple(zones)
