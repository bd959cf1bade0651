"""Standard errors of fitted noise terms that account for the correlation of Allan values.

Every fit here is, to first order, a linear map of the Allan values (or of their logs):
``delta beta = P delta a``. Its covariance is the sandwich ``P C P^T``, with ``C`` the
covariance of the Allan values under the noise model the data show
(:mod:`analysis.allan.covariance`). The textbook ``s^2 (X^T X)^-1`` instead assumes
independent values, which values on one record never are: on the every-m grid it is
10-1000x too small (1-sigma coverage 0 %).

Three refinements make the sandwich hold on real grids and records:

* **Dense grids.** Beyond :data:`MAX_EXACT_TAUS` values the covariance is computed at
  about :data:`ANCHORS` anchor taus spread evenly in log tau (every small m kept) and
  interpolated linearly in log m; neighbouring values on such a grid are nearly
  identical, so a projection onto the anchors loses nothing a fit can see.
* **Low edf in the log domain.** ``var(log a) = psi'(nu/2)`` for a chi-square estimate
  with ``nu`` dof, not the first-order ``2/nu``: at 2 dof it is 1.64 times larger. The
  log-domain covariance is scaled by ``sqrt(f_i f_j)``, ``f = psi'(nu/2) nu / 2``.
* **Model misfit.** A real gyro does not follow eq. 3 to the 0.1 % that a long record
  resolves. The excess of the weighted residuals over what sampling explains is
  estimated (a moment estimate: the residual sum of squares against its expectation) and
  carried as an extra relative error of the model, correlated over about
  :data:`MISFIT_OCTAVES` octave of tau, so a misfit widens the errors instead of being
  read as information.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.allan.covariance import CovarianceBasis, covariance_basis
from analysis.allan.estimators import AllanResult

#: Grids up to this many taus get the covariance of every value; longer ones use anchors.
MAX_EXACT_TAUS = 160
#: Anchor taus of a long grid (about; every m up to SMALL_M is an anchor too).
ANCHORS = 64
SMALL_M = 16
#: Cluster counts J up to which both ends of each J's run of m are anchors.
J_STEPS = 16
#: Least relative variance of a value (what a purely deterministic model would claim).
RELATIVE_VARIANCE_FLOOR = 1e-12
#: The misfit's size at a tau is the residual excess averaged over about this many
#: octaves either side (an exponential window).
MISFIT_WINDOW_OCTAVES = 1.0
#: A misfit is counted where the residuals' local mean square exceeds this many times what
#: sampling explains (the excess over sampling is then its variance).
MISFIT_GATE = 2.0
#: ... and where the log of the value scatters by less than this variance (edf above about 20).
MISFIT_PRECISION = 0.1
#: Correlation length (octaves of tau) of the model's misfit.
MISFIT_OCTAVES = 1.0


@functools.lru_cache(maxsize=4)
def _basis(
    m: tuple[int, ...], n_samples: int, sample_rate_hz: float, overlapping: bool
) -> CovarianceBasis:
    # one grid serves every axis of a record and every run of a Monte Carlo
    return covariance_basis(np.array(m), n_samples, sample_rate_hz, overlapping=overlapping)


def _anchors(m: NDArray[np.int64], clusters: NDArray[np.int64] | None = None
             ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """(anchor m, left anchor index of each grid value, its fraction of the way to the next).

    ``clusters`` (the cluster estimator's J per value) adds the first and last m of every
    J up to :data:`J_STEPS`: the variance of a cluster value jumps where J does, and no
    interpolation may cross such a step.
    """
    if len(m) <= MAX_EXACT_TAUS:
        return m, np.arange(len(m)), np.zeros(len(m))
    logm = np.log(m)
    targets = np.geomspace(m[0], m[-1], ANCHORS)
    steps: list[NDArray[np.int64]] = []
    if clusters is not None:
        change = np.flatnonzero(np.diff(clusters) != 0)
        edges = np.concatenate([change, change + 1])
        steps.append(edges[clusters[edges] <= J_STEPS])
    picks = np.unique(np.concatenate([np.searchsorted(logm, np.log(targets)).clip(0, len(m) - 1),
                                      np.flatnonzero(m <= SMALL_M), [0, len(m) - 1], *steps]))
    anchors = m[picks]
    loga = np.log(anchors)
    left = np.clip(np.searchsorted(loga, logm, side="right") - 1, 0, len(anchors) - 2)
    frac = np.clip((logm - loga[left]) / (loga[left + 1] - loga[left]), 0.0, 1.0)
    return anchors, left, frac


@dataclass(frozen=True)
class ValueCovariance:
    """Relative covariance ``Cov(a_i, a_j) / (E a_i E a_j)`` of one result's Allan values.

    Held at anchor taus (all taus of a short grid) with each value's interpolation onto
    them; use :meth:`sandwich` for ``L C L^T`` without forming the full matrix.

    Attributes
    ----------
    anchor_m : ndarray of int, shape (k,)
        Anchor averaging factors.
    relative : ndarray, shape (k, k)
        Relative sampling covariance at the anchors under the model.
    misfit_kernel : ndarray, shape (k, k)
        Correlation of the model's misfit between anchors.
    left, frac : ndarray, shape (n,)
        Each value's left anchor and its fraction of the log-m way to the next one.
    relative_variance : ndarray, shape (n,)
        Each value's relative sampling variance (``2 / edf`` of the model).
    mean : ndarray, shape (n,)
        Each value's expectation under the model, (deg/s)^2.
    log_scale : ndarray, shape (n,)
        ``sqrt(f)``, ``f = psi'(nu/2) nu / 2`` with ``nu = 2 / relative_variance``.
    """

    anchor_m: NDArray[np.int64]
    relative: NDArray[np.float64]
    misfit_kernel: NDArray[np.float64]
    left: NDArray[np.int64]
    frac: NDArray[np.float64]
    relative_variance: NDArray[np.float64]
    mean: NDArray[np.float64]
    log_scale: NDArray[np.float64]

    def project(self, rows: NDArray[np.float64]) -> NDArray[np.float64]:
        """``rows`` (p, n) onto the anchors: (p, k), each value split between its two anchors."""
        k = len(self.anchor_m)
        if k == len(self.left):
            return rows  # every value is an anchor
        out = np.zeros((rows.shape[0], k))
        if k == 1:
            out[:, 0] = rows.sum(axis=1)
            return out
        for a, share in (
            (self.left, 1.0 - self.frac),
            (np.minimum(self.left + 1, k - 1), self.frac),
        ):
            for r in range(rows.shape[0]):
                out[r] += np.bincount(a, weights=rows[r] * share, minlength=k)
        return out

    def log_factor(self) -> NDArray[np.float64]:
        """``sqrt(f_i)``: how much wider the log of each value scatters than first order says."""
        return self.log_scale

    def expand(self, on_anchors: NDArray[np.float64]) -> NDArray[np.float64]:
        """Values at the anchors (..., k) interpolated to every value (..., n): the transpose of
        :meth:`project`."""
        k = len(self.anchor_m)
        if k == len(self.left):
            return on_anchors
        right = np.minimum(self.left + 1, k - 1)
        return on_anchors[..., self.left] * (1.0 - self.frac) + on_anchors[..., right] * self.frac

    def sandwich(
        self, rows: NDArray[np.float64], *, log: bool, misfit: NDArray[np.float64] | None = None
    ) -> NDArray[np.float64]:
        """``L C L^T`` for ``L = rows`` (p, n) acting on relative deviations of the values.

        ``log`` scales the sampling part for the log of each value (low-edf correction);
        ``misfit`` (n,) is the model's relative misfit of each value, added with its kernel.
        """
        return self.cross(rows, rows, log=log, misfit=misfit)

    def cross(self, rows_a: NDArray[np.float64], rows_b: NDArray[np.float64], *, log: bool,
              misfit: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """``A C B^T`` for two sets of rows (see :meth:`sandwich`)."""
        f = self.log_factor() if log else 1.0
        out = self.project(rows_a * f) @ self.relative @ self.project(rows_b * f).T
        if misfit is not None and np.any(misfit > 0):
            out = (
                out
                + self.project(rows_a * misfit)
                @ self.misfit_kernel
                @ self.project(rows_b * misfit).T
            )
        return out

    def diagonal(self, *, log: bool) -> NDArray[np.float64]:
        """Relative sampling variance of each value (of its log with ``log``)."""
        return self.relative_variance * (self.log_factor() ** 2 if log else 1.0)


def value_covariance(
    result: AllanResult,
    beta: NDArray[np.float64],
    keep: NDArray[np.bool_] | None = None,
    *,
    random_ramp: bool = False,
) -> ValueCovariance:
    """Covariance of the Allan values of ``result`` (rows ``keep``) under the model ``beta``.

    Parameters
    ----------
    result : AllanResult
        One axis; overlapping or cluster estimator, any tau grid.
    beta : ndarray, shape (5,)
        The model (eq. 6, base units, QNBKR; NaN or <= 0 for absent terms).
    keep : ndarray of bool, optional
        Rows of ``result`` to describe (default all).
    random_ramp : bool
        Take the ramp term as a random rise (see
        :meth:`analysis.allan.covariance.CovarianceBasis.covariance`).
    """
    from scipy import special
    m = np.asarray(result.m, dtype=np.int64)
    if keep is not None:
        m = m[keep]
    anchors, left, frac = _anchors(m, None if result.estimator == "overlapping"
                                   else int(result.n_samples) // m)
    basis = _basis(
        tuple(int(v) for v in anchors),
        int(result.n_samples),
        float(result.sample_rate_hz),
        result.estimator == "overlapping",
    )
    relative = basis.relative_covariance(beta, random_ramp=random_ramp)
    # a model of deterministic terms only claims exact values; keep it a (tiny) variance
    relative[np.diag_indices_from(relative)] += RELATIVE_VARIANCE_FLOOR
    diag = np.diag(relative)
    k = len(anchors)
    right = np.minimum(left + 1, k - 1)
    # relative variance interpolated in log: it scales smoothly (as 1/edf) with m
    rel_var = np.exp((1.0 - frac) * np.log(diag[left]) + frac * np.log(diag[right]))
    octaves = np.log2(anchors.astype(float))
    kernel = np.exp(-np.abs(octaves[:, None] - octaves[None, :]) / MISFIT_OCTAVES)
    tau = m / float(result.sample_rate_hz)
    b = np.where(np.isfinite(beta) & (beta > 0), beta, 0.0)
    mean = b[0] / tau**2 + b[1] / tau + b[2] + b[3] * tau + b[4] * tau**2
    # psi' at the anchors (it is smooth in m), interpolated like the variance
    edf = 2.0 / np.maximum(diag, 1e-300)
    at_anchors = np.sqrt(special.polygamma(1, edf / 2.0) * edf / 2.0)
    log_scale = (1.0 - frac) * at_anchors[left] + frac * at_anchors[right]
    return ValueCovariance(anchors, relative, kernel, left, frac, rel_var, mean, log_scale)


@dataclass(frozen=True)
class LinearizedFit:
    """A fit's first-order response to its data: ``delta beta_F = P delta y`` on its free terms.

    Attributes
    ----------
    jacobian : ndarray, shape (n, 5)
        Derivative of each fitted datum in each beta (eq. 6, base units, QNBKR).
    weights : ndarray, shape (n,)
        The weights of the fit's sum of squares (rows of ``y`` and ``J`` times ``sqrt(w)``).
    log : bool
        True when the data are log Allan values (``logwls``), False for the values.
    """

    jacobian: NDArray[np.float64]
    weights: NDArray[np.float64]
    log: bool

    def response(self, columns: NDArray[np.int64]) -> NDArray[np.float64]:
        """``P = (J_F^T W J_F)^-1 J_F^T W`` for the columns ``F``: (len(F), n)."""
        jw = self._weighted(columns)
        return np.linalg.pinv(jw.T @ self.jacobian[:, columns]) @ jw.T

    def _weighted(self, columns: NDArray[np.int64]) -> NDArray[np.float64]:
        return self.jacobian[:, columns] * self.weights[:, None]

    def _rows(self, rows: NDArray[np.float64], cov: ValueCovariance) -> NDArray[np.float64]:
        # the covariance is relative: a value fit sees a_i = E_i (1 + relative deviation)
        return rows if self.log else rows * cov.mean[None, :]

    def covariance(self, columns: NDArray[np.int64], cov: ValueCovariance,
                   misfit: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Covariance of the fitted betas of ``columns``: the sandwich ``P C P^T``."""
        return cov.sandwich(self._rows(self.response(columns), cov), log=self.log, misfit=misfit)

    def local_misfit(self, columns: NDArray[np.int64], residual: NDArray[np.float64],
                     cov: ValueCovariance, share: NDArray[np.float64]) -> NDArray[np.float64]:
        """Relative misfit of the model at each value, from the residuals of a log fit.

        The residuals ``r = (I - H) eps`` (``H = J P``) of a model that holds have
        ``E[r_i^2] = [(I - H) C (I - H)^T]_ii`` under the sampling covariance ``C``. The
        excess ``r_i^2 - E[r_i^2]``, both averaged over about :data:`MISFIT_WINDOW_OCTAVES`
        octave either side (weighted by each value's share of an octave), is the squared
        misfit there, counted where the mean square is over :data:`MISFIT_GATE` times its
        expectation (sampling noise alone seldom gets there) and the value is precise
        (log variance under :data:`MISFIT_PRECISION`). A misfit is local (an output filter at the
        shortest taus, a bump the five terms lack), so it widens the errors of the terms
        that live where it is, not of all.

        Returns
        -------
        ndarray, shape (n,)
            Relative misfit (fraction of the Allan variance) of each value.
        """
        if not self.log:
            raise ValueError("the misfit is estimated from a log fit")
        j = self.jacobian[:, columns]
        p = self.response(columns)
        f = cov.log_factor()
        on_anchors = cov.project(p * f) @ cov.relative  # (P C) at the anchors, log scaled
        pc = cov.expand(on_anchors) * f  # (P C): (p, n)
        pcp = cov.sandwich(p, log=True)
        expected = (cov.diagonal(log=True) - 2.0 * np.sum(j * pc.T, axis=1)
                    + np.einsum("ia,ab,ib->i", j, pcp, j))
        octaves = np.log2(cov.anchor_m.astype(float))
        kernel = np.exp(-np.abs(octaves[:, None] - octaves[None, :]) / MISFIT_WINDOW_OCTAVES)

        def local_mean(x: NDArray[np.float64]) -> NDArray[np.float64]:
            num = kernel @ cov.project((share * x)[None, :])[0]
            den = kernel @ cov.project(share[None, :])[0]
            return cov.expand(np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0))

        observed, sampling = local_mean(residual**2), local_mean(expected)
        # noise alone seldom doubles the mean square over an octave; a misfit that does is
        # counted, where the values are precise enough to show one (at long tau the scatter
        # of a few clusters hides it, and a wrong model's residuals there must not be
        # taken for a misfit that would then excuse them)
        counted = (observed > MISFIT_GATE * sampling) & (cov.diagonal(log=True) < MISFIT_PRECISION)
        return np.sqrt(np.where(counted, observed - sampling, 0.0))
