"""A noise model fitted to a Haar wavelet variance by the GMWM (:mod:`analysis.gmwm`):
values in data-sheet units, their errors and intervals, the fit's statistics."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.allan.confidence import ONE_SIGMA
from analysis.gmwm.equivalent import WhiteEquivalent, white_equivalent
from analysis.gmwm.models import GmwmModel


@dataclass(frozen=True)
class GmwmFit:
    """A noise model fitted to a Haar wavelet variance.

    Attributes
    ----------
    model : GmwmModel
        The model (``model.name`` e.g. ``"wn+gm+rw"``).
    params : ndarray
        Internal parameters (:mod:`analysis.gmwm.models`).
    cov : ndarray
        Their covariance (zero rows for parameters held at a bound).
    values, stderr, ci_low, ci_high : dict
        Data-sheet values (keys with units, e.g. ``gm_sigma_deg_h``), standard errors and
        interval at ``confidence``.
    objective : float
        J of the final weights.
    dof : int
        Levels minus free parameters.
    p_value : float
        P(chi2_dof >= J); NaN with no degree of freedom.
    weights : str
        ``"efficient"`` (full V), ``"diagonal"`` (its diagonal) or ``"reference"`` (the
        V of another model, as in model selection); ``"nonparametric+floor"`` when the
        model was rejected and refitted with the data's variances, floored (``model_error``).
    tau_s, wv, model_wv : ndarray
        Averaging times (s), empirical and fitted wavelet variance ((deg/s)^2).
    sample_rate_hz : float
    n_samples : int
    free : tuple of bool
        Which parameters are not held at a bound.
    confidence : float
    model_error : float
        The relative floor added to the weights' variances (0: none).
    """

    model: GmwmModel
    params: NDArray[np.float64]
    cov: NDArray[np.float64]
    values: dict[str, float]
    stderr: dict[str, float]
    ci_low: dict[str, float]
    ci_high: dict[str, float]
    objective: float
    dof: int
    p_value: float
    weights: str
    tau_s: NDArray[np.float64]
    wv: NDArray[np.float64]
    model_wv: NDArray[np.float64]
    sample_rate_hz: float
    n_samples: int
    free: tuple[bool, ...]
    confidence: float = ONE_SIGMA
    model_error: float = 0.0

    @property
    def n_free(self) -> int:
        """Number of free parameters."""
        return int(sum(self.free))

    def model_wv_at(self, tau_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fitted model's WV ((deg/s)^2) at any ``tau_s`` (its Allan variance is twice this)."""
        return self.model.wv(self.params, tau_s, 1.0 / self.sample_rate_hz)

    def term_wv_at(self, tau_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Each term's WV ((deg/s)^2), shape (n_terms, n_tau)."""
        return self.model.term_wv(self.params, tau_s, 1.0 / self.sample_rate_hz)

    def white_equivalent(self) -> WhiteEquivalent | None:
        """The angle random walk the white term and the Gauss-Markov / AR(1) terms faster
        than the shortest tau amount to, with each part (:mod:`analysis.gmwm.equivalent`);
        None when the model has no such fast term."""
        return white_equivalent(self.model, self.params, self.cov, 1.0 / self.sample_rate_hz,
                                float(self.tau_s[0]))

    def as_json(self) -> dict[str, object]:
        """JSON form: model, params, stderr (same keys), intervals, fit statistics, the WV
        (``wv_deg2_s2``, ``model_wv_deg2_s2``, in (deg/s)^2; ``wv``, ``model_wv``: the same
        values under the keys of the GMWM interface)."""
        def clean(d: dict[str, float]) -> dict[str, float | None]:
            return {k: (v if math.isfinite(v) else None) for k, v in d.items()}

        equivalent = self.white_equivalent()
        return {
            "model": self.model.name,
            "params": clean(self.values),
            **({"wn_equivalent_readings": list(equivalent.readings()),
                "wn_equivalent_parts_deg_rt_h": dict(equivalent.parts)}
               if equivalent is not None else {}),
            "stderr": clean(self.stderr),
            "ci_low": clean(self.ci_low),
            "ci_high": clean(self.ci_high),
            "confidence": self.confidence,
            "objective": self.objective,
            "dof": self.dof,
            "p_value": self.p_value if math.isfinite(self.p_value) else None,
            "weights": self.weights,
            "wv_tau_s": self.tau_s.tolist(),
            "wv_deg2_s2": self.wv.tolist(),
            "model_wv_deg2_s2": self.model_wv.tolist(),
            "wv": self.wv.tolist(),
            "model_wv": self.model_wv.tolist(),
        }
