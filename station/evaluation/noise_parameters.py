"""The noise parameters a Kalman filter or simulator takes, from an axis' analysis.

Which figure feeds which parameter (:func:`axis_noise`; ``AxisNoise.sources`` names it
per axis):

* angle random walk N: the five-term fit's N (``logwls``) or the GMWM's white noise
  (``gmwm``), else the IEEE 952 read-off;
* bias instability B: the IEEE 952 read-off ``sigma_min / 0.664`` (the spec figure), or
  the GMWM's flicker term when its model has one; else the fit's B;
* rate random walk K: the fit's K, or the GMWM's random walk; a K the record does not
  resolve (fitted to zero) is its 1-sigma upper bound, and the source says so, because a
  filter given no bias random walk at all trusts its bias estimate for ever; where the
  record allows other readings (:mod:`analysis.figures.ambiguity`), the largest K of them, the
  source naming the alternatives;
* Gauss-Markov terms: the GMWM's ``gm`` terms (``gmwm``), none otherwise.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from analysis.figures.tool_units import AxisNoise, GaussMarkovBias
from station.errors import UsageError
from station.evaluation.analysis_options import DEFAULT_METHOD, GMWM_METHOD

if TYPE_CHECKING:
    from station.evaluation.analyze import AxisAnalysis

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


def _safe_rrw(axis: AxisAnalysis) -> tuple[float, str]:
    """K from the fit, the largest over its readings where the record allows several
    (:mod:`analysis.figures.ambiguity`), its source naming the alternatives the record allowed."""
    fit = axis.fit
    k, k_from = _rrw(fit.values.get("K"), fit.stderr.get("K"), f"fit ({fit.method})")
    if not fit.alternatives:
        return k, k_from
    for alt in fit.alternatives:
        other, _ = _rrw(alt.fit.values.get("K"), alt.fit.stderr.get("K"), "")
        if other > k:
            k, k_from = other, f"fit ({fit.method}, reading {alt.terms})"
    allowed = "; ".join(alt.describe() for alt in fit.alternatives)
    return k, (f"{k_from}; ambiguous: the record also allows {allowed} (printed terms "
               f"{fit.terms}); the larger K of the readings is written")


def axis_noise(axis: AxisAnalysis, method: str = DEFAULT_METHOD) -> AxisNoise:
    """The noise parameters of one analysed axis (the module docstring says which figure
    feeds which).

    Raises
    ------
    UsageError
        ``method="gmwm"`` on an analysis without a GMWM, or no angle random walk at all.
    """
    fit, fig = axis.fit, axis.figures
    n_fit = fit.values.get("N")
    arw, arw_from = (
        (n_fit, f"fit ({fit.method})") if _positive(n_fit) else (fig.arw_deg_rt_h, "read-off")
    )
    b, b_from = fig.bias_instability_deg_h, "read-off (sigma_min / 0.664)"
    if not _positive(b):
        b, b_from = (
            (fit.values.get("B"), f"fit ({fit.method})")
            if _positive(fit.values.get("B"))
            else (None, "none")
        )
    k, k_from = _safe_rrw(axis)
    gauss_markov: list[GaussMarkovBias] = []
    if method == GMWM_METHOD:
        if axis.gmwm is None:
            raise UsageError(
                f"axis {axis.name}: no GMWM in this analysis (analyze with method gmwm)"
            )
        best = axis.gmwm.best
        values, errors = best.values, best.stderr
        model = f"GMWM ({best.model.name})"
        if _positive(values.get("wn_deg_rt_h")):
            arw, arw_from = values["wn_deg_rt_h"], model
        if _positive(values.get("bi_deg_h")):
            b, b_from = values["bi_deg_h"], model
        if "rw_deg_h_rt_h" in values:
            k, k_from = _rrw(values.get("rw_deg_h_rt_h"), errors.get("rw_deg_h_rt_h"), model)
        for key, sigma in values.items():
            if key.startswith("gm") and key.endswith("_sigma_deg_h") and _positive(sigma):
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
