"""The noise parameters a Kalman filter or simulator takes, from an axis' analysis.

Which figure feeds which parameter (:func:`axis_noise`; ``AxisNoise.sources`` names it
per axis). The fit is the reading a spec sheet prints
(:func:`station.evaluation.readings.best_supported`: one term set, the one the record
supports best), never the largest fit of each term taken from different readings:

* angle random walk N: the five-term fit's N (``logwls``) or the GMWM's white noise
  (``gmwm``; its white-noise equivalent where a Gauss-Markov or AR(1) term is faster than
  the shortest tau, :mod:`analysis.gmwm.equivalent`), else the IEEE 952 read-off;
* bias instability B: the IEEE 952 read-off ``sigma_min / 0.664`` (the spec figure), or
  the GMWM's flicker term when its model has one; else the fit's B;
* rate random walk K: the fit's K, or the GMWM's random walk; a K the record does not
  resolve (fitted to zero) is its 1-sigma upper bound, and the source says so, because a
  filter given no bias random walk at all trusts its bias estimate for ever; where the
  record allows other readings (:mod:`analysis.figures.ambiguity`) and the printed one
  drops K, the bound covers every reading (their ``K + 1 sigma``), the source naming the
  alternatives; a printed K above 0 is written as it is;
* Gauss-Markov terms: the GMWM's ``gm`` terms (``gmwm``) but those in the white-noise
  equivalent, none otherwise.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from analysis.figures.tool_units import AxisNoise, GaussMarkovBias
from analysis.fit.least_squares import NoiseCoefficients
from analysis.gmwm.equivalent import WN_EQUIVALENT_KEY
from analysis.gmwm.result import GmwmFit
from station.errors import UsageError
from station.evaluation.analysis_options import DEFAULT_METHOD, GMWM_METHOD
from station.evaluation.readings import (
    Reading,
    alternative_readings,
    best_supported,
    covering_interval,
)

if TYPE_CHECKING:
    from station.evaluation.axis_analysis import AxisAnalysis

#: The methods noise parameters come from: the Allan fit and read-offs, or the GMWM beside them.
EXPORT_METHODS: tuple[str, ...] = (DEFAULT_METHOD, GMWM_METHOD)


def _positive(value: float | None) -> bool:
    return value is not None and math.isfinite(value) and value > 0


def _rrw(value: float | None, stderr: float | None, what: str) -> tuple[float, str]:
    """(K, its source) from a fitted value and its standard error."""
    if _positive(value):
        return float(value), what  # type: ignore[arg-type]
    if _positive(stderr):
        return float(stderr), f"{what}: upper bound (1 sigma), the record does not resolve K"  # type: ignore[arg-type]
    return 0.0, f"{what}: none found and no bound"


def _printed_rrw(fit: NoiseCoefficients) -> tuple[float, str]:
    """K of the reading a sheet prints (``fit``, :func:`best_supported`); where that
    reading drops K, the 1-sigma upper bound that covers every reading the record allows
    (:func:`station.evaluation.readings.covering_interval`), its source saying it is a
    bound; the source names the other readings."""
    what = f"fit ({fit.method}, terms {fit.terms})"
    k, err = fit.values.get("K"), fit.stderr.get("K")
    if not fit.alternatives:
        return _rrw(k, err, what)
    allowed = "ambiguous: the record also allows " + "; ".join(
        a.describe() for a in fit.alternatives)
    if _positive(k):
        return float(k or 0.0), f"{what}; {allowed}"
    printed = Reading(fit.terms, k or 0.0, None, (k or 0.0) + (err or 0.0))
    _, high = covering_interval(printed, alternative_readings(fit, "K", 1.0))
    if high is None or not _positive(high):
        return 0.0, f"{what}: none found and no bound; {allowed}"
    return high, (f"{what}: upper bound (1 sigma) over the readings the record allows, "
                  f"the printed reading does not resolve K; {allowed}")


def _is_fast(fit: GmwmFit, sigma_key: str) -> bool:
    """Whether the Gauss-Markov term of ``sigma_key`` is faster than the shortest tau (its
    white noise is in the white-noise equivalent, not a bias term of its own)."""
    equivalent = fit.white_equivalent()
    label = sigma_key.removesuffix("_sigma_deg_h")
    return equivalent is not None and label in dict(equivalent.correlation_times_s)


def axis_noise(axis: AxisAnalysis, method: str = DEFAULT_METHOD) -> AxisNoise:
    """The noise parameters of one analysed axis (the module docstring says which figure
    feeds which).

    Raises
    ------
    UsageError
        ``method="gmwm"`` on an analysis without a GMWM, or no angle random walk at all.
    """
    # the reading a sheet prints: one term set, the one the record supports best
    fit, fig = best_supported(axis.fit), axis.figures
    n_fit = fit.values.get("N")
    arw, arw_from = (
        (n_fit, f"fit ({fit.method})") if _positive(n_fit) else
        (fig.arw_deg_rt_h, "read-off: upper bound (no -1/2 region the curve allows white "
                           "noise in; the least sigma sqrt(tau))" if fig.arw_upper_bound
         else "read-off")
    )
    b, b_from = fig.bias_instability_deg_h, "read-off (sigma_min / 0.664)"
    if not _positive(b):
        b, b_from = (
            (fit.values.get("B"), f"fit ({fit.method})")
            if _positive(fit.values.get("B"))
            else (None, "none")
        )
    k, k_from = _printed_rrw(fit)
    gauss_markov: list[GaussMarkovBias] = []
    if method == GMWM_METHOD:
        if axis.gmwm is None:
            raise UsageError(
                f"axis {axis.name}: no GMWM in this analysis (analyze with method gmwm)"
            )
        best = axis.gmwm.best
        values, errors = best.values, best.stderr
        model = f"GMWM ({best.model.name})"
        if _positive(values.get(WN_EQUIVALENT_KEY)):  # fast GM / AR(1) terms are white here
            arw, arw_from = values[WN_EQUIVALENT_KEY], f"{model}, white-noise equivalent"
        elif _positive(values.get("wn_deg_rt_h")):
            arw, arw_from = values["wn_deg_rt_h"], model
        if _positive(values.get("bi_deg_h")):
            b, b_from = values["bi_deg_h"], model
        if "rw_deg_h_rt_h" in values:
            k, k_from = _rrw(values.get("rw_deg_h_rt_h"), errors.get("rw_deg_h_rt_h"), model)
        for key, sigma in values.items():
            if (key.startswith("gm") and key.endswith("_sigma_deg_h") and _positive(sigma)
                    and not _is_fast(best, key)):
                tau = values[key.removesuffix("_sigma_deg_h") + "_tau_s"]
                gauss_markov.append(GaussMarkovBias(float(sigma), float(tau)))
    if not _positive(arw):
        raise UsageError(
            f"axis {axis.name}: no angle random walk found (neither fit nor read-off): "
            f"record longer or at a higher rate"
        )
    gauss_markov.sort(key=lambda g: g.tau_s)
    return AxisNoise(
        name=axis.name,
        sample_rate_hz=axis.sample_rate_hz,
        arw_deg_rt_h=float(arw),  # type: ignore[arg-type]
        bias_instability_deg_h=None if b is None else float(b),
        rrw_deg_h_1_5=k,
        bias_deg_h=fig.bias_deg_h,
        gauss_markov=tuple(gauss_markov),
        sources={"arw": arw_from, "bias_instability": b_from, "rrw": k_from},
    )
