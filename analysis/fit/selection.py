"""Which of the five noise terms the data resolve: model selection for the ``logwls`` fit.

A five-term fit to a curve that holds three terms does not return three terms and two
zeros: over the few octaves where a rate random walk shows, a flat bias instability plus a
ramp (or a walk plus a ramp) follows the rising curve about as well, and the fit shares
the rise among them or gives it to the wrong one. Every subset of the candidate terms is
therefore fitted and compared by an information criterion

    IC(S) = min_beta (z - log m_S(beta))^T C^-1 (z - log m_S(beta)) + penalty |S|

on the log Allan values ``z``, whose covariance ``C`` is the one the values really have
(:mod:`analysis.fit.uncertainty`: sampling covariance under the full candidate model,
plus the model misfit the residuals show). Taking the covariance in full is what makes
the effective number of observations right: a grid of 100 strongly correlated values
holds about as much as a handful of independent ones, and a criterion that counted each
value would keep every term. The values are first thinned to :data:`PER_OCTAVE` per
octave of tau (their covariance is then well conditioned; neighbours on a denser grid
add nothing). The penalty is Schwarz's ``log n`` with ``n`` the number of thinned values,
about the count of independent Allan values the record holds.

Values of fewer than :data:`MIN_CRITERION_EDF` degrees of freedom (the last octave of an
overlapping curve continued to half the record, where a value is one or two squared
differences) are left out of the criterion, not of the fit. The log of a one-degree
chi-square value has a heavy left tail (a value a thousandth of its mean has a chance of
2.5 %), and where its neighbour on the thinned grid correlates with it to 0.98 (as under a
walk) the Gaussian criterion judges it given that neighbour: one value near zero then
counts as a miss of 17 sigma against the model that holds (a 6 h record of N 0.1
deg/sqrt(h) + K 1 deg/h^1.5 whose value at half the record was e^-8 of the walk's
was read as white noise alone, K 0 +- 0.09).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.allan.estimators import AllanResult
from analysis.fit.log import LogData, fit_log, log_tau_share
from analysis.fit.model import TERMS
from analysis.fit.uncertainty import LinearizedFit, value_covariance

#: Thinned values per octave of tau that the criterion sees.
PER_OCTAVE = 3
#: Values of a dense grid the subset fits use (see :func:`_reduced`).
MAX_POINTS = 400
#: Fewest degrees of freedom of a value the criterion sees (module docstring).
MIN_CRITERION_EDF = 2.0


@dataclass(frozen=True)
class Selection:
    """The outcome of a term selection.

    Attributes
    ----------
    terms : str
        The chosen subset of the candidates.
    criteria : dict
        ``IC`` of every subset tried, by subset.
    penalty : float
        Penalty per term.
    n_points : int
        Thinned values the criterion used.
    misfit : ndarray
        Relative misfit of the full candidate model at each value.
    """

    terms: str
    criteria: dict[str, float]
    penalty: float
    n_points: int
    misfit: NDArray[np.float64]


def thin_by_octave(tau_s: NDArray[np.float64], per_octave: int = PER_OCTAVE) -> NDArray[np.int64]:
    """Indices of a subset of ``tau_s`` (sorted): the first tau at or past each step of
    ``1/per_octave`` octave from the first."""
    octaves = np.log2(np.asarray(tau_s, dtype=float))
    steps = np.arange(0.0, octaves[-1] - octaves[0] + 1e-9, 1.0 / per_octave)
    picks = np.searchsorted(octaves, octaves[0] + steps - 1e-9)
    return np.unique(picks[picks < len(octaves)]).astype(np.int64)


def _reduced(data: LogData) -> LogData:
    """At most about :data:`MAX_POINTS` values of a dense grid, spread evenly in log tau.

    The subset fits only have to find each model; neighbours on an every-m grid add
    nothing to that. Each kept value's weight takes its new share of an octave.
    """
    if len(data.tau_s) <= MAX_POINTS:
        return data
    octaves = float(np.log2(data.tau_s[-1] / data.tau_s[0]))
    rows = thin_by_octave(data.tau_s, max(1, int(MAX_POINTS / max(octaves, 1.0))))
    keep = np.zeros_like(data.keep)
    keep[np.flatnonzero(data.keep)[rows]] = True
    weights = data.weights[rows] / log_tau_share(data.tau_s)[rows] * log_tau_share(data.tau_s[rows])
    return LogData(
        keep, data.tau_s[rows], data.avar[rows], data.target[rows], weights, data.design[rows]
    )


def select_terms(result: AllanResult, data: LogData, candidates: str, *,
                 penalty: float | None = None) -> Selection:
    """Choose the subset of ``candidates`` with the least information criterion (module docstring).

    Parameters
    ----------
    result : AllanResult
        The one-axis result ``data`` was made from (estimator, grid, record length).
    data : LogData
        The log fit's rows (:func:`analysis.fit.log.log_data`).
    candidates : str
        Terms to choose among (a subset of ``"QNBKR"``, in that order).
    penalty : float, optional
        Penalty per term; default ``log n`` of the thinned values.

    Returns
    -------
    Selection
    """
    data = _reduced(data)
    full, _ = fit_log(data, candidates)
    cov = value_covariance(result, full, keep=data.keep, random_ramp=True)
    free = np.flatnonzero(np.nan_to_num(full) > 0)
    lin = LinearizedFit(data.jacobian(full), data.weights, log=True)
    misfit = (
        lin.local_misfit(free, data.residual(full), cov, log_tau_share(data.tau_s))
        if len(free)
        else np.zeros(len(data.tau_s))
    )
    rows = thin_by_octave(data.tau_s)
    rows = rows[np.asarray(result.edf, dtype=float)[data.keep][rows] >= MIN_CRITERION_EDF]
    picks = np.zeros((len(rows), len(data.tau_s)))
    picks[np.arange(len(rows)), rows] = 1.0
    if penalty is None:
        penalty = math.log(max(len(rows), 2))
    criteria: dict[str, float] = {}
    fits: dict[str, NDArray[np.float64]] = {}
    for size in range(1, len(candidates) + 1):
        for subset in itertools.combinations(candidates, size):
            terms = "".join(subset)
            beta = (
                full if terms == candidates else fit_log(data, terms, start=full, tolerance=1e-9)[0]
            )
            fits[terms] = beta
            criteria[terms] = _deviance(result, data, beta, picks, rows, misfit) + penalty * size
    best = min(criteria, key=lambda t: (criteria[t], len(t)))
    return Selection(best, criteria, float(penalty), len(rows), misfit)


def _cholesky_jittered(c: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lower Cholesky factor of a covariance that rounding (or its approximations) may
    leave short of positive definite: values at neighbouring taus of a long record
    correlate to 1 within rounding (a 24 h record at 1 kHz does). The diagonal is raised
    by 1e-9 of itself, then by ten times more each time the factorization fails (up to
    1e-6); past that, the eigenvalues are floored at 1e-9 of the largest (the nearest
    positive definite matrix of the same eigenvectors)."""
    from scipy import linalg
    diag = np.diag_indices_from(c)
    base = c[diag].copy()
    for jitter in (1e-9, 1e-8, 1e-7, 1e-6):
        c[diag] = base * (1.0 + jitter)
        try:
            return np.asarray(linalg.cholesky(c, lower=True), dtype=np.float64)
        except linalg.LinAlgError:
            continue
    c[diag] = base
    values, vectors = np.linalg.eigh((c + c.T) / 2.0)
    floored = np.maximum(values, 1e-9 * float(values.max()))
    repaired = (vectors * floored) @ vectors.T
    return np.asarray(linalg.cholesky((repaired + repaired.T) / 2.0, lower=True), dtype=np.float64)


def _deviance(
    result: AllanResult,
    data: LogData,
    beta: NDArray[np.float64],
    picks: NDArray[np.float64],
    rows: NDArray[np.int64],
    misfit: NDArray[np.float64],
) -> float:
    """``-2 log L`` (up to a constant) of the thinned log values under the model ``beta``.

    Gaussian in the log values, with the covariance the model itself implies: a model
    that claims precise values (a deterministic ramp) must also meet them.
    """
    from scipy.linalg import lapack
    c = value_covariance(result, beta, keep=data.keep, random_ramp=True).sandwich(
        picks, log=True, misfit=misfit
    )
    chol = _cholesky_jittered(c)
    # the likelihood at its best: generalized least squares under that covariance
    # L^-1 by LAPACK's triangular inverse (solve_triangular with an identity is 100x slower)
    whiten = np.tril(lapack.dtrtri(chol, lower=1)[0])
    thin = LogData(
        data.keep,
        data.tau_s[rows],
        data.avar[rows],
        data.target[rows],
        data.weights[rows],
        data.design[rows],
    )
    terms = "".join(t for t, b in zip(TERMS, beta, strict=True) if np.isfinite(b))
    beta, _ = fit_log(thin, terms, start=beta, tolerance=1e-9, whiten=whiten)
    z = whiten @ thin.residual(beta)
    return float(z @ z) + 2.0 * float(np.sum(np.log(np.diag(chol))))
