"""Model versus measurement, step 2: the candidate effects and their fits to the measured curve.

A candidate is one term of the simulation library (:data:`analysis.models.TERM_NAMES`,
except the constant ``bias``, which has no Allan variance): *added* when the model lacks
it, *refitted* when the model has it (its parameters are then free, so the data may say
there is more of it or less of it than the model claims). Every term's Allan variance is
``theta^2 g(tau; eta)``: a scale ``theta`` (the key named in :data:`SCALE_KEYS`) times a
shape that depends on at most one further parameter ``eta`` (the Gauss-Markov
correlation time ``tau_s``, the sinusoid's ``period_s``). The temperature-driven bias is
the measured temperature's own Allan variance times the squared coefficient (the bias is
``c (T(t) - T_ref)``, deterministic given the temperature), so it is fitted only when the
record has a temperature channel. Bias steps have, on average, the second moments of a
rate random walk with ``K^2 = lambda s^2`` (see :class:`analysis.models.BiasSteps`), but
one record holds a handful of them and its curve is far from that average; so they are a
candidate only when the change-point test of :mod:`analysis.reconcile.confirm` has located them, and
their shape is the Allan variance of the steps located (scale 1 = as found).

**Fit.** With the model's other terms held, the candidate's parameters minimize the
weighted log residuals of :mod:`analysis.reconcile.discrepancy` (the ``logwls`` objective of
:mod:`analysis.fit`, eq. G1 weights):

    chi2(theta, eta) = sum_i (s_i / v_i) (log a_i - c_i - log(B_i + theta^2 g_i(eta)))^2   (C1)

with ``B_i`` the rest of the model. A grid over ``(log theta^2, log eta)`` finds the
global minimum (the sinusoid's curve is multimodal in its period) and
``scipy.optimize.least_squares`` refines it. Standard errors come from the Jacobian,
``cov = s^2 (J'J)^-1`` with ``s^2 = max(chi2 / (n_oct - k), 1)``, propagated to each key.

**Criterion.** Octave weighting makes C1 count about one observation per octave, so the
information criterion is BIC with ``n = sum_i s_i`` (the octaves of the grid):

    Delta BIC = chi2(model) - chi2(model + candidate) - k ln(n)                       (C2)

and a candidate is considered only if ``Delta BIC >= BIC_THRESHOLD`` (10: "very strong"
evidence on the scale of Kass and Raftery, J. Am. Stat. Assoc. 90, 1995, p. 777).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from analysis.models.terms import NoiseModel, NoiseTerm, term_type
from analysis.reconcile.discrepancy import Comparison, MeasuredCurve, allan_on_grid
from analysis.reconcile.options import BIC_THRESHOLD as BIC_THRESHOLD

#: The key of each term whose square scales its Allan variance.
SCALE_KEYS: dict[str, str] = {
    "quantization": "Q_urad",
    "arw": "N_deg_rt_h",
    "bias_instability": "B_deg_h",
    "rate_random_walk": "K_deg_h_1_5",
    "rate_ramp": "R_deg_h2",
    "gauss_markov": "sigma_deg_h",
    "sinusoid": "amplitude_deg_h",
    "temperature_bias": "coefficient_deg_s_per_c",
    "bias_steps": "size_deg_h",
}
#: The shape parameter of the terms that have one.
SHAPE_KEYS: dict[str, str] = {"gauss_markov": "tau_s", "sinusoid": "period_s"}
#: Values of the non-fitted keys when a term is added (bias steps: one per hour, see above).
ADD_DEFAULTS: dict[str, dict[str, float]] = {"bias_steps": {"rate_per_h": 1.0}}
#: Fewest periods of a sinusoid in the record (fewer look like any slow noise).
MIN_CYCLES = 8.0
#: Shortest sinusoid period, in samples: a little over two, the Nyquist frequency (exactly
#: at Nyquist a sampled sinusoid can fall on its zeros).
NYQUIST_PERIODS = 2.05
#: Shape grid points per octave (dense enough for the sinusoid's lobes).
SHAPE_POINTS_PER_OCTAVE = 12
#: Scale grid points (log theta^2) before refinement.
SCALE_GRID = 48


@dataclass(frozen=True)
class CandidateFit:
    """A candidate effect fitted to the measured curve with the rest of the model held.

    Attributes
    ----------
    name : str
        Term name (``"sinusoid"``, ``"gauss_markov"``, ...).
    mode : str
        ``"add"`` (the model lacked the term) or ``"refit"`` (it had it).
    term : NoiseTerm
        The term with the fitted values.
    values, stderr : dict
        Fitted keys (units in their names) and their standard errors.
    chi2, delta_chi2, delta_bic : float
        C1 at the fit, its drop from the model's, and C2.
    n_params : int
        Number of fitted parameters k.
    model_avar : ndarray
        Allan variance (deg/s)^2 of the model with the candidate, on the grid.
    """

    name: str
    mode: str
    term: NoiseTerm
    values: dict[str, float]
    stderr: dict[str, float]
    chi2: float
    delta_chi2: float
    delta_bic: float
    n_params: int
    model_avar: NDArray[np.float64]

    def with_term(self, term: NoiseTerm) -> CandidateFit:
        """The same fit carrying another version of its term (e.g. refined from the time series)."""
        return replace(self, term=term)


def candidate_names(*, has_temperature: bool) -> tuple[str, ...]:
    """Every term the workflow can try on this model (temperature only with a channel)."""
    return tuple(n for n in SCALE_KEYS if n != "temperature_bias" or has_temperature)


def _unit_term(name: str, base: NoiseTerm | None, eta: float | None) -> NoiseTerm:
    """The term with scale 1 (and shape ``eta``), keeping the other keys of ``base``."""
    values: dict[str, float] = {SCALE_KEYS[name]: 1.0}
    if eta is not None:
        values[SHAPE_KEYS[name]] = eta
    if base is not None:
        return replace(base, **values)
    return term_type(name)(**{**ADD_DEFAULTS.get(name, {}), **values})


class _Shape:
    """``g(tau; eta)`` of one candidate on the grid: the Allan variance of its unit-scale term,
    or of its realization when the record shows it (temperature, located steps)."""

    def __init__(self, name: str, curve: MeasuredCurve, base: NoiseTerm | None,
                 realized: NDArray[np.float64] | None = None) -> None:
        self.name, self.curve, self.base = name, curve, base
        self.realized_curve = None
        if realized is not None:
            self.realized_curve = allan_on_grid(realized, curve.sample_rate_hz, curve.m)[:, 0]

    def __call__(self, eta: float | None) -> NDArray[np.float64]:
        if self.realized_curve is not None:
            return self.realized_curve
        return _unit_term(self.name, self.base, eta).avar(self.curve.tau_s)

    def eta_grid(self) -> NDArray[np.float64] | None:
        if self.name not in SHAPE_KEYS:
            return None
        dt, length = 1.0 / self.curve.sample_rate_hz, self.curve.duration_s
        # a sinusoid needs MIN_CYCLES periods in the record to be told from red noise, and
        # reaches up to the Nyquist frequency (a period of two samples)
        lo, hi = (3.0 * dt, length / 2.0) if self.name == "gauss_markov" else (NYQUIST_PERIODS * dt,
                                                                               length / MIN_CYCLES)
        count = int(math.log2(hi / lo) * SHAPE_POINTS_PER_OCTAVE) + 1
        return np.geomspace(lo, hi, count)


def _chi2_grid(y: NDArray[np.float64], w: NDArray[np.float64], base: NDArray[np.float64],
               g: NDArray[np.float64], logs: NDArray[np.float64]) -> NDArray[np.float64]:
    """C1 for every ``log theta^2`` in ``logs`` (rows) and shape curve in ``g`` (n_eta, n_tau)."""
    total = base[None, None, :] + np.exp(logs)[None, :, None] * g[:, None, :]
    resid = y[None, None, :] - np.log(np.maximum(total, np.finfo(float).tiny))
    return np.asarray((w * resid**2).sum(axis=-1), dtype=np.float64)


def fit_candidate(name: str, model: NoiseModel, curve: MeasuredCurve, comparison: Comparison, *,
                  realized: NDArray[np.float64] | None = None) -> CandidateFit | None:
    """Fit one candidate (C1) and score it (C2); None when its shape is zero on the grid.

    ``realized`` is the candidate's unit realization in the record when its curve is that
    of a realization (rate per unit coefficient for the temperature bias, the located
    steps for bias steps); the rest of the model's curve is the comparison's.
    """
    from scipy import optimize
    present = model.get(name)
    term_now = (
        present.avar(curve.tau_s, duration_s=curve.duration_s) if present is not None else 0.0
    )
    base = np.maximum(comparison.model_avar - term_now, 0.0)
    shape = _Shape(name, curve, present, realized)
    prec = curve.precision
    y = np.log(curve.avar) - prec.offset
    w = prec.weight
    etas = shape.eta_grid()
    g = np.array([shape(e) for e in etas]) if etas is not None else shape(None)[None, :]
    if not np.any(g > 0):
        return None
    ratio = curve.avar[None, :] / np.where(g > 0, g, np.nan)
    lo, hi = np.nanmin(ratio), np.nanmax(ratio)
    logs = np.linspace(math.log(lo) - 9.0, math.log(hi) + 2.0, SCALE_GRID)
    grid = _chi2_grid(y, w, base, g, logs)
    i_eta, i_s = np.unravel_index(int(np.argmin(grid)), grid.shape)
    sw = np.sqrt(w)

    def model_curve(p: NDArray[np.float64]) -> NDArray[np.float64]:
        gg = shape(math.exp(p[1])) if etas is not None else g[0]
        return base + math.exp(p[0]) * gg

    def resid(p: NDArray[np.float64]) -> NDArray[np.float64]:
        return sw * (y - np.log(np.maximum(model_curve(p), np.finfo(float).tiny)))

    p0 = [logs[i_s]] + ([math.log(etas[i_eta])] if etas is not None else [])
    lower = [logs[0] - 5.0] + ([math.log(etas[0])] if etas is not None else [])
    upper = [logs[-1] + 5.0] + ([math.log(etas[-1])] if etas is not None else [])
    sol = optimize.least_squares(resid, p0, bounds=(lower, upper), x_scale=1.0, diff_step=1e-4,
                                 xtol=1e-10, ftol=1e-10, max_nfev=200)
    chi2 = float(sol.fun @ sol.fun)
    k = len(p0)
    n_oct = float(prec.share.sum())
    s2 = max(chi2 / max(n_oct - k, 1.0), 1.0)
    cov = s2 * np.linalg.pinv(sol.jac.T @ sol.jac)
    theta = math.exp(sol.x[0] / 2.0)
    values = {SCALE_KEYS[name]: theta}
    stderr = {SCALE_KEYS[name]: theta * math.sqrt(max(cov[0, 0], 0.0)) / 2.0}
    if etas is not None:
        eta = math.exp(sol.x[1])
        values[SHAPE_KEYS[name]] = eta
        stderr[SHAPE_KEYS[name]] = eta * math.sqrt(max(cov[1, 1], 0.0))
    term = replace(_unit_term(name, present, values.get(SHAPE_KEYS.get(name, ""))), **values)
    chi2_model = float((w * (y - np.log(comparison.model_avar)) ** 2).sum())
    delta = chi2_model - chi2
    return CandidateFit(
        name=name, mode="refit" if present is not None else "add", term=term, values=values,
        stderr=stderr, chi2=chi2, delta_chi2=delta, delta_bic=delta - k * math.log(max(n_oct, 1.0)),
        n_params=k, model_avar=model_curve(sol.x),
    )


def fit_candidates(model: NoiseModel, curve: MeasuredCurve, comparison: Comparison, *,
                   steps: NDArray[np.float64] | None = None) -> list[CandidateFit]:
    """Every candidate fitted and scored, best (largest Delta BIC, C2) first.

    ``steps`` is the bias the change-point test located (deg/s per sample); without it
    there is no bias-steps candidate (their Allan curve alone is a rate random walk's).
    """
    realized = {"temperature_bias": curve.temperature_c, "bias_steps": steps}
    fits = []
    for name in candidate_names(has_temperature=curve.temperature_c is not None):
        if name == "bias_steps" and (steps is None or name in model):
            continue
        fit = fit_candidate(name, model, curve, comparison, realized=realized.get(name))
        if fit is not None:
            fits.append(fit)
    return sorted(fits, key=lambda f: -f.delta_bic)


def change_of(fit: CandidateFit, model: NoiseModel, curve: MeasuredCurve) -> str:
    """``"added"``, or for a refitted term ``"increased"``, ``"decreased"`` or ``"replaced"``."""
    old = model.get(fit.name)
    if old is None:
        return "added"
    before = old.avar(curve.tau_s, duration_s=curve.duration_s)
    after = fit.term.avar(curve.tau_s, duration_s=curve.duration_s)
    if np.all(after <= before * (1 + 1e-9)):
        return "decreased"
    if np.all(after >= before * (1 - 1e-9)):
        return "increased"
    return "replaced"


def tau_range(before: NDArray[np.float64], after: NDArray[np.float64], tau_s: NDArray[np.float64],
              *, share: float = 0.2) -> tuple[float, float]:
    """Taus where the change of the model's Allan variance is at least ``share`` of the larger
    curve."""
    changed = np.abs(after - before) >= share * np.maximum(after, before)
    if not changed.any():
        i = int(np.argmax(np.abs(after - before)))
        return float(tau_s[i]), float(tau_s[i])
    idx = np.nonzero(changed)[0]
    return float(tau_s[idx[0]]), float(tau_s[idx[-1]])
