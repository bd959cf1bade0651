"""The ``logwls`` estimator: least squares of log Allan variance under ``beta >= 0``.

Residual ``r_i = sqrt(w_i) (log a_i - c_i - log m_i(beta))`` with

* ``w_i = s_i / (psi'(nu_i / 2) + e^2)``: ``psi'(nu/2)`` is the variance of the log of a
  chi-square estimate with ``nu`` (edf) degrees of freedom (``2/nu`` for large ``nu``,
  1.64 at ``nu = 2``), ``e`` (``model_error``) the relative error floor of the model
  itself, ``s_i`` the value's share of an octave (:func:`log_tau_share`), so a dense
  grid of correlated values counts once per octave;
* ``c_i = psi(nu_i/2) - log(nu_i/2)``, the mean of the log of a chi-square estimate
  divided by its dof, which would otherwise pull the fit below the curve at long tau.

Log residuals penalize a model above and below the data alike, so a curve the five terms
cannot follow everywhere is not pulled up or down. The weights define the estimator
only; its standard errors come from :mod:`analysis.fit.uncertainty`, which accounts for
the correlation the weights leave out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.estimators import AllanResult
from analysis.fit.model import TERMS, design_matrix, full_beta

#: Most Gauss-Newton steps of one fit.
MAX_STEPS = 100


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


@dataclass(frozen=True)
class LogData:
    """What the log fit sees of a result: kept rows, targets, weights, the full design.

    Attributes
    ----------
    keep : ndarray of bool, shape (n_all,)
        Rows of the result used.
    tau_s : ndarray, shape (n,)
        Their taus (s).
    avar : ndarray, shape (n,)
        Their Allan values, (deg/s)^2.
    target : ndarray, shape (n,)
        ``log a_i - c_i``.
    weights : ndarray, shape (n,)
        ``w_i`` of the module docstring.
    design : ndarray, shape (n, 5)
        Columns ``tau^p`` of all five terms (QNBKR).
    """

    keep: NDArray[np.bool_]
    tau_s: NDArray[np.float64]
    avar: NDArray[np.float64]
    target: NDArray[np.float64]
    weights: NDArray[np.float64]
    design: NDArray[np.float64]

    def model(self, beta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Model Allan variance at the kept taus for a five-entry beta (NaN = absent)."""
        return self.design @ np.where(np.isfinite(beta), beta, 0.0)

    def residual(self, beta: NDArray[np.float64]) -> NDArray[np.float64]:
        """``target - log model`` (unweighted)."""
        return self.target - np.log(np.maximum(self.model(beta), 1e-300))

    def jacobian(self, beta: NDArray[np.float64]) -> NDArray[np.float64]:
        """d log model / d beta for all five terms: (n, 5)."""
        return self.design / np.maximum(self.model(beta), 1e-300)[:, None]


def log_data(result: AllanResult, keep: NDArray[np.bool_], model_error: float) -> LogData:
    """Targets and weights of the log fit (module docstring) for the rows ``keep`` of ``result``."""
    from scipy import special
    edf = np.asarray(result.edf, dtype=float)[keep]
    avar = np.asarray(result.avar, dtype=float)[keep]
    tau = np.asarray(result.tau_s, dtype=float)[keep]
    weights = log_tau_share(tau) / (special.polygamma(1, edf / 2.0) + model_error**2)
    target = np.log(avar) - (special.digamma(edf / 2.0) - np.log(edf / 2.0))
    return LogData(keep, tau, avar, target, weights, design_matrix(tau, TERMS))


def fit_log(data: LogData, terms: str, *, start: NDArray[np.float64] | None = None,
            tolerance: float = 1e-12, whiten: NDArray[np.float64] | None = None
            ) -> tuple[NDArray[np.float64], int]:
    """Minimize the weighted log residuals over ``beta >= 0`` for ``terms``.

    Projected Gauss-Newton: each step solves the linearized problem under the bounds
    (scipy's NNLS in the stepped-to point) and is halved until the cost falls.

    Parameters
    ----------
    data : LogData
        From :func:`log_data`.
    terms : str
        Terms to fit (the others are absent, NaN in the returned beta).
    start : ndarray, shape (5,), optional
        A starting beta; by default a non-negative least squares of the relative residuals.
    tolerance : float
        Relative tolerance on the cost.
    whiten : ndarray, shape (n, n), optional
        ``L^-1`` of a full covariance ``L L^T`` of the targets: the residuals are then
        ``L^-1 r`` (generalized least squares) instead of ``sqrt(w) r``.

    Returns
    -------
    beta : ndarray, shape (5,)
        Fitted variance coefficients (eq. 6, base units), exactly 0 where the bound holds.
    iterations : int
        Gauss-Newton steps taken.
    """
    from scipy import optimize
    cols = [TERMS.index(t) for t in terms]
    x = data.design[:, cols]
    sw = np.sqrt(data.weights)
    scale = np.linalg.norm(x / data.avar[:, None] * sw[:, None], axis=0)
    scale[scale == 0] = 1.0
    xs = x / scale
    # the measured values stand in for the model: NNLS of the relative residuals
    u, _ = optimize.nnls(xs / data.avar[:, None] * sw[:, None], sw, maxiter=50 * len(cols))
    u = np.maximum(u, 1e-6 * max(float(np.max(u, initial=0.0)), 1e-300))
    if not np.any(u > 0):
        u = np.ones(len(cols))

    def weigh(a: NDArray[np.float64]) -> NDArray[np.float64]:
        if whiten is not None:
            return whiten @ a
        return sw * a if a.ndim == 1 else sw[:, None] * a

    def residual(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return weigh(data.target - np.log(np.maximum(xs @ v, 1e-300)))

    if start is not None and np.any(np.nan_to_num(start[cols]) > 0):
        given = np.nan_to_num(start[cols]) * scale
        given = np.maximum(given, 1e-6 * float(given.max()))
        if float(np.sum(residual(given) ** 2)) < float(np.sum(residual(u) ** 2)):
            u = given
    r = residual(u)
    cost = float(r @ r)
    steps = 0
    for steps in range(1, MAX_STEPS + 1):  # noqa: B007  (the count is returned)
        jac = weigh(xs / np.maximum(xs @ u, 1e-300)[:, None])
        step = np.linalg.lstsq(jac, r, rcond=None)[0]
        if np.any(u + step < 0):
            # the bound binds: the linearized problem under u + step >= 0, an NNLS in
            # t = u + step (min |J t - (r + J u)|, t >= 0: the same solution as a bounded
            # least squares in the step, 15 times faster than scipy's BVLS on these sizes)
            t, _ = optimize.nnls(jac, r + jac @ u, maxiter=50 * len(cols))
            step = t - u
        length = 1.0
        while True:
            trial = np.maximum(u + length * step, 0.0)
            r_trial = residual(trial)
            cost_trial = float(r_trial @ r_trial)
            if cost_trial <= cost or length < 1e-6:
                break
            length /= 2.0
        done = cost - cost_trial <= tolerance * max(cost, 1e-300) + 1e-300
        if cost_trial <= cost:
            u, r, cost = trial, r_trial, cost_trial
        if done:
            break
    # a term the bound holds at (numerically) zero is zero, not a tiny positive value
    u[u < 1e-9 * float(u.max(initial=0.0))] = 0.0
    return full_beta(terms, u / scale), steps
