"""What a five-term fit returns: the coefficients in data-sheet units with their standard
errors and notes (:class:`NoiseCoefficients`), and the other readings of the same record its
criteria cannot tell from it (:class:`Alternative`, made by :mod:`analysis.figures.ambiguity`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.curves import FLICKER_AVAR_FACTOR, gauss_markov_avar
from analysis.fit.model import COEFFICIENT_NAMES, TAU_POWER, TERMS


def _peak_adev_per_sigma() -> float:
    """The largest Allan deviation of a Gauss-Markov process per its sigma (0.617, at
    about 1.89 correlation times; IEEE Std 952-1997, Annex C)."""
    x = np.logspace(-0.5, 1.0, 4001)
    return float(np.sqrt(gauss_markov_avar(x, 1.0, 1.0).max()))


#: The bias instability whose Allan floor equals a Gauss-Markov process' Allan peak, per
#: the process' sigma: 0.617 / 0.664 = 0.929 (the factor the B read-off divides by).
GM_B_EQUIVALENT = _peak_adev_per_sigma() / float(np.sqrt(FLICKER_AVAR_FACTOR))


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
        ``candidate_terms`` tried (:mod:`analysis.fit.selection`); empty otherwise.
    alternatives : tuple of Alternative
        Other readings of the same record that its criteria cannot tell from this one
        (:mod:`analysis.figures.ambiguity`); empty when the reading is unambiguous.
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


def _pm(err: float | None) -> str:
    return "" if err is None else f" +- {err:.2g}"


@dataclass(frozen=True)
class GaussMarkovReading:
    """A first-order Gauss-Markov process read from the record by the GMWM in place of a
    bias instability or a rate random walk (:mod:`analysis.figures.bias_or_markov`).

    Attributes
    ----------
    sigma_deg_h, sigma_stderr_deg_h : float
        The process' stationary standard deviation (deg/h) and its standard error (None
        where the GMWM has none, e.g. a parameter held at a bound).
    tau_s, tau_stderr_s : float
        Its correlation time (s) and standard error (None likewise).
    """

    sigma_deg_h: float
    sigma_stderr_deg_h: float | None
    tau_s: float
    tau_stderr_s: float | None

    @property
    def bias_instability_deg_h(self) -> float:
        """The B (deg/h) a bias instability would need for an Allan floor as high as this
        process' Allan peak: ``sigma * GM_B_EQUIVALENT``. Both figures then describe the
        same largest wander of adjacent averages, so a B limit judges them alike."""
        return self.sigma_deg_h * GM_B_EQUIVALENT

    @property
    def bias_instability_stderr_deg_h(self) -> float | None:
        """Standard error (deg/h) of :attr:`bias_instability_deg_h` (None where sigma has
        none)."""
        err = self.sigma_stderr_deg_h
        return None if err is None else err * GM_B_EQUIVALENT


@dataclass(frozen=True)
class Alternative:
    """Another reading of the record, as good by its criteria as the one printed.

    Attributes
    ----------
    fit : NoiseCoefficients
        The reading: its terms, values and standard errors (data-sheet units).
    criterion_delta : float or None
        Its ``logwls`` information criterion minus the printed reading's (negative: the
        term selection preferred it); None where not computed (a Gauss-Markov reading,
        which the ``logwls`` terms cannot hold).
    wavelet_criterion_delta : float or None
        The same for the GMWM's wavelet information criterion; None where not computed.
    gauss_markov : GaussMarkovReading or None
        The Gauss-Markov process this reading holds in place of the printed reading's
        bias instability or rate random walk (whose value it leaves None); None otherwise.
    """

    fit: NoiseCoefficients
    criterion_delta: float | None
    wavelet_criterion_delta: float | None = None
    gauss_markov: GaussMarkovReading | None = None

    @property
    def terms(self) -> str:
        """The reading's terms, ``+GM`` appended where it holds a Gauss-Markov process."""
        return self.fit.terms + ("+GM" if self.gauss_markov is not None else "")

    def describe(self) -> str:
        """One line: the terms and the values of the terms that differ from zero."""
        shown = []
        for t in self.fit.candidate_terms:
            v, s = self.fit.values[t], self.fit.stderr[t]
            if v is not None and v > 0:
                shown.append(f"{t} {v:.3g}" + (f" +- {s:.2g}" if s is not None else ""))
        gm = self.gauss_markov
        if gm is not None:
            shown.append(f"GM sigma {gm.sigma_deg_h:.3g}{_pm(gm.sigma_stderr_deg_h)} deg/h, "
                         f"tau {gm.tau_s:.3g}{_pm(gm.tau_stderr_s)} s")
        return f"terms {self.terms}: {', '.join(shown) or 'none above zero'}"

    def as_dict(self) -> dict[str, object]:
        """JSON form: ``terms``, ``values`` and ``stderr`` by coefficient name (with
        ``GM_sigma_deg_h`` and ``GM_tau_s`` where the reading holds a Gauss-Markov
        process), ``criterion_delta``, ``wavelet_criterion_delta``."""
        values: dict[str, float | None] = {COEFFICIENT_NAMES[t]: self.fit.values[t]
                                           for t in TERMS}
        stderr: dict[str, float | None] = {COEFFICIENT_NAMES[t]: self.fit.stderr[t]
                                           for t in TERMS}
        gm = self.gauss_markov
        if gm is not None:
            values |= {"GM_sigma_deg_h": gm.sigma_deg_h, "GM_tau_s": gm.tau_s}
            stderr |= {"GM_sigma_deg_h": gm.sigma_stderr_deg_h, "GM_tau_s": gm.tau_stderr_s}
        return {
            "terms": self.terms,
            "values": values,
            "stderr": stderr,
            "criterion_delta": self.criterion_delta,
            "wavelet_criterion_delta": self.wavelet_criterion_delta,
        }
