"""Term sets a record cannot tell apart, and the reading a spec sheet prints.

Over a few hours a realisation of a rate random walk wanders like a rate ramp or flattens
like a bias instability: its last octaves hold a handful of clusters, each Allan value
there nearly one chi-square degree of freedom. The term selection of ``logwls``
(:mod:`analysis.fit.selection`) then often keeps ``N+R``, ``N+B`` or ``N+B+R`` where the
record holds ``N+K``, and a K reported as 0 with a bound is a figure a walk's realisation
bought, not a measurement (N 0.1 deg/sqrt(h) + K 1 deg/h^1.5, 6 h: K kept in 11 of 20
records, its mean 0.58).

A reading that exchanges the rate random walk with the ramp or the bias instability is
therefore held against the selected one by two criteria, and the record counts as
unable to tell them apart when either puts it within :data:`AMBIGUITY_MARGIN` (a walk
against a ramp: when the selection's criterion puts it within :data:`RAMP_MARGIN`):

* the selection's own information criterion (log Allan values with their covariance);
* the wavelet information criterion of the GMWM (:mod:`analysis.gmwm.selection`) of the
  two models on the Haar wavelet variance, whose full covariance weighs the last scales
  as little as they hold (run only when K was left out, about 0.5-1.5 s per axis).

Where the selected reading left K out and a reading with K is not ruled out, the reading
with K is the one printed (a realised walk holds the ramp-like rise and the slow wander a
separate R or B would claim), and the selected one becomes its alternative; the selected
one stays printed, the reading with K its alternative, where the GMWM prefers a bias
instability alone or only the ramp's wider margin keeps the walk. A spec sheet prints
the reading the selection's criterion supports best either way, each figure's interval
covering the other readings (:func:`station.evaluation.readings.best_supported`). Where the
selected reading kept K, readings that trade it for R or B within the margin of the
information criterion are listed as alternatives. Every alternative carries its values
and standard errors, so that a verdict can take the reading that is safe for a limit.

Where the printed reading holds B or K, a slow Gauss-Markov process in its place is held
against it on the GMWM's criterion (:mod:`analysis.figures.bias_or_markov`) and listed as an
alternative where the record allows it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from analysis.allan import blocks
from analysis.allan.estimators import AllanResult
from analysis.errors import AnalysisError, FitError
from analysis.figures.bias_or_markov import (
    GMWM_TERM,
    MARKOV_LOOKALIKES,
    gmwm_model,
    markov_alternative,
)
from analysis.fit.least_squares import TERMS, Alternative, NoiseCoefficients, fit_term_set
from analysis.gmwm.models import GmwmModelError
from analysis.gmwm.selection import select_model
from analysis.gmwm.wavelet import WaveletVariance, haar_wavelet_variance

#: Criterion units (-2 log-likelihood) within which two readings count as the same: about
#: one term's penalty of the selection (log n, n about 40-60 values), twice the GMWM's.
AMBIGUITY_MARGIN = 4.0
#: Criterion units past which the selection's criterion alone rules a walk out against a
#: ramp, or a ramp against a walk: "essentially no support" for the other model (Burnham
#: and Anderson, Model Selection and Multimodel Inference, 2nd ed., sec. 2.6). A ramp is
#: deterministic: one record cannot check the precision a fit of it claims, so the GMWM's
#: wavelet criterion (whose covariance is the data's, not the model's) does not rule a walk
#: out against it (on 13 of 542 walks of the issue's case it preferred the ramp by 8-81
#: where the selection's criterion put the two 4-9 apart, and the sheet printed K = 0).
RAMP_MARGIN = 10.0
#: Terms a rate random walk's realisation may be read as.
WALK_LOOKALIKES = "BR"
__all__ = ["AMBIGUITY_MARGIN", "GMWM_TERM", "RAMP_MARGIN", "WALK_LOOKALIKES", "resolve_ambiguity",
           "resolve_for_rate", "wavelet_criterion_delta"]


def _with_walk(terms: str, candidates: str) -> list[str]:
    """The term sets that read the lookalikes of ``terms`` as a rate random walk (none
    where ``terms`` holds neither: whether K is there at all is the selection's call)."""
    present = [t for t in WALK_LOOKALIKES if t in terms]
    out = []
    for mask in range(1, 2 ** len(present)):
        gone = {t for i, t in enumerate(present) if mask >> i & 1}
        out.append("".join(t for t in candidates if (t in terms and t not in gone) or t == "K"))
    return out


def wavelet_criterion_delta(wavelet: WaveletVariance, terms: str, other: str) -> float | None:
    """WIC of the GMWM model of ``other`` minus that of ``terms``, both fitted with the
    weights of the larger (:func:`analysis.gmwm.selection.select_model`); None where the
    record has too few scales or a model cannot be fitted."""
    try:
        ranking = select_model(wavelet, [gmwm_model(terms), gmwm_model(other)]).ranking
    except (GmwmModelError, AnalysisError, np.linalg.LinAlgError):
        return None  # the information criterion then decides alone
    criteria = {r.model: r.criterion for r in ranking}
    a, b = criteria.get(gmwm_model(terms)), criteria.get(gmwm_model(other))
    return None if a is None or b is None else b - a


def resolve_ambiguity(
    result: AllanResult,
    fit: NoiseCoefficients,
    wavelet: WaveletVariance | None,
    *,
    exclude_tau_s: tuple[tuple[float, float], ...] = (),
    margin: float = AMBIGUITY_MARGIN,
) -> NoiseCoefficients:
    """The reading a sheet prints, with the others the record allows (module docstring).

    Parameters
    ----------
    result : AllanResult
        The one-axis Allan variance ``fit`` was made from.
    fit : NoiseCoefficients
        The ``logwls`` fit with term selection (others are returned as they are).
    wavelet : WaveletVariance or None
        The axis' Haar wavelet variance (:func:`analysis.gmwm.wavelet.haar_wavelet_variance`)
        for the GMWM criterion; None: the information criterion alone decides.
    exclude_tau_s : tuple of (float, float)
        The tau ranges ``fit`` left out (:func:`analysis.figures.zones.fit_outside_zones`).
    margin : float
        Criterion difference within which two readings are the same
        (:data:`AMBIGUITY_MARGIN`).

    Returns
    -------
    NoiseCoefficients
        The printed reading, its ``alternatives`` filled (unchanged when unambiguous).
    """
    printed = _resolve_walk(result, fit, wavelet, exclude_tau_s, margin)
    if fit.method != "logwls" or wavelet is None:
        return printed
    markov = markov_alternative(wavelet, printed, margin=margin)
    if markov is None:
        return printed
    return replace(printed, alternatives=(*printed.alternatives, markov))


def _resolve_walk(result: AllanResult, fit: NoiseCoefficients, wavelet: WaveletVariance | None,
                  exclude_tau_s: tuple[tuple[float, float], ...],
                  margin: float) -> NoiseCoefficients:
    """The walk against its lookalikes (:func:`resolve_ambiguity`, less the Gauss-Markov
    reading)."""
    crit, chosen, cand = fit.criteria, fit.terms, fit.candidate_terms
    if fit.method != "logwls" or "K" not in cand or not crit or chosen not in crit:
        return fit

    def refit(terms: str) -> NoiseCoefficients | None:
        try:
            return fit_term_set(result, cand, terms, exclude_tau_s=exclude_tau_s)
        except FitError:
            return None

    if "K" in chosen:
        rivals = [s for t in WALK_LOOKALIKES if t in cand and t not in chosen
                  for s in (chosen.replace("K", t), chosen.replace("K", "") + t)]
        alternatives = []
        for terms in dict.fromkeys("".join(t for t in TERMS if t in s) for s in rivals):
            allowed = max(margin, RAMP_MARGIN) if "R" in terms and "R" not in chosen else margin
            if terms in crit and crit[terms] - crit[chosen] <= allowed:
                other = refit(terms)
                if other is not None:
                    alternatives.append(Alternative(other, crit[terms] - crit[chosen]))
        return replace(fit, alternatives=tuple(alternatives)) if alternatives else fit
    walks = [s for s in _with_walk(chosen, cand) if s in crit]
    if not walks:
        return fit
    walk = min(walks, key=lambda s: crit[s])
    delta = crit[walk] - crit[chosen]
    wic = None if wavelet is None else wavelet_criterion_delta(wavelet, chosen, walk)
    within = delta <= margin or (wic is not None and wic <= margin)
    # a ramp traded: not ruled out while the selection's criterion alone allows the walk
    ramp = "R" in chosen and "R" not in walk and delta <= max(margin, RAMP_MARGIN)
    if not (within or ramp):
        return fit
    other = refit(walk)
    if other is None or not (other.values["K"] or 0.0) > 0:
        return fit
    gmwm = "" if wic is None else f", the GMWM's wavelet criterion {_signed(wic)}"
    why = (f"terms {walk} and {chosen} are not told apart by this record (information "
           f"criterion of {walk} {_signed(delta)}{gmwm}): a rate random walk's realisation "
           f"rises like a ramp or flattens like a bias instability over a few hours")
    # Printed: the reading with K (a dropped K is the figure a walk's realisation buys),
    # except where the selection read the walk as a bias instability alone and the GMWM's
    # criterion (the full covariance of the wavelet variance, which weighs the last
    # octaves as little as they hold) prefers that: a flat Allan curve over the last
    # octaves is a bias instability's, and a record of one is not to print a walk; and
    # except where only the ramp's wider margin keeps the walk (the selection prefers the
    # ramp by more than the margin). The sheet prints the reading the selection's
    # criterion supports best either way, its intervals covering the others
    # (station.evaluation.readings.best_supported).
    if not within or (wic is not None and wic >= 0 and "R" not in chosen):
        which = "the GMWM prefers" if within else "the information criterion prefers"
        note = (f"{why}. Printed: the reading without K, which {which}; the reading "
                f"with K is listed as an alternative, and a verdict takes the reading safe "
                f"for its limit")
        walk_alt = Alternative(other, delta, wic)
        return replace(fit, notes=(note, *fit.notes), alternatives=(walk_alt,))
    note = (f"{why}. Printed: the reading with K, its standard error widened by the chance "
            f"that the other reading holds (the unconditional error over the two readings); "
            f"the other is listed as an alternative, and a verdict takes the reading safe "
            f"for its limit")
    back = Alternative(fit, -delta, None if wic is None else -wic)
    printed = replace(other, stderr=_unconditional_stderr(other, fit, delta))
    return replace(printed, notes=(note, *other.notes), criteria=crit, alternatives=(back,))


def _unconditional_stderr(printed: NoiseCoefficients, other: NoiseCoefficients,
                          delta: float) -> dict[str, float | None]:
    """Standard errors of ``printed`` that carry the choice between two readings: each
    term's variance plus the other reading's weight times the squared difference of their
    values (the unconditional variance of a model-averaging estimate; Akaike weights from
    the criterion difference ``delta`` of ``printed`` minus ``other``)."""
    weight = 1.0 / (1.0 + math.exp(min(delta, 50.0) / 2.0))  # of ``other``
    out: dict[str, float | None] = {}
    for term, err in printed.stderr.items():
        a, b = printed.values.get(term), other.values.get(term)
        if err is None or a is None:
            out[term] = err
            continue
        shift = a - (b or 0.0)
        out[term] = math.sqrt(err ** 2 + weight * shift ** 2)
    return out


def _signed(x: float) -> str:
    return f"{x:+.1f}" if math.isfinite(x) else "n/a"



def resolve_for_rate(
    result: AllanResult,
    fit: NoiseCoefficients,
    rate_deg_s: NDArray[np.float64],
    sample_rate_hz: float,
    *,
    gaps: bool = False,
    exclude_tau_s: tuple[tuple[float, float], ...] = (),
    angle_out: NDArray[np.float64] | None = None,
) -> NoiseCoefficients:
    """:func:`resolve_ambiguity` with the wavelet variance of ``rate_deg_s`` (deg/s, NaN
    where missing when ``gaps``), computed only where a GMWM criterion is needed (K a
    candidate the selection left out, or B or K in the selected terms). A long record with
    gaps (:func:`analysis.allan.blocks.is_long`) has no block-wise wavelet variance: there the
    information criterion decides alone, so that the memory a grading needs stays flat in
    the record's length."""
    wavelet = None
    if gaps and blocks.is_long(len(rate_deg_s)):
        return resolve_ambiguity(result, fit, None, exclude_tau_s=exclude_tau_s)
    walk_check = "K" in fit.candidate_terms and "K" not in fit.terms
    if fit.method == "logwls" and (walk_check
                                   or any(t in fit.terms for t in MARKOV_LOOKALIKES)):
        try:
            wavelet = haar_wavelet_variance(rate_deg_s, sample_rate_hz, gaps=gaps,
                                            angle_out=angle_out)
        except AnalysisError:
            wavelet = None
    return resolve_ambiguity(result, fit, wavelet, exclude_tau_s=exclude_tau_s)
