"""The other readings of an ambiguous fitted figure, and the verdict safe for a limit.

Where the record cannot tell two term sets apart (:mod:`analysis.figures.ambiguity`: a rate
random walk against a ramp or a bias instability, a bias instability or a walk against a
slow Gauss-Markov process), the fit carries the other readings
beside the one printed. A fitted figure then has several values, each with its interval;
a limit is passed only when every reading passes it, failed only when every reading fails
it, and indeterminate otherwise: never a pass bought by the zero of a term one reading
dropped.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from analysis.fit.least_squares import NoiseCoefficients
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
    """The readings of ``term`` by the fit's alternatives whose value differs from the
    printed one (``z``: the normal quantile of the profile's confidence)."""
    printed = fit.values[term]
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
        if value is None or (printed is not None and math.isclose(value, printed)):
            continue
        if err is None or not math.isfinite(err):
            out.append(Reading(alt.terms, value, None, None, equivalent))
        else:
            out.append(Reading(alt.terms, value, max(value - z * err, 0.0), value + z * err,
                               equivalent))
    return tuple(out)


def largest_reading(printed: Reading, others: Sequence[Reading], term: str
                    ) -> tuple[Reading, tuple[Reading, ...]]:
    """The reading a sheet prints of a figure the record reads several ways, and the others.

    The largest value among the readings that fit the term ``term`` itself: of two
    readings a record cannot tell apart, the larger is the one an upper limit and an error
    budget are safe with (a term one reading drops comes back as 0 there, a figure the
    realisation bought). A reading that drops the term, or reads it as a Gauss-Markov
    process' equivalent, is listed and judged but not printed: it is no fit of the term.
    Without such readings, ``printed`` itself."""
    readings = (printed, *others)
    fitted = [i for i, r in enumerate(readings) if term and term in r.terms
              and not r.equivalent and r.value is not None and math.isfinite(r.value)]
    if not others or not fitted:
        return printed, tuple(others)
    i = max(fitted, key=lambda j: (readings[j].value, -j))
    return readings[i], tuple(r for j, r in enumerate(readings) if j != i)


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
