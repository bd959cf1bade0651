"""GMWM model selection: candidate models ranked by the wavelet information criterion.

Every candidate is fitted (:mod:`analysis.gmwm`) with the same weights, ``V^-1`` of the
largest candidate's efficient fit (with its model-error floor when that model is
rejected), so that their objectives compare, and ranked by

    WIC = J + 2 tr(Omega D (D' Omega D)^-1 D' Omega V)                                 (S1)

the estimated expected distance of the fitted model to an independent copy of the
empirical wavelet variance (Balamuta et al., arXiv 1603.05297, section 4: the in-sample
distance J is optimistic by twice the trace, the covariance between the fitted and the
empirical WV weighted by Omega). With ``Omega = V^-1`` the trace is the number of free
parameters, those not held at a bound, so a term fitted to zero costs nothing and adds
nothing. Ties (a larger model whose extra term is zero) go to the model with fewer
parameters. The ranking is reported whole, not only the winner; the winner is then
refitted with its own efficient weights.

:func:`gmwm_analysis` is the whole workflow for one axis of a record: the Haar wavelet
variance (classical or robust), then a given model or the automatic selection.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.confidence import ONE_SIGMA
from analysis.gmwm.covariance import clear_rules
from analysis.gmwm.estimator import (
    GMWM_MIN_BLOCKS,
    GmwmFit,
    gmwm,
    gmwm_with_covariance,
    weight_covariance,
)
from analysis.gmwm.models import GmwmModel, GmwmModelError
from analysis.gmwm.wavelet import WaveletVariance, haar_wavelet_variance

#: Terms of the automatic candidate set: white noise always, then these combinations.
AUTO_CANDIDATES = (("", "qn"), ("", "gm", "gm+gm"), ("", "bi"), ("", "rw"))


@dataclass(frozen=True)
class RankedModel:
    """One candidate of model selection: its WIC and what it is made of."""

    model: str
    criterion: float
    objective: float
    n_free: int
    effective: str = ""


@dataclass(frozen=True)
class GmwmSelection:
    """The selected model's fit and the whole ranking (best, i.e. lowest WIC, first)."""

    best: GmwmFit
    ranking: tuple[RankedModel, ...]
    reference: str
    wavelet: WaveletVariance

    @property
    def runner_up(self) -> RankedModel | None:
        """The best candidate that amounts to another model than the winner (None if none)."""
        first = self.ranking[0].effective
        return next((r for r in self.ranking[1:] if r.effective != first), None)

    def as_json(self) -> dict[str, object]:
        """The ``gmwm`` object of ``station analyze --json``: the fit's JSON (model, params,
        stderr, ...) plus ``ranking: [{"model", "criterion", ...}]``, the empirical WV's
        interval (``wv_ci_low_deg2_s2``, ``wv_ci_high_deg2_s2``; ``wv_ci_low``, ``wv_ci_high``:
        the same) and the model whose weights ranked the candidates."""
        w = self.wavelet
        return {
            **self.best.as_json(),
            "ranking": [
                {
                    "model": r.model,
                    "criterion": r.criterion,
                    "objective": r.objective,
                    "n_free": r.n_free,
                    "effective": r.effective,
                }
                for r in self.ranking
            ],
            "criterion": "WIC",
            "selection_weights_from": self.reference,
            "wv_ci_low_deg2_s2": np.asarray(w.ci_low).tolist(),
            "wv_ci_high_deg2_s2": np.asarray(w.ci_high).tolist(),
            "wv_ci_low": np.asarray(w.ci_low).tolist(),
            "wv_ci_high": np.asarray(w.ci_high).tolist(),
            "wv_ci": w.ci,
            "robust": w.robust,
        }


def effective_model(fit: GmwmFit) -> str:
    """The model the fit amounts to: its terms whose variance is not held at zero."""
    kept = [
        code
        for code, (iv, _) in zip(fit.model.codes, fit.model.slices(), strict=True)
        if fit.free[iv]
    ]
    return "+".join(kept) or fit.model.name


def auto_candidates(n_levels: int) -> list[str]:
    """The automatic candidate set: ``wn`` plus every combination of ``AUTO_CANDIDATES``,
    keeping models with at most ``n_levels - 2`` parameters."""
    out = []
    for parts in itertools.product(*AUTO_CANDIDATES):
        model = GmwmModel.parse("+".join(["wn", *[p for p in parts if p]]))
        if model.n_params <= n_levels - 2:
            out.append(model.name)
    return out


def select_model(wv: WaveletVariance, candidates: Sequence[str] | None = None, *, steps: int = 2,
                 confidence: float = ONE_SIGMA) -> GmwmSelection:
    """Rank candidate models by the WIC and fit the best efficiently (module docstring).

    Parameters
    ----------
    wv : WaveletVariance
        Empirical wavelet variance of one axis.
    candidates : sequence of str, optional
        Model strings; default :func:`auto_candidates`.
    steps, confidence
        As in :func:`gmwm`, for the reference and the selected model.

    Returns
    -------
    GmwmSelection

    Raises
    ------
    GmwmModelError
        A bad candidate string, or no candidate small enough for the record.
    """
    names = list(
        dict.fromkeys(
            GmwmModel.parse(c).name for c in (candidates or auto_candidates(len(wv.tau_s)))
        )
    )
    usable = [n for n in names if GmwmModel.parse(n).n_params < len(wv.tau_s)]
    if not usable:
        raise GmwmModelError(
            f"no candidate model has fewer parameters than the {len(wv.tau_s)} scales"
        )
    reference = max(usable, key=lambda n: GmwmModel.parse(n).n_params)
    ref_fit = gmwm(wv, reference, steps=steps, confidence=confidence)
    v_ref = weight_covariance(ref_fit.model, ref_fit.params, wv, ref_fit.model_error)
    fits = {}
    ranking = []
    for name in usable:
        fit = gmwm_with_covariance(wv, name, v_ref, confidence=confidence)
        fits[name] = fit
        ranking.append(
            RankedModel(
                name,
                fit.objective + 2.0 * fit.n_free,
                fit.objective,
                fit.n_free,
                effective_model(fit),
            )
        )
    ranking.sort(key=lambda r: (round(r.criterion, 6), GmwmModel.parse(r.model).n_params))
    best_name = ranking[0].model
    best = (
        ref_fit
        if best_name == reference
        else gmwm(wv, best_name, steps=steps, confidence=confidence)
    )
    return GmwmSelection(best=best, ranking=tuple(ranking), reference=reference, wavelet=wv)


def gmwm_analysis(
    rate: ArrayLike,
    sample_rate_hz: float,
    *,
    model: str = "auto",
    robust: bool = False,
    confidence: float = ONE_SIGMA,
    gaps: bool = False,
    angle_out: NDArray[np.float64] | None = None,
) -> GmwmSelection:
    """Haar wavelet variance of one axis and its GMWM fit: a given model, or ``"auto"`` selection.

    The wavelet variance has every level the record holds (``floor(log2 N)`` scales,
    ``GMWM_MIN_BLOCKS``), as the reference implementation of the GMWM uses.

    With a given model the ranking holds that model alone, with its WIC (J + 2 free
    parameters under its own weights).

    Parameters
    ----------
    rate : array_like, shape (N,)
        Rate in deg/s.
    sample_rate_hz : float
        Sample rate in Hz.
    model : str
        ``"auto"`` or a model string such as ``"wn+gm+rw"``.
    robust : bool
        Use the robust (Huber-type) wavelet variance.
    confidence : float
        Level of the parameter and WV intervals.
    gaps : bool
        NaN samples are missing (:func:`analysis.gmwm.wavelet.haar_wavelet_variance`).
    angle_out : ndarray, shape (N + 1, 1), optional
        Where a long record's angle is kept (e.g. a memmap): the wavelet variance is then
        computed in bounded memory (:func:`analysis.gmwm.wavelet.haar_wavelet_variance`).

    Raises
    ------
    GmwmModelError, FitError, TooFewSamplesError, NonFiniteSamplesError
    """
    wv = haar_wavelet_variance(
        rate, sample_rate_hz, robust=robust, confidence=confidence, gaps=gaps, angle_out=angle_out,
        min_blocks=GMWM_MIN_BLOCKS,
    )
    if np.ndim(wv.wv) != 1:
        raise GmwmModelError("gmwm_analysis takes one axis; pass a 1-D rate")
    try:
        if model.strip().lower() == "auto":
            return select_model(wv, confidence=confidence)
        fit = gmwm(wv, model, confidence=confidence)
    finally:  # the rules of this record's levels serve no other record
        clear_rules()
    ranked = RankedModel(
        fit.model.name,
        fit.objective + 2.0 * fit.n_free,
        fit.objective,
        fit.n_free,
        effective_model(fit),
    )
    return GmwmSelection(best=fit, ranking=(ranked,), reference=fit.model.name, wavelet=wv)
