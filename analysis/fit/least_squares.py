"""Least-squares fits of the five IEEE noise terms to an Allan variance curve.

The model is Lv et al. 2015, eq. 3 (:mod:`analysis.fit.model`)::

    avar(tau) = 3 Q^2 / tau^2 + N^2 / tau + (0.664 B)^2 + K^2 tau / 3 + R^2 tau^2 / 2

linear in ``beta = [3 Q^2, N^2, (0.664 B)^2, K^2/3, R^2/2]`` (eq. 5-6; the paper's
printed ``K^2/2`` is a typo for ``R^2/2``).

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
    least squares on ``log avar`` under ``beta >= 0`` (:mod:`analysis.fit.log`), over the
    subset of terms the data resolve (:mod:`analysis.fit.selection`).

Coefficients are returned in data-sheet units (urad, deg/sqrt(h), deg/h, deg/h^1.5,
deg/h^2). Every standard error is the sandwich ``P C P^T`` of the fit's linear response
``P`` with the covariance ``C`` of the Allan values under the fitted model
(:mod:`analysis.fit.uncertainty`), propagated to the coefficient by the delta method:
the formula errors ``s^2 (X^T X)^-1`` of eq. 7 and 14 assume independent values and are
10-1000x too small on a grid of correlated ones, so they are never reported.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from analysis.allan.estimators import AllanResult
from analysis.errors import FitError
from analysis.fit.log import LogData, fit_log, log_data, log_tau_share
from analysis.fit.methods import FIT_METHODS as FIT_METHODS, FitMethod as FitMethod
from analysis.fit.model import (
    BETA_FACTOR,
    COEFFICIENT_NAMES,
    TAU_POWER,
    TERMS,
    TO_DATASHEET,
    design_matrix,
    full_beta,
    theoretical_avar,
)
from analysis.fit.result import Alternative, NoiseCoefficients
from analysis.fit.selection import select_terms
from analysis.fit.uncertainty import LinearizedFit, value_covariance

__all__ = [
    "BETA_FACTOR",
    "COEFFICIENT_NAMES",
    "DEFAULT_MODEL_ERROR",
    "FIT_METHODS",
    "FitMethod",
    "Alternative",
    "NoiseCoefficients",
    "TAU_POWER",
    "TERMS",
    "TO_DATASHEET",
    "check_terms",
    "design_matrix",
    "fit_every_method",
    "fit_noise_terms",
    "fit_term_set",
    "log_tau_share",
    "theoretical_avar",
]

OLS40_MAX_ERROR = 0.40
#: Relative error floor of the five-term model assumed by ``logwls``'s weights (2 % of avar).
DEFAULT_MODEL_ERROR = 0.02
#: A model misfit above this relative size (beyond sampling) is named in the notes.
NOTED_MISFIT = 0.01


def check_terms(terms: str) -> str:
    """The terms of ``terms`` (letters of ``QNBKR``, any case) in model order.

    Raises
    ------
    FitError
        A letter that is not a term (named, with the valid ones), or no term at all.
    """
    extra = sorted(set(terms.upper()) - set(TERMS))
    kept = "".join(t for t in TERMS if t in terms.upper())
    if not kept or extra:
        what = (
            f"{', '.join(repr(c) for c in extra)} {'is' if len(extra) == 1 else 'are'} not"
            if extra
            else "no letter is"
        )
        raise FitError(
            f"terms {terms!r}: {what} one of Q (quantization), N (angle random walk), "
            f"B (bias instability), K (rate random walk), R (rate ramp); give a "
            f"subset such as QNBKR or NBK"
        )
    return kept


def _checked(
    result: AllanResult, terms: str, model_error: float
) -> tuple[str, NDArray[np.float64]]:
    terms = check_terms(terms)
    avar = np.asarray(result.avar, dtype=float)
    if avar.ndim != 1:
        raise FitError("fit one axis at a time: pass result.axis(i)")
    if not model_error >= 0:
        raise FitError(f"model_error must be >= 0, got {model_error}")
    return terms, avar


def _usable_rows(
    method: str,
    result: AllanResult,
    avar: NDArray[np.float64],
    n_terms: int,
    exclude_tau_s: tuple[tuple[float, float], ...] = (),
) -> NDArray[np.bool_]:
    """The Allan values ``method`` uses; raises FitError when fewer than ``n_terms``."""
    keep = np.isfinite(avar)
    for lo, hi in exclude_tau_s:
        keep &= ~((result.tau_s >= lo) & (result.tau_s <= hi))
    if method == "ols40":
        keep &= result.relative_error < OLS40_MAX_ERROR
    if method == "logwls":
        keep &= avar > 0
    if keep.sum() < n_terms:
        raise FitError(
            f"{int(keep.sum())} Allan values usable by {method}, fewer than the {n_terms} terms "
            f"to fit; record longer or fit fewer terms"
        )
    return keep


def fit_noise_terms(
    result: AllanResult,
    *,
    method: FitMethod = "wls",
    terms: str = TERMS,
    model_error: float = DEFAULT_MODEL_ERROR,
    exclude_tau_s: tuple[tuple[float, float], ...] = (),
    select: bool | None = None,
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
        Which of ``"QNBKR"`` may be fitted; the others are held at zero.
    model_error : float
        ``logwls`` only: relative error floor of the five-term model (fraction of the
        Allan variance, default 2 %) in the weights. Without it the very precise
        short-tau values of a long real record decide every term.
    exclude_tau_s : tuple of (float, float)
        Closed tau ranges (s) left out of the fit: where the curve holds something the
        five terms do not describe (a tone, an output filter; see :mod:`analysis.figures.zones`).
    select : bool, optional
        Keep only the terms the data resolve (:mod:`analysis.fit.selection`); the others
        come back as 0 with a 1-sigma bound. Default: on for ``logwls``, off for the
        paper's methods, which fit every term asked for.

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
    terms, avar = _checked(result, terms, model_error)
    keep = _usable_rows(method, result, avar, len(terms), exclude_tau_s)
    if select is None:
        select = method == "logwls"
    if method == "logwls":
        return _fit_logwls(result, keep, terms, model_error, select)[0]
    log_keep = _usable_rows("logwls", result, avar, len(terms), exclude_tau_s)
    reference = _fit_logwls(result, log_keep, terms, model_error, True)[1]
    return _fit_linear(method, result, keep, terms, reference)


def fit_every_method(
    result: AllanResult, *, terms: str = TERMS, model_error: float = DEFAULT_MODEL_ERROR
) -> dict[str, NoiseCoefficients]:
    """:func:`fit_noise_terms` with each method at its default, the logwls model shared.

    The standard errors of the paper's methods take the covariance of the Allan values
    from the logwls model of the curve; fitting every method at once computes it once.

    Returns
    -------
    dict
        ``{method: NoiseCoefficients}`` for every method of :data:`FIT_METHODS`.

    Raises
    ------
    FitError
        As :func:`fit_noise_terms`.
    """
    terms, avar = _checked(result, terms, model_error)
    fit, reference = _fit_logwls(
        result, _usable_rows("logwls", result, avar, len(terms)), terms, model_error, True
    )
    out = {"logwls": fit}
    for method in FIT_METHODS:
        if method != "logwls":
            keep = _usable_rows(method, result, avar, len(terms))
            out[method] = _fit_linear(method, result, keep, terms, reference)
    return out


#: The logwls model of a curve, the rows it used and its misfit at each: what the paper's
#: methods take the covariance of the Allan values from.
Reference = tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]


def fit_term_set(
    result: AllanResult,
    candidates: str,
    chosen: str,
    *,
    model_error: float = DEFAULT_MODEL_ERROR,
    exclude_tau_s: tuple[tuple[float, float], ...] = (),
) -> NoiseCoefficients:
    """The ``logwls`` fit of the terms ``chosen`` among ``candidates``, as if the term
    selection had kept them: the others come back as 0 with their 1-sigma bound.

    Raises
    ------
    FitError
        As :func:`fit_noise_terms`, or ``chosen`` not a subset of ``candidates``.
    """
    candidates, avar = _checked(result, candidates, model_error)
    chosen = check_terms(chosen)
    if set(chosen) - set(candidates):
        raise FitError(f"terms {chosen!r} are not all among the candidates {candidates!r}")
    keep = _usable_rows("logwls", result, avar, len(chosen), exclude_tau_s)
    return _fit_logwls(result, keep, candidates, model_error, False, chosen=chosen)[0]


def _fit_logwls(
    result: AllanResult, keep: NDArray[np.bool_], candidates: str, model_error: float, select: bool,
    *, chosen: str | None = None,
) -> tuple[NoiseCoefficients, Reference]:
    data = log_data(result, keep, model_error)
    notes: list[str] = []
    criteria: dict[str, float] = {}
    if chosen is None:
        chosen = candidates
    if select and len(candidates) > 1:
        selection = select_terms(result, data, candidates)
        chosen, criteria = selection.terms, selection.criteria
        dropped = "".join(t for t in candidates if t not in chosen)
        if dropped:
            notes.append(
                f"terms {chosen} kept of {candidates}: {', '.join(dropped)} not resolved by the "
                "data "
                f"(information criterion on the log Allan values with their covariance, "
                f"{selection.n_points} values, penalty {selection.penalty:.2f} per term); "
                f"each reported as 0 with its 1-sigma upper bound as standard error"
            )
    beta, nfev = fit_log(data, chosen)
    lin, misfit = _log_linearization(result, data, beta)
    notes.append(
        "standard errors: sandwich of the fit's response with the covariance of the Allan "
        "values under the fitted model"
    )
    fit = _finish(
        "logwls", result, keep, candidates, beta, lin, beta, misfit, notes, iterations=nfev
    )
    return replace(fit, criteria=criteria), (beta, keep, misfit)


def _log_linearization(
    result: AllanResult, data: LogData, beta: NDArray[np.float64]
) -> tuple[LinearizedFit, NDArray[np.float64]]:
    """The log fit's linear response at ``beta`` and the model misfit its residuals show."""
    lin = LinearizedFit(data.jacobian(beta), data.weights, log=True)
    free = _free_columns(beta)
    if not len(free):
        return lin, np.zeros(len(data.tau_s))
    cov = value_covariance(result, beta, keep=data.keep)
    return lin, lin.local_misfit(free, data.residual(beta), cov, log_tau_share(data.tau_s))


def _linear_solution(
    method: str, x: NDArray[np.float64], y: NDArray[np.float64], weights: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Least squares of ``sqrt(w) x b = sqrt(w) y`` with columns scaled to unit norm."""
    from scipy import optimize
    sw = np.sqrt(weights)[:, None]
    xs = x * sw
    scale = np.linalg.norm(xs, axis=0)
    scale[scale == 0] = 1.0
    xs = xs / scale
    ys = y * sw[:, 0]
    y_scale = np.linalg.norm(ys) or 1.0
    ys = ys / y_scale
    if method == "nnls":
        bs, _ = optimize.nnls(xs, ys, maxiter=50 * xs.shape[1])
    else:
        bs = np.linalg.lstsq(xs, ys, rcond=None)[0]
    out: NDArray[np.float64] = bs * y_scale / scale
    return out


def _fit_linear(
    method: str, result: AllanResult, keep: NDArray[np.bool_], terms: str, reference: Reference
) -> NoiseCoefficients:
    avar = np.asarray(result.avar, dtype=float)[keep]
    x = design_matrix(result.tau_s[keep], TERMS)
    cols = [TERMS.index(t) for t in terms]
    j = result.n_clusters[keep].astype(float)
    # eq. 11-14 multiply each row by J: least squares with weights J^2
    weights = j**2 if method in ("wls", "nnls") else np.ones(len(avar))
    beta = full_beta(terms, _linear_solution(method, x[:, cols], avar, weights))
    model, log_keep, misfit = reference
    if not np.any(np.nan_to_num(model) > 0):
        return _finish(
            method,
            result,
            keep,
            terms,
            beta,
            None,
            model,
            None,
            [
                "standard errors: none; no model with positive terms fits this curve to take the "
                "covariance of the Allan values from"
            ],
        )
    notes = [
        f"standard errors: sandwich of {method}'s linear response with the covariance of the "
        f"Allan values under the logwls model of this curve (the formula error of eq. 7/14 "
        f"assumes independent values and is far too small on correlated ones)"
    ]
    return _finish(
        method,
        result,
        keep,
        terms,
        beta,
        LinearizedFit(x, weights, log=False),
        model,
        _on_rows(misfit, log_keep, keep),
        notes,
    )


def _on_rows(
    values: NDArray[np.float64], rows_have: NDArray[np.bool_], rows_want: NDArray[np.bool_]
) -> NDArray[np.float64]:
    full = np.zeros(len(rows_have))
    full[rows_have] = values
    return full[rows_want]


def _free_columns(beta: NDArray[np.float64]) -> NDArray[np.int64]:
    return np.flatnonzero(np.isfinite(beta) & (beta != 0)).astype(np.int64)


def _finish(
    method: str,
    result: AllanResult,
    keep: NDArray[np.bool_],
    candidates: str,
    beta: NDArray[np.float64],
    lin: LinearizedFit | None,
    model_beta: NDArray[np.float64],
    misfit: NDArray[np.float64] | None,
    notes: list[str],
    *,
    iterations: int = 1,
) -> NoiseCoefficients:
    """Coefficients, their sandwich standard errors and the notes, in data-sheet units.

    ``model_beta`` is the model the covariance of the values is taken under, ``misfit``
    its relative misfit at each value used.
    """
    variances: dict[str, float | None] = dict.fromkeys(TERMS)
    if lin is not None:
        cov = value_covariance(result, model_beta, keep=keep)
        free = _free_columns(beta)
        # a misfit worth naming: above 1 % and twice the sampling error of the value
        noted = None if misfit is None else np.where(
            misfit > np.maximum(NOTED_MISFIT, 2.0 * np.sqrt(cov.diagonal(log=True))), misfit, 0.0)
        if misfit is not None and noted is not None and noted.max(initial=0.0) > 0:
            worst = int(np.argmax(noted))
            size = (
                f"{misfit[worst]:.1%}"
                if misfit[worst] < 0.3
                else f"a factor {math.exp(misfit[worst]):.2g} in Allan variance"
            )
            notes.append(
                f"the curve departs from the five-term model beyond sampling, by up to {size} "
                f"(near tau {result.tau_s[keep][worst]:.3g} s); that misfit is carried in the "
                f"standard errors"
            )
        if len(free):
            c = lin.covariance(free, cov, misfit)
            for k, col in enumerate(free):
                variances[TERMS[col]] = float(c[k, k])
        for t in candidates:
            col = TERMS.index(t)
            if col not in free:
                # a term at zero: its variance as if it were free beside the others
                aug = np.sort(np.append(free, col))
                c = lin.covariance(aug, cov, misfit)
                k = int(np.searchsorted(aug, col))
                variances[t] = float(c[k, k])
    values: dict[str, float | None] = dict.fromkeys(TERMS)
    stderr: dict[str, float | None] = dict.fromkeys(TERMS)
    negative = ""
    for term in candidates:
        col = TERMS.index(term)
        b = float(beta[col]) if np.isfinite(beta[col]) else 0.0
        var = variances[term]
        sb = math.sqrt(max(var, 0.0)) if var is not None else None
        factor, unit = BETA_FACTOR[term], TO_DATASHEET[term]
        if b > 0:
            values[term] = math.sqrt(b / factor) * unit
            stderr[term] = None if sb is None else sb / (2.0 * math.sqrt(factor * b)) * unit
        elif b == 0:
            values[term] = 0.0
            stderr[term] = None if sb is None else math.sqrt(sb / factor) * unit
        else:
            negative += term
    full = np.where(np.isfinite(beta), beta, np.nan)
    kept = "".join(t for t in candidates if np.isfinite(beta[TERMS.index(t)]))
    return NoiseCoefficients(
        method,
        kept,
        values,
        stderr,
        full,
        negative,
        int(keep.sum()),
        iterations,
        candidates,
        tuple(notes),
    )
