"""Model versus measurement: which candidates a round of the reconcile loop tries, in which order
(:func:`ranked`), and what is reported beside the one named (:func:`alternatives`).

A spectral line the line test detects (:mod:`analysis.reconcile.line_test`) is tried first, as the
sinusoid the time series fits there; then the candidates of the Allan curve
(:mod:`analysis.reconcile.candidates`) in the order described at :func:`ranked`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from analysis.models.terms import NoiseTerm
from analysis.reconcile.candidates import CandidateFit, change_of, fit_candidate, fit_candidates
from analysis.reconcile.confirm import Evidence, RoundEvidence
from analysis.reconcile.discrepancy import Comparison, ComparisonCache, MeasuredCurve
from analysis.reconcile.gmwm_naming import (
    ALTERNATIVE_SCORE,
    Alternative,
    GmwmJudgement,
    judge,
    new_or_more,
)

#: What the time series says of a candidate: (term to add, evidence, reason refused).
Confirmation = tuple[NoiseTerm | None, Evidence | None, str]
#: A candidate in the order a round tries it: its fit, its change, its confirmation.
Ranked = tuple[CandidateFit, str, Confirmation]

#: Candidates within this Delta BIC of the best are not told apart by the curve ("positive"
#: evidence at most on the Kass-Raftery scale); among them the simpler goes first.
INDISTINCT_BIC = 6.0
#: Candidates whose time-series test singles them out (a periodogram line, located steps, a
#: correlation with the temperature): when confirmed they are tried first. Not the rate
#: ramp: a trend in one record is as much a random walk's as a ramp's.
TIME_SERIES_TESTED = frozenset({"sinusoid", "bias_steps", "temperature_bias"})
#: Share of the best Delta BIC a confirmed candidate needs to go first.
CONFIRMED_SHARE = 0.5


def allan_ranked(evidence: RoundEvidence, current: Comparison, curve: MeasuredCurve,
                 steps: NDArray[np.float64] | None, *, bic_threshold: float,
                 gmwm: bool) -> tuple[list[Ranked], GmwmJudgement | None]:
    """Candidates above the threshold with their confirmation, in the order they are tried,
    and the GMWM's judgement of the close ones (None when it judged none).

    First the candidates the time series confirms (``TIME_SERIES_TESTED``) that explain at
    least ``CONFIRMED_SHARE`` of the best one's Delta BIC, then those within
    ``INDISTINCT_BIC`` of the best by their number of parameters (the curve cannot tell
    them apart, so the simpler explanation is tried first; with ``gmwm``, when the
    GMWM can judge every one of them and they include a refit of a term the model has, the
    GMWM's answer to "a new process or more of one the model has" first,
    :func:`analysis.reconcile.gmwm_naming.new_or_more`), then the rest; by Delta BIC within each
    group.
    """
    fits = [f for f in fit_candidates(current.model, curve, current, steps=steps)
            if f.delta_bic >= bic_threshold]
    if not fits:
        return [], None
    best = fits[0].delta_bic
    rows = []
    for fit in fits:
        change = change_of(fit, current.model, curve)
        verdict = evidence.confirm(fit, change)
        close = fit.delta_bic >= best - INDISTINCT_BIC
        confirmed = (
            fit.name in TIME_SERIES_TESTED and verdict[0] is not None and change != "decreased"
        )
        strong = fit.delta_bic >= CONFIRMED_SHARE * best
        rank = (0, 0) if confirmed and strong else ((1, fit.n_params) if close else (2, 0))
        rows.append((rank, -fit.delta_bic, fit, change, verdict))
    rows.sort(key=lambda r: (r[0], r[1]))
    judgement = None
    close_rows = [r for r in rows if r[0][0] == 1 and r[3] != "decreased" and r[4][0] is not None]
    if gmwm and len(close_rows) >= 2:
        judgement = judge(evidence.residual, curve.sample_rate_hz, current.model,
                          [(r[2].name, r[2].mode) for r in close_rows])
    # the GMWM orders the close group when it can judge every viable member and the question
    # is a new process against more of one the model has (a Gauss-Markov process or more bias
    # instability); between two added terms the curve's order (simplest first) stands
    decides = (judgement is not None and all(r[2].name in judgement.scores for r in close_rows)
               and any(r[3] != "added" for r in close_rows))
    if decides:
        assert judgement is not None
        group = [r for r in rows if r[0][0] == 1]
        ordered = new_or_more(group, lambda r: r[2].name, lambda r: r[3] == "added", judgement)
        rows = [r for r in rows if r[0][0] == 0] + ordered + [r for r in rows if r[0][0] == 2]
    return [(fit, change, verdict) for _, _, fit, change, verdict in rows], judgement


def alternatives(named: CandidateFit, ranked: list[Ranked],
                  judgement: GmwmJudgement | None) -> tuple[float, str, tuple[Alternative, ...]]:
    """(score, criterion, alternatives) of the named candidate: the other viable explanations
    (confirmed where they need it, not a decrease) within ``ALTERNATIVE_SCORE`` of its GMWM
    score or above it when the GMWM judged it (the curve's order may name a random walk
    that the GMWM scores below a Gauss-Markov process), else within ``INDISTINCT_BIC`` of
    its Delta BIC."""
    viable = [(fit, change) for fit, change, verdict in ranked
              if fit.name != named.name and verdict[0] is not None and change != "decreased"]
    if judgement is not None and named.name in judgement.scores:
        own = judgement.scores[named.name]
        alts = tuple(
            Alternative(fit.name, judgement.scores[fit.name], "gmwm", change)
            for fit, change in viable
            if fit.name in judgement.scores
            and judgement.scores[fit.name] > own - ALTERNATIVE_SCORE
        )
        return own, "gmwm", alts
    alts = tuple(Alternative(fit.name, fit.delta_bic, "allan", change) for fit, change in viable
                 if abs(fit.delta_bic - named.delta_bic) < INDISTINCT_BIC)
    return named.delta_bic, "allan", alts




def ranked(
    evidence: RoundEvidence,
    current: Comparison,
    curve: MeasuredCurve,
    steps: NDArray[np.float64] | None,
    *,
    bic_threshold: float,
    gmwm: bool,
    significant: bool,
    alpha: float = 0.01,
    seed: int = 0,
    cache: ComparisonCache | None = None,
    process: bool = True,
) -> tuple[list[Ranked], GmwmJudgement | None, CandidateFit | None]:
    """The candidates of a round in the order they are tried, the GMWM's judgement, and the
    candidate a spectral test leads with (None when none does).

    A spectral line the line test detects (L2 of :mod:`analysis.reconcile.line_test`) contradicts
    the model whether or not the Allan gap is significant: its sinusoid, fitted to the
    time series, is tried first (and is the only candidate when the gap is not
    significant); the Allan curve's sinusoid then gives way to it. The rest follow in the
    order of :func:`allan_ranked` when the gap is significant. When neither the gap nor a
    line contradicts the model, the spectral process test
    (:mod:`analysis.reconcile.process_test`, P3 at level ``alpha``) may, where ``process``
    allows it: the Gauss-Markov process it finds is then the only candidate.
    """
    rows: list[Ranked] = []
    judgement = None
    if significant:
        rows, judgement = allan_ranked(evidence, current, curve, steps,
                                       bic_threshold=bic_threshold, gmwm=gmwm)
    found = evidence.line_sinusoid()
    if found is None:
        if significant or not process:
            return rows, judgement, None
        return _process_led(evidence, current, curve, alpha, seed, cache)
    term, ev = found
    fit = fit_candidate("sinusoid", current.model, curve, current)
    if fit is None:
        return rows, judgement, None
    line_fit = fit.with_term(term)
    rows = [r for r in rows if r[0].name != "sinusoid"]
    return [(line_fit, "added", (term, ev, "")), *rows], judgement, line_fit


def _process_led(evidence: RoundEvidence, current: Comparison, curve: MeasuredCurve,
                 alpha: float, seed: int, cache: ComparisonCache | None,
                 ) -> tuple[list[Ranked], GmwmJudgement | None, CandidateFit | None]:
    """The Gauss-Markov process of the spectral process test as the round's only candidate
    (no candidate when the test finds none)."""
    process = evidence.missing_process(alpha, seed, cache)
    if process is None:
        return [], None, None
    term, ev = process
    fit = fit_candidate("gauss_markov", current.model, curve, current)
    if fit is None:
        return [], None, None
    # the curve's fit lends its Delta BIC, not its parameters' errors (those of another fit)
    led = replace(fit.with_term(term), stderr={})
    return [(led, "added", (term, ev, ""))], None, led
