"""Least-squares fits of the five IEEE noise terms to an Allan variance curve.

The model is Lv et al. 2015, eq. 3::

    avar(tau) = 3 Q^2 / tau^2 + N^2 / tau + (0.664 B)^2 + K^2 tau / 3 + R^2 tau^2 / 2

linear in ``beta = [3 Q^2, N^2, (0.664 B)^2, K^2/3, R^2/2]`` with design columns
``[tau^-2, tau^-1, 1, tau, tau^2]`` (eq. 5-6). The paper's printed beta vector ends in
``K^2/2``; that is a typo for ``R^2/2`` (the rate-ramp term of eq. 3), and ``R^2/2`` is
what is used here.

Methods (``method=``):

``ols``
    ordinary least squares on every value (eq. 7);
``ols40``
    ordinary least squares on the values whose eq. 8 error ``1/sqrt(2(J-1))`` is under 40 %;
``wls``
    weighted by the cluster count J (eq. 11-14): rows of ``y`` and ``X`` times ``J``;
``nnls``
    the same J-weighted system solved under ``beta >= 0`` (scipy's NNLS), so that no
    variance term comes out negative;
``logwls``
    least squares on ``log avar`` under ``beta >= 0``, each value weighted by its own
    precision (``edf / 2``, the inverse variance of the log of a chi-square estimate,
    with a 2 % model-error floor) and by its share of an octave of tau, so that a dense
    grid of strongly correlated values does not outvote the sparse short taus (see
    :func:`_fit_log`).

Coefficients are returned in data-sheet units (urad, deg/sqrt(h), deg/h, deg/h^1.5,
deg/h^2) with a standard error each (covariance of beta from the weighted residuals,
propagated to the coefficient by the delta method).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize, special

from analysis.allan import AllanResult
from analysis.errors import FitError
from analysis.units import DEG_PER_URAD, S_PER_H

FitMethod = Literal["ols", "ols40", "wls", "nnls", "logwls"]
FIT_METHODS: tuple[FitMethod, ...] = ("ols", "ols40", "wls", "nnls", "logwls")

TERMS = "QNBKR"
#: Exponent of tau in each term's Allan variance (eq. 3).
TAU_POWER = {"Q": -2, "N": -1, "B": 0, "K": 1, "R": 2}
#: beta = factor * coefficient^2 (eq. 6, with R^2/2 in place of the printed K^2/2).
BETA_FACTOR = {"Q": 3.0, "N": 1.0, "B": 0.664**2, "K": 1.0 / 3.0, "R": 0.5}
#: Coefficient in base units (deg, s) times this gives the data-sheet unit.
TO_DATASHEET = {
    "Q": 1.0 / DEG_PER_URAD,  # deg -> urad
    "N": math.sqrt(S_PER_H),  # deg/sqrt(s) -> deg/sqrt(h)
    "B": S_PER_H,  # deg/s -> deg/h
    "K": S_PER_H**1.5,  # deg/s^1.5 -> deg/h^1.5
    "R": S_PER_H**2,  # deg/s^2 -> deg/h^2
}
#: JSON/data-sheet name of each coefficient.
COEFFICIENT_NAMES = {
    "Q": "Q_urad",
    "N": "N_deg_rt_h",
    "B": "B_deg_h",
    "K": "K_deg_h_1_5",
    "R": "R_deg_h2",
}
OLS40_MAX_ERROR = 0.40
#: Relative error floor of the five-term model assumed by ``logwls`` (2 % of avar).
DEFAULT_MODEL_ERROR = 0.02


@dataclass(frozen=True)
class NoiseCoefficients:
    """Fitted noise-term coefficients in data-sheet units.

    A coefficient is ``None`` when it was not fitted or its variance term came out
    negative (no physical meaning); ``negative_terms`` names the latter.

    Attributes
    ----------
    method : str
        Fit method (see the module docstring).
    terms : str
        The fitted terms, a subset of ``"QNBKR"``.
    values : dict
        ``{"Q": urad, "N": deg/sqrt(h), "B": deg/h, "K": deg/h^1.5, "R": deg/h^2}``,
        ``None`` where not estimable.
    stderr : dict
        Standard error of each value in the same unit, ``None`` where not estimable.
    beta : ndarray, shape (5,)
        The fitted variance coefficients of eq. 6 in base units ((deg/s)^2 s^p), NaN for
        terms not fitted.
    negative_terms : str
        Terms whose fitted variance coefficient is negative.
    n_points : int
        Number of Allan variance values used.
    """

    method: str
    terms: str
    values: dict[str, float | None]
    stderr: dict[str, float | None]
    beta: NDArray[np.float64]
    negative_terms: str = ""
    n_points: int = 0
    iterations: int = field(default=1)

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
        """JSON form: ``method``, each ``<name>`` and ``<name>_stderr`` (null where not estimable)."""
        out: dict[str, object] = {"method": self.method}
        for term in TERMS:
            name = COEFFICIENT_NAMES[term]
            out[name] = self.values[term]
            out[f"{name}_stderr"] = self.stderr[term]
        out["negative_terms"] = list(self.negative_terms)
        return out


def design_matrix(tau_s: ArrayLike, terms: str = TERMS) -> NDArray[np.float64]:
    """Columns ``tau^p`` of eq. 5 for the chosen terms (p = -2, -1, 0, 1, 2 for Q, N, B, K, R)."""
    tau = np.asarray(tau_s, dtype=float)
    return np.column_stack([tau ** TAU_POWER[t] for t in terms])


def _check_terms(terms: str) -> str:
    terms = "".join(t for t in TERMS if t in terms.upper())
    extra = set(terms.upper()) - set(TERMS)
    if not terms or extra:
        raise FitError(f"terms must be a non-empty subset of 'QNBKR', got {terms!r}")
    return terms


def _solve(
    x: NDArray[np.float64], y: NDArray[np.float64], *, nonnegative: bool
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Least squares of ``x b = y`` with columns scaled to unit norm; returns (b, cov(b)).

    The covariance is ``s^2 (X^T X)^-1`` with ``s^2`` the residual variance.
    """
    scale = np.linalg.norm(x, axis=0)
    scale[scale == 0] = 1.0
    xs = x / scale
    y_scale = np.linalg.norm(y) or 1.0
    ys = y / y_scale
    if nonnegative:
        bs, _ = optimize.nnls(xs, ys, maxiter=50 * xs.shape[1])
    else:
        bs = np.linalg.lstsq(xs, ys, rcond=None)[0]
    resid = ys - xs @ bs
    dof = max(len(ys) - xs.shape[1], 1)
    s2 = float(resid @ resid) / dof
    cov_s = s2 * np.linalg.pinv(xs.T @ xs)
    b = bs * y_scale / scale
    cov = cov_s * y_scale**2 / np.outer(scale, scale)
    return b, cov


def _weighted_system(
    method: str, result: AllanResult, avar: NDArray[np.float64], x: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    j = result.n_clusters.astype(float)
    keep = np.ones(len(avar), dtype=bool)
    if method == "ols40":
        keep = result.relative_error < OLS40_MAX_ERROR
    if method in ("wls", "nnls"):
        return x * j[:, None], avar * j, keep
    return x, avar, keep


def fit_noise_terms(
    result: AllanResult, *, method: FitMethod = "wls", terms: str = TERMS,
    model_error: float = DEFAULT_MODEL_ERROR, exclude_tau_s: tuple[tuple[float, float], ...] = (),
) -> NoiseCoefficients:
    """Fit the five-term model (Lv 2015 eq. 3) to a single-axis Allan variance.

    Parameters
    ----------
    result : AllanResult
        A single-axis Allan variance in (deg/s)^2 (use ``result.axis(i)`` first).
    method : {"ols", "ols40", "wls", "nnls", "logwls"}
        See the module docstring: eq. 7, eq. 7 on values under 40 % error (eq. 8),
        eq. 14, eq. 14 under beta >= 0, or log-domain weighted least squares.
    terms : str
        Which of ``"QNBKR"`` to fit; the others are held at zero.
    model_error : float
        ``logwls`` only: relative error floor of the five-term model (fraction of the
        Allan variance, default 2 %), added in quadrature to each value's sampling error
        in the log domain. Without it the very precise short-tau values of a long real
        record decide every term, and a small misfit there pulls B off the plateau.
    exclude_tau_s : tuple of (float, float)
        Closed tau ranges (s) left out of the fit: where the curve holds something the
        five terms do not describe (a tone, an output filter; see :mod:`analysis.zones`).

    Returns
    -------
    NoiseCoefficients

    Raises
    ------
    FitError
        Unknown method or terms, a multi-axis result, or fewer usable values than terms.
    """
    if method not in FIT_METHODS:
        raise FitError(f"unknown fit method {method!r}; use one of {', '.join(FIT_METHODS)}")
    terms = _check_terms(terms)
    avar = np.asarray(result.avar, dtype=float)
    if avar.ndim != 1:
        raise FitError("fit one axis at a time: pass result.axis(i)")
    x_full = design_matrix(result.tau_s, terms)
    x, y, keep = _weighted_system(method, result, avar, x_full)
    for lo, hi in exclude_tau_s:
        keep = keep & ~((result.tau_s >= lo) & (result.tau_s <= hi))
    if keep.sum() < len(terms):
        raise FitError(
            f"{int(keep.sum())} Allan values usable by {method}, fewer than the {len(terms)} terms "
            f"to fit; record longer or fit fewer terms"
        )
    x, y = x[keep], y[keep]
    if method == "logwls":
        if not model_error >= 0:
            raise FitError(f"model_error must be >= 0, got {model_error}")
        b, cov, iterations = _fit_log(result, keep, x_full[keep], avar[keep], model_error)
    else:
        b, cov = _solve(x, y, nonnegative=method == "nnls")
        iterations = 1
    return _coefficients(method, terms, b, cov, n_points=int(keep.sum()), iterations=iterations)


def log_tau_share(tau_s: ArrayLike) -> NDArray[np.float64]:
    """Each tau's share of an octave of log tau on its grid: ``dlog(tau) / log 2``.

    Half the log distance to each neighbour (the end points take their one side), so
    that the shares of a run of values sum to the octaves they span. Values on a dense
    grid (every m) are strongly correlated; weighting by this share counts each octave
    about once, as its information does, instead of once per value.
    """
    logt = np.log(np.asarray(tau_s, dtype=float))
    if len(logt) == 1:
        return np.ones(1)
    edges = np.concatenate([[logt[0] - (logt[1] - logt[0]) / 2], (logt[1:] + logt[:-1]) / 2,
                            [logt[-1] + (logt[-1] - logt[-2]) / 2]])
    return np.diff(edges) / math.log(2.0)


def _fit_log(
    result: AllanResult, keep: NDArray[np.bool_], x: NDArray[np.float64], avar: NDArray[np.float64],
    model_error: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Weighted least squares of ``log avar`` under ``beta >= 0`` (the ``logwls`` method).

    Residual ``r_i = sqrt(s_i / (2 / edf_i + e^2)) (log a_i - c_i - log m_i(beta))``: the
    variance of the log of a chi-square estimate with ``edf`` dof is about ``2 / edf``,
    ``e`` (``model_error``) is the relative error floor of the model itself, and
    ``c_i = psi(edf/2) - log(edf/2)`` removes its mean offset; ``s_i`` is the value's
    share of an octave (:func:`log_tau_share`), so a dense grid of correlated values
    counts once per octave. Log residuals penalize a model above and below the data
    alike, so a curve the five terms cannot follow everywhere is not pulled up or down.
    """
    edf = np.asarray(result.edf, dtype=float)[keep]
    share = log_tau_share(result.tau_s[keep])
    # var(log a_i) = 2 / edf_i from sampling, plus model_error^2 because no gyro follows
    # eq. 3 to the 0.1 % that a million-sample record resolves at short tau
    sw = np.sqrt(share / (2.0 / edf + model_error**2))
    target = np.log(avar) - (special.digamma(edf / 2.0) - np.log(edf / 2.0))
    scale = np.linalg.norm(x / avar[:, None] * sw[:, None], axis=0)
    scale[scale == 0] = 1.0
    xs = x / scale
    # start: NNLS of the relative residuals, the measured values standing in for the model
    u0, _ = optimize.nnls(xs / avar[:, None] * sw[:, None], sw, maxiter=50 * x.shape[1])
    floor = 1e-300

    def residual(u: NDArray[np.float64]) -> NDArray[np.float64]:
        return sw * (target - np.log(np.maximum(xs @ u, floor)))

    def jacobian(u: NDArray[np.float64]) -> NDArray[np.float64]:
        return -sw[:, None] * xs / np.maximum(xs @ u, floor)[:, None]

    u0 = np.maximum(u0, 1e-12 * max(float(u0.max()), 1e-300))
    sol = optimize.least_squares(residual, u0, jac=jacobian, bounds=(0.0, np.inf), method="trf",
                                 x_scale="jac", xtol=1e-12, ftol=1e-12, max_nfev=500)
    jac = jacobian(sol.x)
    dof = max(len(avar) - x.shape[1], 1)
    s2 = max(float(sol.fun @ sol.fun) / dof, 1.0)
    cov_u = s2 * np.linalg.pinv(jac.T @ jac)
    # a term the bound holds at (numerically) zero is zero, not a tiny positive value
    sol.x[sol.x < 1e-9 * float(sol.x.max(initial=0.0))] = 0.0
    return sol.x / scale, cov_u / np.outer(scale, scale), int(sol.nfev)


def _coefficients(
    method: str, terms: str, b: NDArray[np.float64], cov: NDArray[np.float64], *,
    n_points: int, iterations: int,
) -> NoiseCoefficients:
    beta = np.full(len(TERMS), np.nan)
    values: dict[str, float | None] = dict.fromkeys(TERMS)
    stderr: dict[str, float | None] = dict.fromkeys(TERMS)
    negative = ""
    for k, term in enumerate(terms):
        bk = float(b[k])
        sb = math.sqrt(max(float(cov[k, k]), 0.0))
        beta[TERMS.index(term)] = bk
        c, unit = BETA_FACTOR[term], TO_DATASHEET[term]
        if bk > 0:
            values[term] = math.sqrt(bk / c) * unit
            stderr[term] = sb / (2.0 * math.sqrt(c * bk)) * unit
        elif bk == 0:
            values[term] = 0.0
            stderr[term] = math.sqrt(sb / c) * unit
        else:
            negative += term
    return NoiseCoefficients(method, terms, values, stderr, beta, negative, n_points, iterations)


def theoretical_avar(coefficients: dict[str, float], tau_s: ArrayLike) -> NDArray[np.float64]:
    """Allan variance ((deg/s)^2) of eq. 3 for coefficients in data-sheet units.

    ``coefficients`` maps any of ``"Q"`` (urad), ``"N"`` (deg/sqrt(h)), ``"B"`` (deg/h),
    ``"K"`` (deg/h^1.5), ``"R"`` (deg/h^2) to a value; missing terms are zero.
    """
    tau = np.asarray(tau_s, dtype=float)
    total = np.zeros_like(tau)
    for term, value in coefficients.items():
        base = value / TO_DATASHEET[term]
        total = total + BETA_FACTOR[term] * base**2 * tau ** TAU_POWER[term]
    return total
