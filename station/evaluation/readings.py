"""The reading a sheet prints of an ambiguous fit, its honest intervals, and the verdict
safe for a limit.

Where the record cannot tell two term sets apart (:mod:`analysis.figures.ambiguity`: a rate
random walk against a ramp or a bias instability, a bias instability or a walk against a
slow Gauss-Markov process), the fit carries the other readings beside the one printed.
A sheet prints the figures of one reading, the term set the record supports best
(:func:`best_supported`): never the largest fit of each term taken from different
readings, a model no reading supports (issue 38: on N 0.1 + B 0.3 records that printed K
in 14-15 of 20 and B as 0). Each fitted figure's interval is widened to cover every
other reading (:func:`covering_interval`): a term one allowed reading lacks has an
interval reaching 0, a term another reading puts higher one reaching that value. A limit
is passed only when every reading passes it, failed only when every reading fails it, and
indeterminate otherwise: never a pass bought by the zero of a term one reading dropped.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from analysis.fit.least_squares import NoiseCoefficients
from analysis.fit.result import Alternative
from station.model.kinds import INDETERMINATE, Verdict

#: The fitted term of each fit figure of a profile.
FIT_TERM = {"quantization": "Q", "arw_fit": "N", "bias_instability_fit": "B", "rrw": "K",
            "rate_ramp": "R"}


@dataclass(frozen=True)
class Reading:
    """One alternative reading of a fitted figure (canonical unit), with the terms of its
    model and its interval ``value +- z stderr`` clipped at 0 (None where unknown).
    ``equivalent``: the value is a Gauss-Markov process' equivalent of the term, not a fit
    of it."""

    terms: str
    value: float | None
    low: float | None
    high: float | None
    equivalent: bool = False

    def as_json(self, factor: float = 1.0) -> dict[str, object]:
        """``{"terms", "value", "ci_low", "ci_high"}`` in the unit ``factor`` converts to."""
        def conv(v: float | None) -> float | None:
            return None if v is None or not math.isfinite(v) else v / factor

        return {"terms": self.terms, "value": conv(self.value), "ci_low": conv(self.low),
                "ci_high": conv(self.high)}


def fit_term(name: str, source: str) -> str | None:
    """The fitted term a figure of a profile grades (None: not a fitted figure).

    ``source`` is the profile's ``figure_source``: with ``"fit"``, ``arw`` and
    ``bias_instability`` are the fitted N and B."""
    if source == "fit" and name in ("arw", "bias_instability"):
        return FIT_TERM[f"{name}_fit"]
    return FIT_TERM.get(name)


def alternative_readings(fit: NoiseCoefficients, term: str, z: float) -> tuple[Reading, ...]:
    """The readings of ``term`` by the fit's alternatives, less those identical to the
    printed one (``z``: the normal quantile of the profile's confidence). A reading that
    dropped the term holds it as 0, its interval up to ``z`` times the error the fit gives
    the dropped term."""
    printed, printed_err = fit.values[term], fit.stderr[term]
    out = []
    for alt in fit.alternatives:
        value, err = alt.fit.values[term], alt.fit.stderr[term]
        gm = alt.gauss_markov
        equivalent = False
        if term == "B" and gm is not None:
            equivalent = True
            # A Gauss-Markov reading's B: the bias instability whose Allan floor is as high
            # as the process' Allan peak (0.617 sigma near 1.89 T; B = 0.929 sigma). Both
            # then promise the same largest wander of adjacent averages, which is what a B
            # limit bounds; sigma / 0.664 would charge the process an Allan deviation it
            # never reaches. The verdict takes the larger reading (safe_verdict).
            value, err = gm.bias_instability_deg_h, gm.bias_instability_stderr_deg_h
        if value is None or (printed is not None and math.isclose(value, printed)
                             and (err == printed_err or (err is not None and printed_err
                                                         is not None and math.isclose(
                                                             err, printed_err)))):
            continue
        if err is None or not math.isfinite(err):
            out.append(Reading(alt.terms, value, None, None, equivalent))
        else:
            out.append(Reading(alt.terms, value, max(value - z * err, 0.0), value + z * err,
                               equivalent))
    return tuple(out)


def best_supported(fit: NoiseCoefficients) -> NoiseCoefficients:
    """The reading of ``fit`` the record supports best, the others its alternatives.

    The term set with the lowest information criterion of the ``logwls`` selection
    (:mod:`analysis.fit.selection`) among ``fit`` and its alternatives that have one (a
    Gauss-Markov reading has none: it stays an alternative). Where
    :mod:`analysis.figures.ambiguity` printed the reading with K over the selection's own,
    this is the selection's reading again: a sheet prints the figures of one reading the
    record supports, not a mix of readings, and each figure's interval covers the others
    (:func:`covering_interval`). Criterion differences of the alternatives are taken
    relative to the reading returned. ``fit`` itself where no alternative is better."""
    ranked = [a for a in fit.alternatives
              if a.gauss_markov is None and a.criterion_delta is not None]
    best = min(ranked, key=lambda a: a.criterion_delta or 0.0, default=None)
    if best is None or not (best.criterion_delta or 0.0) < 0.0:
        return fit
    d, wd = best.criterion_delta or 0.0, best.wavelet_criterion_delta

    def rebased(a: Alternative) -> Alternative:
        cd, wcd = a.criterion_delta, a.wavelet_criterion_delta
        return replace(a, criterion_delta=None if cd is None else cd - d,
                       wavelet_criterion_delta=None if wcd is None or wd is None else wcd - wd)

    was_printed = Alternative(replace(fit, alternatives=(), notes=()), -d,
                              None if wd is None else -wd)
    others = tuple(rebased(a) for a in fit.alternatives if a is not best)
    note = (f"terms {best.fit.terms}: the reading the record supports best (information "
            f"criterion {d:+.1f} against terms {fit.terms}); the record also allows "
            + "; ".join(a.describe() for a in (was_printed, *others))
            + ": each figure's interval covers every reading")
    return replace(best.fit, notes=(note, *best.fit.notes), criteria=fit.criteria,
                   alternatives=(was_printed, *others))


def covering_interval(printed: Reading, others: Sequence[Reading]
                      ) -> tuple[float | None, float | None]:
    """The interval of a figure that covers every reading the record allows: the printed
    reading's own, widened to each other reading's interval (its value where it has no
    interval; a reading without the term holds 0). A bound the printed reading does not
    know (None) stays unknown."""
    low, high = printed.low, printed.high
    for r in others:
        if r.value is None or not math.isfinite(r.value):
            continue
        lo = r.value if r.low is None else r.low
        hi = r.value if r.high is None else r.high
        low = None if low is None else min(low, lo)
        high = None if high is None else max(high, hi)
    return low, high


def safe_verdict(verdicts: Sequence[Verdict]) -> Verdict:
    """One verdict from those of every reading: pass when all pass, fail when all fail,
    indeterminate otherwise."""
    if all(v == "pass" for v in verdicts):
        return "pass"
    if all(v == "fail" for v in verdicts):
        return "fail"
    return INDETERMINATE


def readings_note(readings: Sequence[Reading], unit: str, factor: float = 1.0) -> str:
    """A sentence naming the other readings of a figure ('' when there are none)."""
    if not readings:
        return ""

    def fmt(v: float | None) -> str:
        return "?" if v is None else f"{v / factor:.3g}"

    parts = [f"{fmt(r.value)} [{fmt(r.low)}, {fmt(r.high)}] {unit} (terms {r.terms})"
             for r in readings]
    return ("ambiguous: the record also allows " + "; ".join(parts)
            + "; the verdict holds for every reading")
