"""What a five-term fit returns: the coefficients in data-sheet units with their standard
errors and notes (:class:`NoiseCoefficients`), and the other readings of the same record its
criteria cannot tell from it (:class:`Alternative`, made by :mod:`analysis.ambiguity`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.fit_model import COEFFICIENT_NAMES, TAU_POWER, TERMS


@dataclass(frozen=True)
class NoiseCoefficients:
    """Fitted noise-term coefficients in data-sheet units.

    A coefficient is ``None`` when it was not a candidate or its variance term came out
    negative (no physical meaning; ``negative_terms`` names those). A candidate term the
    data do not resolve (``logwls`` leaves it out of the model) is ``0.0``, its standard
    error then the coefficient at which its variance term would be one standard error of
    the fit: an upper bound at 1 sigma, not a measurement.

    Attributes
    ----------
    method : str
        Fit method (see the module docstring).
    terms : str
        The terms in the fitted model, a subset of ``"QNBKR"``.
    values : dict
        ``{"Q": urad, "N": deg/sqrt(h), "B": deg/h, "K": deg/h^1.5, "R": deg/h^2}``,
        ``None`` where not estimable.
    stderr : dict
        Standard error of each value in the same unit; ``None`` where it cannot be computed
        honestly (``notes`` says why).
    beta : ndarray, shape (5,)
        The fitted variance coefficients of eq. 6 in base units ((deg/s)^2 s^p), NaN for
        terms not fitted.
    negative_terms : str
        Terms whose fitted variance coefficient is negative.
    n_points : int
        Number of Allan variance values used.
    iterations : int
        Function evaluations of an iterative fit (1 for the linear ones).
    candidate_terms : str
        The terms asked for (``terms`` is the subset kept); default ``terms``.
    notes : tuple of str
        What a reader of the numbers should know: terms left out and why, the origin of
        the standard errors, a model misfit.
    criteria : dict
        ``logwls`` with term selection: the information criterion of every subset of
        ``candidate_terms`` tried (:mod:`analysis.fit_select`); empty otherwise.
    alternatives : tuple of Alternative
        Other readings of the same record that its criteria cannot tell from this one
        (:mod:`analysis.ambiguity`); empty when the reading is unambiguous.
    """

    method: str
    terms: str
    values: dict[str, float | None]
    stderr: dict[str, float | None]
    beta: NDArray[np.float64]
    negative_terms: str = ""
    n_points: int = 0
    iterations: int = field(default=1)
    candidate_terms: str = ""
    notes: tuple[str, ...] = ()
    criteria: dict[str, float] = field(default_factory=dict)
    alternatives: tuple[Alternative, ...] = ()

    def model_avar(self, tau_s: ArrayLike) -> NDArray[np.float64]:
        """Allan variance ((deg/s)^2) of the fitted model at ``tau_s`` (s), eq. 3.

        Terms that were not fitted or came out negative contribute nothing.
        """
        tau = np.asarray(tau_s, dtype=float)
        total = np.zeros_like(tau)
        for i, term in enumerate(TERMS):
            b = self.beta[i]
            if np.isfinite(b) and b > 0:
                total = total + b * tau ** TAU_POWER[term]
        return total

    def term_avar(self, term: str, tau_s: ArrayLike) -> NDArray[np.float64]:
        """Allan variance ((deg/s)^2) of one fitted term at ``tau_s`` (s)."""
        b = self.beta[TERMS.index(term)]
        tau = np.asarray(tau_s, dtype=float)
        return (b if np.isfinite(b) and b > 0 else 0.0) * tau ** TAU_POWER[term]

    def as_dict(self) -> dict[str, object]:
        """JSON form: ``method``, each ``<name>`` and ``<name>_stderr`` (null where not
        estimable), ``negative_terms``, ``terms`` (the model's terms), ``notes`` and
        ``alternatives`` (the other readings the record allows, docs/json.md)."""
        out: dict[str, object] = {"method": self.method}
        for term in TERMS:
            name = COEFFICIENT_NAMES[term]
            out[name] = self.values[term]
            out[f"{name}_stderr"] = self.stderr[term]
        out["negative_terms"] = list(self.negative_terms)
        out["terms"] = self.terms
        out["notes"] = list(self.notes)
        out["alternatives"] = [a.as_dict() for a in self.alternatives]
        return out


@dataclass(frozen=True)
class Alternative:
    """Another reading of the record, as good by its criteria as the one printed.

    Attributes
    ----------
    fit : NoiseCoefficients
        The reading: its terms, values and standard errors (data-sheet units).
    criterion_delta : float
        Its ``logwls`` information criterion minus the printed reading's (negative: the
        term selection preferred it).
    wavelet_criterion_delta : float or None
        The same for the GMWM's wavelet information criterion; None where not computed.
    """

    fit: NoiseCoefficients
    criterion_delta: float
    wavelet_criterion_delta: float | None = None

    def describe(self) -> str:
        """One line: the terms and the values of the terms that differ from zero."""
        shown = []
        for t in self.fit.candidate_terms:
            v, s = self.fit.values[t], self.fit.stderr[t]
            if v is not None and v > 0:
                shown.append(f"{t} {v:.3g}" + (f" +- {s:.2g}" if s is not None else ""))
        return f"terms {self.fit.terms}: {', '.join(shown) or 'none above zero'}"

    def as_dict(self) -> dict[str, object]:
        """JSON form: ``terms``, ``values`` and ``stderr`` by coefficient name,
        ``criterion_delta``, ``wavelet_criterion_delta``."""
        return {
            "terms": self.fit.terms,
            "values": {COEFFICIENT_NAMES[t]: self.fit.values[t] for t in TERMS},
            "stderr": {COEFFICIENT_NAMES[t]: self.fit.stderr[t] for t in TERMS},
            "criterion_delta": self.criterion_delta,
            "wavelet_criterion_delta": self.wavelet_criterion_delta,
        }
