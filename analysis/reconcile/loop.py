"""Model versus measurement: find where a noise model and a record disagree, name the missing
effect, add it and show the gap shrink (issue 9).

The workflow (:func:`reconcile`), each step reported in a :class:`ReconcileResult`:

1. **Compare** (:mod:`analysis.reconcile.discrepancy`): the measured overlapping Allan variance on a
   log grid against the model's theoretical curve and a Monte Carlo band of the model
   simulated on the same length, rate and grid. The gap statistic G (eq. G2 there: the
   octave-weighted mean square of the standardized log-ratio, about 1 when the model
   holds) and its p-value under the simulated null say whether they disagree; the tau
   ranges where the curve leaves the band say where. The model *disagrees significantly*
   when ``p < alpha`` (default 0.01).
2. **Name** (:mod:`analysis.reconcile.candidates`): every term of the simulation library is fitted
   to the curve with the rest of the model held (added if the model lacks it, refitted
   if it has it), and scored by Delta BIC (eq. C2 there, ``n`` = octaves of the grid).
   Candidates below ``bic_threshold`` (10) are not considered. The sinusoid, bias steps,
   temperature-driven bias and rate ramp must also be confirmed by the time series
   (:mod:`analysis.reconcile.confirm`: periodogram peak, change points, regression on temperature
   or time), which then also gives their parameters. Bias steps have the expected Allan
   curve of a rate random walk; they are a candidate only when the change-point test
   locates them, and then their curve (and every later comparison) is that of the steps
   located, not of a random draw of steps. A spectral line the full-resolution line test
   finds (:mod:`analysis.reconcile.line_test`, family-wise level 1e-3) contradicts the model even
   where the gap does not (a sinusoid of a tenth of the white noise moves no Allan value
   beyond its interval, but stands 30 times over the background of an hour's
   periodogram): its sinusoid, fitted to the time series, is tried first
   (:mod:`analysis.reconcile.ranking`), and the loop runs while the gap is significant or
   such a line is left. When neither the gap nor a line contradicts the model, the
   spectral process test (:mod:`analysis.reconcile.process_test`, level ``alpha``) may: a
   faint Gauss-Markov process the Allan curve cannot see, tried alone and kept like the
   line's sinusoid, in rounds where every change so far was led by a spectral test.
3. **Add and re-check**: the best candidate is put into the model, the comparison is run
   again (new curve, new simulated band and null) and the effect is kept only if the gap
   shrinks significantly: ``G_after < G_before - shrink_sigmas * sd(G_null_before)``
   (3 standard deviations of the gap's simulated spread under the model before the
   change) and ``G_after < (1 - min_shrink) G_before`` (by 10 % at least: where the gap
   is far above its null, as on real records, a 2 % drop is no explanation). Otherwise
   the next candidate is tried (at most ``max_tries`` per round). The sinusoid of a
   spectral line needs only not to raise the gap by ``shrink_sigmas`` standard deviations
   (its own test has rejected the model without it), and is not dropped later. After an
   addition, every effect added earlier is re-checked: one the model no longer needs
   (without it the model still agrees with the data and the gap is not significantly
   larger) is dropped. The loop repeats until the gap is no longer significant and no
   line is left, no candidate passes, or ``max_effects`` changes.

A refitted term whose Allan variance comes out lower than the model's at every tau is an
*excess* term (the model has more of it than the data show) and is reported apart from
the missing effects.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.models.terms import (
    NoiseModel,
    NoiseTerm,
    term_type,
)
from analysis.reconcile.candidates import SCALE_KEYS, CandidateFit, tau_range
from analysis.reconcile.confirm import Evidence, RoundEvidence, StepEvidence
from analysis.reconcile.discrepancy import (
    Comparison,
    ComparisonCache,
    MeasuredCurve,
    compare,
    measure_curve,
)
from analysis.reconcile.gmwm_naming import Alternative
from analysis.reconcile.options import ReconcileOptions as ReconcileOptions
from analysis.reconcile.ranking import alternatives, ranked
from analysis.units.conversions import rate_deg_s_to_deg_h


@dataclass(frozen=True)
class Effect:
    """A change the workflow made to the model, with the evidence for it.

    Attributes
    ----------
    name : str
        Term name of the simulation library.
    change : str
        ``"added"``, ``"increased"``, ``"decreased"`` or ``"replaced"``.
    params, stderr : dict
        The term's keys (units in the names) as put in the model, and standard errors of
        the fitted ones.
    tau_range_s : tuple of float
        Taus (s) where the change moves the model's Allan variance by 20 % or more.
    delta_bic : float
        Its Delta BIC (C2).
    gap_before, gap_after : float
        G before and after the change.
    evidence : str
        The time-series confirmation, when the effect has one.
    events : tuple of (float, float)
        For bias steps: (time in s, size in deg/h) of each step located.
    score, criterion : float, str
        What named it: the GMWM's N1 score (``"gmwm"``, :mod:`analysis.reconcile.gmwm_naming`) or
        the Allan curve's Delta BIC (``"allan"``).
    alternatives : tuple of Alternative
        Other explanations within ``ALTERNATIVE_SCORE`` of it or above it (GMWM), or within
        ``INDISTINCT_BIC`` of it (Allan curve), with their scores.
    """

    name: str
    change: str
    params: dict[str, float]
    stderr: dict[str, float]
    tau_range_s: tuple[float, float]
    delta_bic: float
    gap_before: float
    gap_after: float
    evidence: str = ""
    events: tuple[tuple[float, float], ...] = ()
    score: float | None = None
    criterion: str = "allan"
    alternatives: tuple[Alternative, ...] = ()

    def as_json(self) -> dict[str, object]:
        """JSON form: name, params, tau_range_s, the rest of the evidence, its naming score and
        the ``alternatives`` (``[{"name", "score", ...}]``) that fit about as well."""
        return {
            "name": self.name,
            "change": self.change,
            "params": dict(self.params),
            "stderr": dict(self.stderr),
            "tau_range_s": list(self.tau_range_s),
            "delta_bic": self.delta_bic,
            "gap_before": self.gap_before,
            "gap_after": self.gap_after,
            "evidence": self.evidence,
            **(
                {"steps": [{"time_s": t, "size_deg_h": z} for t, z in self.events]}
                if self.events
                else {}
            ),
            "score": self.score,
            "score_criterion": self.criterion,
            "alternatives": [a.as_json() for a in self.alternatives],
        }


@dataclass(frozen=True)
class Attempt:
    """One candidate tried in a round and what became of it."""

    name: str
    mode: str
    delta_bic: float
    outcome: str


@dataclass(frozen=True)
class ReconcileRound:
    """One pass of the loop: the comparison it started from and the candidates it tried."""

    comparison: Comparison
    attempts: tuple[Attempt, ...] = ()


@dataclass(frozen=True)
class ReconcileResult:
    """Everything :func:`reconcile` did, step by step.

    Attributes
    ----------
    curve : MeasuredCurve
        The measured record and its Allan variance on the grid.
    before, after : Comparison
        The starting model and the reconciled model against the curve.
    effects : tuple of Effect
        Missing effects, in the order they were added (more of a term counts as missing).
    excess : tuple of Effect
        Terms the model has more of than the data show.
    rounds : tuple of ReconcileRound
    options : ReconcileOptions
    """

    curve: MeasuredCurve
    before: Comparison
    after: Comparison
    effects: tuple[Effect, ...]
    excess: tuple[Effect, ...]
    rounds: tuple[ReconcileRound, ...]
    options: ReconcileOptions = field(default_factory=ReconcileOptions)

    @property
    def gap_before(self) -> float:
        """G of the starting model."""
        return self.before.gap

    @property
    def gap_after(self) -> float:
        """G of the reconciled model."""
        return self.after.gap

    @property
    def model_before(self) -> NoiseModel:
        """The starting model."""
        return self.before.model

    @property
    def model_after(self) -> NoiseModel:
        """The reconciled model."""
        return self.after.model

    def as_json(self) -> dict[str, object]:
        """The JSON of the ``station reconcile --json`` interface (plus diagnostics)."""
        return {
            "gap_before": self.gap_before,
            "gap_after": self.gap_after,
            "effects": [e.as_json() for e in self.effects],
            "model_after": self.model_after.to_tables(),
            "excess_terms": [e.as_json() for e in self.excess],
            "p_before": self.before.p_value,
            "p_after": self.after.p_value,
            "outside_band_before": [list(r) for r in self.before.outside],
            "outside_band_after": [list(r) for r in self.after.outside],
            "sample_rate_hz": self.curve.sample_rate_hz,
            "decimation": self.curve.decimation,
            "n_samples": self.curve.n_samples,
            "mc_runs": self.options.runs,
            "gap_threshold": self.before.gap_null.quantile(1.0 - self.options.alpha),
            "alternatives": [
                {"effect": e.name, **a.as_json()} for e in self.effects for a in e.alternatives
            ],
        }


def _apply(model: NoiseModel, term: NoiseTerm, old: NoiseTerm | None) -> NoiseModel:
    """The model with ``term``; a term refitted to (almost) nothing is removed."""
    if old is not None:
        key = SCALE_KEYS[term.name]
        if abs(getattr(term, key)) < 1e-3 * abs(getattr(old, key)):
            return model.without_term(term.name)
    return model.with_term(term)


def _effect(
    fit: CandidateFit,
    term: NoiseTerm,
    change: str,
    ev: Evidence | None,
    before: Comparison,
    after: Comparison,
    curve: MeasuredCurve,
) -> Effect:
    stderr = {k: v for k, v in fit.stderr.items() if math.isfinite(v)}
    if ev is not None:
        stderr.update(ev.stderr)
    return Effect(
        name=fit.name,
        change=change,
        params=term.to_table(),
        stderr=stderr,
        tau_range_s=tau_range(before.model_avar, after.model_avar, curve.tau_s),
        delta_bic=fit.delta_bic,
        gap_before=before.gap,
        gap_after=after.gap,
        evidence="" if ev is None else ev.statistic,
        events=tuple(
            (t, rate_deg_s_to_deg_h(z)) for t, z in zip(ev.times_s, ev.sizes_deg_s, strict=True)
        )
        if isinstance(ev, StepEvidence)
        else (),
    )


# -------------------------------------------------------------------------------- the loop
def reconcile_curve(
    curve: MeasuredCurve, model: NoiseModel, *, options: ReconcileOptions | None = None,
    cache: ComparisonCache | None = None,
) -> ReconcileResult:
    """Run the compare / name / add-and-re-check loop on a measured curve (see the module
    docstring)."""
    opt = options or ReconcileOptions()
    cache = cache if cache is not None else ComparisonCache()

    known: dict[str, NDArray[np.float64]] = {}

    def comparison_of(
        m: NoiseModel, extra: dict[str, NDArray[np.float64]] | None = None
    ) -> Comparison:
        realized = {k: v for k, v in {**known, **(extra or {})}.items() if k in m}
        return compare(curve, m, runs=opt.runs, seed=opt.seed, cache=cache, known=realized)

    current = first = comparison_of(model)
    changes: list[Effect] = []
    rounds: list[ReconcileRound] = []
    by_line: set[str] = set()
    while len(changes) < opt.max_effects:
        evidence = RoundEvidence(curve, current, known)
        significant = current.significant(opt.alpha)
        attempts: list[Attempt] = []
        accepted = None
        steps = evidence.step_series()
        order, judgement, line_fit = ranked(evidence, current, curve, steps,
                                            significant=significant,
                                            bic_threshold=opt.bic_threshold, gmwm=opt.gmwm,
                                            alpha=opt.alpha, seed=opt.seed, cache=cache,
                                            process=all(e.name in by_line for e in changes))
        if not significant and line_fit is None:
            break
        for fit, change, (term, ev, refusal) in order:
            if len(attempts) >= opt.max_tries:
                break
            if term is None:
                attempts.append(Attempt(fit.name, fit.mode, fit.delta_bic, f"refused: {refusal}"))
                continue
            extra = (
                {"bias_steps": steps} if fit.name == "bias_steps" and steps is not None else None
            )
            trial = comparison_of(_apply(current.model, term, current.model.get(fit.name)), extra)
            needed = _needed(current, opt, line=fit is line_fit)
            if not trial.gap < needed:
                attempts.append(Attempt(fit.name, fit.mode, fit.delta_bic,
                                        f"refused: gap {current.gap:.3g} -> {trial.gap:.3g}, "
                                        f"not below {needed:.3g}"))
                continue
            attempts.append(Attempt(fit.name, fit.mode, fit.delta_bic,
                                    f"accepted: gap {current.gap:.3g} -> {trial.gap:.3g}"))
            score, criterion, alts = alternatives(fit, order, judgement)
            accepted = (replace(_effect(fit, term, change, ev, current, trial, curve), score=score,
                                criterion=criterion, alternatives=alts), trial)
            if fit is line_fit:
                by_line.add(fit.name)
            known.update(extra or {})
            break
        rounds.append(ReconcileRound(current, tuple(attempts)))
        if accepted is None:
            break
        effect, current = accepted
        changes.append(effect)
        dropped = _drop_superseded(changes, current, comparison_of, opt, keep=by_line)
        if dropped is not None:
            gone, current = dropped
            changes.remove(gone)
            changes[-1] = replace(changes[-1], gap_after=current.gap)
            known.pop(gone.name, None)
            rounds[-1] = replace(rounds[-1], attempts=(*rounds[-1].attempts, Attempt(
                gone.name, "drop", 0.0, f"dropped: not needed once {effect.name} is in the model "
                f"(gap without it {current.gap:.3g})")))
    if not rounds or rounds[-1].comparison is not current:
        rounds.append(ReconcileRound(current))
    effects, excess = _merged(changes, first, current, curve)
    return ReconcileResult(curve=curve, before=first, after=current, effects=effects,
                           excess=excess, rounds=tuple(rounds), options=opt)


def _needed(current: Comparison, opt: ReconcileOptions, *, line: bool) -> float:
    """The gap a change must bring the model below to be kept.

    A change named by the Allan curve must shrink the gap significantly (by
    ``shrink_sigmas`` null standard deviations and by ``min_shrink`` of it); the sinusoid of
    a spectral line (:mod:`analysis.reconcile.line_test`), whose test has already rejected the model
    without it, must only not make the curve's gap significantly larger.
    """
    if line:
        return current.gap + opt.shrink_sigmas * current.gap_null.std
    return min(current.gap - opt.shrink_sigmas * current.gap_null.std,
               (1.0 - opt.min_shrink) * current.gap)


def _drop_superseded(
    changes: list[Effect], current: Comparison,
    comparison_of: Callable[[NoiseModel], Comparison], opt: ReconcileOptions,
    *, keep: set[str],
) -> tuple[Effect, Comparison] | None:
    """The re-check after an addition: an earlier added effect the model no longer needs.

    Each term added before the latest one is taken out in turn; it is dropped (the first
    such) when the model without it agrees with the data (``p >= alpha``) and its gap is
    not significantly larger (less than ``shrink_sigmas`` null standard deviations above):
    e.g. a slow sinusoid that stood in for part of a random walk before the walk was added.
    Terms in ``keep`` (the sinusoid of a spectral line, which the line test holds against
    the model without it) stay.
    """
    for e in changes[:-1]:
        if e.change != "added" or e.name not in current.model or e.name in keep:
            continue
        trial = comparison_of(current.model.without_term(e.name))
        if (not trial.significant(opt.alpha)
                and trial.gap < current.gap + opt.shrink_sigmas * current.gap_null.std):
            return e, trial
    return None


def _merged(changes: list[Effect], first: Comparison, last: Comparison,
            curve: MeasuredCurve) -> tuple[tuple[Effect, ...], tuple[Effect, ...]]:
    """One effect per term: a term changed twice (refitted after another effect was added)
    is reported once, with its final values and its change against the starting model."""
    by_name: dict[str, Effect] = {}
    for e in changes:
        prior = by_name.get(e.name)
        if prior is None:
            by_name[e.name] = e
            continue
        original = first.model.get(e.name)
        change = "added"
        before = np.zeros(curve.tau_s.shape)
        after = term_type(e.name)(**e.params).avar(curve.tau_s, duration_s=curve.duration_s)
        if original is not None:
            before = original.avar(curve.tau_s, duration_s=curve.duration_s)
            change = ("decreased" if np.all(after <= before * (1 + 1e-9)) else
                      "increased" if np.all(after >= before * (1 - 1e-9)) else "replaced")
        span = tau_range(first.model_avar, first.model_avar - before + after, curve.tau_s)
        by_name[e.name] = replace(e, change=change, gap_before=prior.gap_before, tau_range_s=span,
                                  delta_bic=prior.delta_bic + e.delta_bic,
                                  evidence=e.evidence or prior.evidence)
    merged = list(by_name.values())
    return (tuple(e for e in merged if e.change != "decreased"),
            tuple(e for e in merged if e.change == "decreased"))


def reconcile(
    rate_deg_s: ArrayLike, sample_rate_hz: float, model: NoiseModel, *,
    temperature_c: ArrayLike | None = None, options: ReconcileOptions | None = None,
    cache: ComparisonCache | None = None,
) -> ReconcileResult:
    """Reconcile a noise model with one axis of a measured record.

    Parameters
    ----------
    rate_deg_s : array_like, shape (n,)
        Measured rate in deg/s.
    sample_rate_hz : float
        Sample rate in Hz.
    model : NoiseModel
        The model to check (e.g. a data-sheet FOG model, or a fit's result).
    temperature_c : array_like, optional
        Temperature channel in degC (enables the ``temperature_bias`` candidate).
    options : ReconcileOptions, optional
        Thresholds and Monte Carlo settings.
    cache : ComparisonCache, optional
        Memo of simulated bands, shared between calls on records of one length.

    Returns
    -------
    ReconcileResult

    Raises
    ------
    ReconcileError
        Record too short for the grid, several axes, a model without noise.
    NonFiniteSamplesError, InvalidSampleRateError
        Bad input samples or rate.
    """
    opt = options or ReconcileOptions()
    curve = measure_curve(rate_deg_s, sample_rate_hz, temperature_c=temperature_c,
                          max_samples=opt.max_samples, points_per_octave=opt.points_per_octave,
                          min_clusters=opt.min_clusters, floor=opt.floor)
    return reconcile_curve(curve, model, options=opt, cache=cache)


def term_avar(result: ReconcileResult, name: str) -> NDArray[np.float64]:
    """Allan variance (deg/s)^2 on the grid of the reconciled model's term ``name`` (zeros if
    absent)."""
    term = result.model_after.get(name)
    if term is None:
        return np.zeros(result.curve.tau_s.shape)
    return term.avar(result.curve.tau_s, duration_s=result.curve.duration_s)


__all__ = [
    "Attempt",
    "Effect",
    "ReconcileOptions",
    "ReconcileResult",
    "ReconcileRound",
    "reconcile",
    "reconcile_curve",
    "term_avar",
]
