"""The generalized method of wavelet moments (GMWM): a noise model fitted to the Haar WV.

The estimator (Guerrier, Skaloud, Stebler and Victoria-Feser, JASA 108 (2013) 776, eq. 5)
minimizes the weighted distance between the empirical wavelet variance ``nu_hat``
(:mod:`analysis.gmwm.wavelet`) and the model's ``nu(theta)`` (:mod:`analysis.gmwm.models`):

    theta_hat = argmin (nu_hat - nu(theta))' Omega (nu_hat - nu(theta))                 (M1)

**Weights.** ``Omega = V^-1``, ``V`` the covariance of ``nu_hat``, makes the estimator
efficient among these (the efficient GMWM, eq. 7 there). ``V`` is estimated in two steps:
first the diagonal of the nonparametric variances of ``nu_hat`` (Percival-Walden, from
the data alone), then the full ``V`` of :mod:`analysis.gmwm.covariance` at the first
estimate, and once more at the second (``steps``). When that matrix cannot be factored
(or with ``weights="diagonal"``), its diagonal is used: the diagonal fallback.

**Misspecified models.** A record of a million samples resolves the finest scales' WV
to 0.1 %, better than any model of a real sensor holds (an anti-alias filter, quantization,
a bias-instability plateau). When the J test below rejects the model (``p < REJECT_P``),
the model-based ``V`` is not the covariance of ``nu_hat``: it grows with the fitted curve,
so a wrong model that overshoots the long scales weights down the scales that contradict
it (wn+ar1+rw on a bias-instability plateau: 30 times above the top scales). A rejected
model is refitted with the first step's nonparametric variances plus a relative floor
``(model_error nu_hat)^2`` (2 %, the ``logwls`` Allan fit's): ``"nonparametric+floor"``.
A model that holds keeps the efficient weights (on records simulated from the model they
recover it as well as the reference implementation's weights: ``bench_gmwm_sim``).

**Solution.** For fixed correlation times the model is linear in its variance parameters,
so M1 is a non-negative least-squares problem in them; a grid over the correlation times
(``GRID_PER_OCTAVE``, ordered ``T_1 < T_2 < ...``) with NNLS in the variances gives global
starting values, together with the five-term Allan fit's values (``logwls``,
:func:`analysis.fit.fit_noise_terms` on the octave Allan curve ``2 nu_hat``) for the
terms the two share; ``scipy.optimize.least_squares`` refines the best grid point of each
of ``REFINED_STARTS`` basins (an octave apart) and the Allan start under ``v >= 0`` and
``dt / 64 <= T <= N dt``: a correlation time far below one sample period is reachable (an
AR(1)'s ``phi = exp(-dt / T)`` from ``e^-64``, i.e. towards 0, up to the record's length;
the closed forms hold for every ``phi`` in (0, 1)), and the grid starts two octaves below
``dt``. The wavelet variance of :func:`analysis.gmwm.selection.gmwm_analysis` has every
level the record holds (``GMWM_MIN_BLOCKS``: ``floor(log2 N)`` scales, as the reference
implementation). Each re-weighting starts from the previous solution;
the last one also from the grid and the Allan fit again, since the first step's weights
can leave the solution in a local minimum the efficient weights do not prefer.

**Uncertainty.** ``cov(theta_hat) = (D' Omega D)^-1`` with ``D = d nu / d theta`` (eq. 8
there with ``Omega = V^-1``), over the parameters not held at a bound, multiplied by
``max(J / dof, 1)``: a model the test below rejects has standard errors widened by its
misfit instead of the ones of a model that held. Values and errors are in data-sheet
units (delta method); intervals are ``exp(log x +- z se/x)`` for positive values.

**Goodness of fit.** ``J = (nu_hat - nu(theta_hat))' V^-1 (nu_hat - nu(theta_hat))`` is
Hansen's over-identification statistic, chi-square with ``levels - free parameters``
degrees of freedom when the model holds.

Model selection among candidate models is :mod:`analysis.gmwm.selection`.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray

from analysis.allan.confidence import ONE_SIGMA, local_noise_alpha
from analysis.allan.estimators import AllanResult
from analysis.distributions import chi2_sf, normal_ppf
from analysis.errors import FitError, TooFewSamplesError
from analysis.fit.least_squares import BETA_FACTOR, DEFAULT_MODEL_ERROR, fit_noise_terms
from analysis.gmwm.covariance import wv_covariance
from analysis.gmwm.equivalent import WN_EQUIVALENT_KEY, white_equivalent
from analysis.gmwm.models import GmwmModel
from analysis.gmwm.result import GmwmFit as GmwmFit  # re-exported: fits are imported from here
from analysis.gmwm.wavelet import WaveletVariance, dyadic_m

#: Correlation-time grid points per octave for one, two, three or more shaped terms.
GRID_PER_OCTAVE = {1: 4, 2: 2, 3: 1}
#: Shortest correlation time, in sample periods (AR(1): ``phi >= e^-64``, i.e. phi -> 0).
SHORTEST_T_SAMPLES = 1.0 / 64.0
#: The starting grid begins this many octaves below one sample period (phi = e^-4 = 0.018).
GRID_OCTAVES_BELOW_SAMPLE = 2
#: Grid starts refined by least squares (the best of each basin: ``START_SEPARATION``).
REFINED_STARTS = 3
#: Grid starts at least this far apart in some log correlation time (one octave and a bit).
START_SEPARATION = 1.01 * math.log(2.0)
#: Condition number above which V falls back to its diagonal.
MAX_CONDITION = 1e13
#: A model whose J test gives a p-value below this gets the model-error floor in its weights.
REJECT_P = 1e-3
#: Scales of the GMWM: every level the record holds, ``2 m <= N`` (``floor(log2 N)`` levels, the
#: reference implementation's rule; :func:`analysis.gmwm.wavelet.dyadic_m` with this
# ``min_blocks``).
GMWM_MIN_BLOCKS = 2
#: Five-term Allan fit letter of each GMWM term.
ALLAN_TERM = {"qn": "Q", "wn": "N", "bi": "B", "rw": "K", "dr": "R"}


# ------------------------------------------------------------------------------ the solver


class _Problem:
    """One model against one empirical WV: scaling, bounds, residuals and Jacobian of M1."""

    def __init__(self, model: GmwmModel, wv: WaveletVariance) -> None:
        self.model, self.wv = model, wv
        self.tau = np.asarray(wv.tau_s, dtype=float)
        self.nu = np.asarray(wv.wv, dtype=float)
        if self.nu.ndim != 1:
            raise FitError("fit one axis at a time: pass wv.axis(i)")
        self.dt = 1.0 / wv.sample_rate_hz
        self.slices = model.slices()
        self.var_idx = [iv for iv, _ in self.slices]
        self.shape_idx = [ish for _, ish in self.slices if ish is not None]
        n = model.n_params
        # each variance scaled by the largest value whose term stays under the data everywhere
        self.scale = np.ones(n)
        self.lower, self.upper = np.zeros(n), np.full(n, np.inf)
        self.t_lo = math.log(SHORTEST_T_SAMPLES * self.dt)
        self.t_hi = math.log(wv.n_samples * self.dt)
        for kind, (iv, ish) in zip(model.kinds, self.slices, strict=True):
            unit = kind.unit_wv(self.tau, 0.5 * (self.t_lo + self.t_hi), self.dt)
            self.scale[iv] = float(np.min(self.nu / np.maximum(unit, 1e-300)))
            if ish is not None:
                self.lower[ish], self.upper[ish] = self.t_lo, self.t_hi
        self.scale[self.scale <= 0] = 1.0
        self.whiten = np.eye(len(self.tau))
        self._allan_beta: NDArray[np.float64] | None = None

    def theta(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        p = np.array(x, dtype=float)
        p[self.var_idx] = p[self.var_idx] * self.scale[self.var_idx]
        return p

    def x_of(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        x = np.array(theta, dtype=float)
        x[self.var_idx] = x[self.var_idx] / self.scale[self.var_idx]
        out: NDArray[np.float64] = np.clip(x, self.lower, self.upper)
        return out

    def set_weights(self, v: NDArray[np.float64], *, diagonal: bool = False) -> str:
        """Whitening by ``V = L L'`` (or by its diagonal, the fallback); returns which.

        Raises
        ------
        FitError
            ``V`` with a variance that is not positive (a model nil at some scale).
        """
        from scipy import linalg
        var = np.diag(v)
        if not np.all(var > 0) or not np.all(np.isfinite(var)):
            raise FitError("the weights' covariance has no positive variance at some scale "
                           "(a model nil there): fit a model with a term at every scale")
        d = np.sqrt(var)
        if not diagonal:
            corr = v / np.outer(d, d)
            try:
                if np.linalg.cond(corr) < MAX_CONDITION:
                    chol = linalg.cholesky(corr, lower=True)
                    self.whiten = (
                        linalg.solve_triangular(chol, np.eye(len(d)), lower=True) / d[None, :]
                    )
                    return "efficient"
            except (linalg.LinAlgError, ValueError):
                pass
        self.whiten = np.diag(1.0 / d)
        return "diagonal"

    def _apply(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """``L^-1 y`` with ``V = L L'``."""
        return self.whiten @ y

    def nu_jacobian(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """d nu / d x, (levels, params)."""
        p = self.theta(x)
        jac = np.zeros((len(self.tau), len(p)))
        for kind, (iv, ish) in zip(self.model.kinds, self.slices, strict=True):
            shape = float(p[ish]) if ish is not None else 0.0
            jac[:, iv] = kind.unit_wv(self.tau, shape, self.dt) * self.scale[iv]
            if ish is not None:
                h = 1e-5
                jac[:, ish] = p[iv] * (kind.unit_wv(self.tau, shape + h, self.dt)
                                       - kind.unit_wv(self.tau, shape - h, self.dt)) / (2 * h)
        return jac

    def residual(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return self._apply(self.nu - self.model.wv(self.theta(x), self.tau, self.dt))

    def jacobian(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return -self._apply(self.nu_jacobian(x))

    def objective(self, x: NDArray[np.float64]) -> float:
        r = self.residual(x)
        return float(r @ r)

    # ---------------------------------------------------------------------- starting values

    def _columns(self, shapes: NDArray[np.float64]) -> NDArray[np.float64]:
        """Whitened WV columns of each term (scaled variance 1) at shape values ``shapes``."""
        cols = np.zeros((len(self.tau), len(self.var_idx)))
        for c, (kind, (iv, ish)) in enumerate(zip(self.model.kinds, self.slices, strict=True)):
            shape = float(shapes[self.shape_idx.index(ish)]) if ish is not None else 0.0
            cols[:, c] = kind.unit_wv(self.tau, shape, self.dt) * self.scale[iv]
        return self._apply(cols)

    def grid_starts(self, count: int) -> list[NDArray[np.float64]]:
        """The ``count`` best grid points: NNLS in the variances at every combination of grid
        correlation times (increasing within a repeated term)."""
        from scipy import optimize
        b = self._apply(self.nu)
        n_shaped = len(self.shape_idx)
        x = np.zeros(self.model.n_params)
        if n_shaped == 0:
            x[self.var_idx] = optimize.nnls(self._columns(np.zeros(0)), b)[0]
            return [x]
        per_octave = GRID_PER_OCTAVE.get(n_shaped, 1)
        grid_lo = max(self.t_lo, math.log(self.dt) - GRID_OCTAVES_BELOW_SAMPLE * math.log(2.0))
        n_points = max(int((self.t_hi - grid_lo) / math.log(2.0) * per_octave) + 1, n_shaped)
        grid = np.linspace(grid_lo, self.t_hi - math.log(2.0), n_points)
        shaped = [
            (c, kind, ish)
            for c, (kind, (_, ish)) in enumerate(zip(self.model.kinds, self.slices, strict=True))
            if ish is not None
        ]
        base = self._columns(np.full(n_shaped, grid[0]))
        tables = {}
        for _c, kind, _ in shaped:
            if kind.code not in tables:
                unit = kind.unit_wv(self.tau[None, :], grid[:, None], self.dt)
                tables[kind.code] = (self.whiten @ unit.T).T
        groups = {code: [c for c, kind, _ in shaped if kind.code == code] for code in tables}
        per_group = [
            list(itertools.combinations(range(n_points), len(cols))) for cols in groups.values()
        ]
        scored = []
        for combo in itertools.product(*per_group):
            a = base.copy()
            for (code, cols), picks in zip(groups.items(), combo, strict=True):
                for c, g in zip(cols, picks, strict=True):
                    a[:, c] = tables[code][g] * self.scale[self.var_idx[c]]
            u, norm = optimize.nnls(a, b, maxiter=50 * a.shape[1])
            scored.append((norm, u, combo))
        scored.sort(key=lambda item: item[0])
        starts: list[NDArray[np.float64]] = []
        for _, u, combo in scored:
            x = np.zeros(self.model.n_params)
            x[self.var_idx] = u
            for (_, cols), picks in zip(groups.items(), combo, strict=True):
                for c, g in zip(cols, picks, strict=True):
                    x[self.slices[c][1]] = grid[g]
            # the best point of each basin: a start an octave or more from every one taken
            if all(np.max(np.abs(x[self.shape_idx] - y[self.shape_idx])) > START_SEPARATION
                   for y in starts):
                starts.append(x)
            if len(starts) == count:
                break
        return starts

    def allan_start(self, base: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """``base`` with the terms the five-term Allan fit shares set from its logwls fit."""
        if self._allan_beta is None:
            self._allan_beta = self._allan_fit()
        beta5 = self._allan_beta
        if not beta5.size:
            return None
        x = np.array(base, dtype=float)
        for code, (iv, _) in zip(self.model.codes, self.slices, strict=True):
            if code in ALLAN_TERM:
                beta = float(beta5["QNBKR".index(ALLAN_TERM[code])])
                beta = (
                    beta if np.isfinite(beta) and beta > 0.0 else 0.0
                )  # NaN: a term the fit left out
                x[iv] = beta / BETA_FACTOR[ALLAN_TERM[code]] / self.scale[iv]
        return x

    def _allan_fit(self) -> NDArray[np.float64]:
        """The logwls fit's five betas of the terms the model shares with the Allan fit (empty
        where it shares none or the fit fails): the same for every start of this problem, so
        fitted once (a re-weighted search starts from it again)."""
        letters = "".join(ALLAN_TERM[c] for c in self.model.codes if c in ALLAN_TERM)
        if not letters:
            return np.empty(0)
        wv = self.wv
        allan = AllanResult(
            tau_s=wv.tau_s,
            m=wv.m,
            avar=2.0 * wv.wv,
            n_clusters=wv.n_samples // wv.m,
            n_terms=wv.n_coefficients,
            edf=wv.edf,
            ci_low=2.0 * wv.ci_low,
            ci_high=2.0 * wv.ci_high,
            confidence=wv.confidence,
            estimator="overlapping",
            sample_rate_hz=wv.sample_rate_hz,
            n_samples=wv.n_samples,
            noise_alpha=local_noise_alpha(wv.m, 2.0 * wv.wv, wv.n_samples),
        )
        try:
            fit = fit_noise_terms(allan, method="logwls", terms=letters)
        except FitError:
            return np.empty(0)
        return np.asarray(fit.beta, dtype=float)

    def refine(self, starts: list[NDArray[np.float64]], count: int) -> NDArray[np.float64]:
        """Least squares from the ``count`` starts of lowest objective; the best solution."""
        from scipy import optimize
        ready = []
        for x0 in starts:
            x0 = np.clip(np.nan_to_num(x0, nan=0.0), self.lower, self.upper)
            x0[self.var_idx] = np.maximum(x0[self.var_idx], 1e-9)
            ready.append((self.objective(x0), x0))
        ready.sort(key=lambda item: item[0])
        best, best_obj = ready[0][1], ready[0][0]
        for _, x0 in ready[:count]:
            sol = optimize.least_squares(
                self.residual,
                x0,
                jac=self.jacobian,
                bounds=(self.lower, self.upper),
                method="trf",
                x_scale="jac",
                xtol=1e-9,
                ftol=1e-9,
                gtol=1e-9,
                max_nfev=200,
            )
            obj = float(sol.fun @ sol.fun)
            if obj < best_obj:
                best, best_obj = sol.x, obj
        return best

    def solve(self, previous: NDArray[np.float64] | None = None, *, allan: bool = True,
              fresh: bool = False) -> NDArray[np.float64]:
        """Minimize M1 under the current weights: from the grid (and the Allan fit), or, when
        re-weighting, from the ``previous`` solution (M1 moves little with the weights);
        ``fresh`` adds the grid and the Allan fit to ``previous`` (the weights changed much)."""
        if previous is not None and not fresh:
            return self.refine([previous], 1)
        count = REFINED_STARTS if self.shape_idx else 1
        starts = self.grid_starts(count)
        start = self.allan_start(starts[0]) if allan else None
        if start is not None:
            starts.append(start)
        if previous is not None:
            starts.append(previous)
        return self.refine(starts, len(starts))

    def free(self, x: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Parameters not held at a bound (a shape is free only when its variance is)."""
        free = np.ones(len(x), dtype=bool)
        tol = 1e-7
        for iv, ish in self.slices:
            if x[iv] <= tol * max(1.0, float(np.max(x[self.var_idx]))):
                free[iv] = False
                if ish is not None:
                    free[ish] = False
            if ish is not None and (
                x[ish] <= self.lower[ish] + 1e-6 or x[ish] >= self.upper[ish] - 1e-6
            ):
                free[ish] = False
        return free


# --------------------------------------------------------------------------------- fitting


def _finish(problem: _Problem, x: NDArray[np.float64], weights: str, confidence: float,
            model_error: float = 0.0) -> GmwmFit:
    model, dt = problem.model, problem.dt
    x = np.array(x, dtype=float)
    free = problem.free(x)
    r = problem.residual(x)
    obj = float(r @ r)
    dof = len(problem.tau) - int(free.sum())
    p_value = float(chi2_sf(obj, dof)) if dof > 0 else math.nan
    jac = problem.jacobian(x)
    cov_x = np.zeros((len(x), len(x)))
    # every variance gets a standard error (a zero one: the size the data cannot exclude)
    use = free | np.isin(np.arange(len(x)), problem.var_idx)
    if use.any():
        cov_x[np.ix_(use, use)] = np.linalg.pinv(jac[:, use].T @ jac[:, use])
    cov_x *= max(obj / dof, 1.0) if dof > 0 else 1.0
    sx = np.array(problem.scale)
    sx[problem.shape_idx] = 1.0
    cov = cov_x * np.outer(sx, sx)
    params = problem.theta(x)
    values, stderr = model.physical(params, cov, dt)
    for key, idx, role in model.keys(params):
        if role == "shape" and not free[idx]:
            stderr[key] = math.nan
    equivalent = white_equivalent(model, params, cov, dt, float(problem.tau[0]))
    if equivalent is not None:  # a fast GM / AR(1) term: the white noise it amounts to
        values[WN_EQUIVALENT_KEY] = equivalent.value_deg_rt_h
        stderr[WN_EQUIVALENT_KEY] = equivalent.stderr_deg_rt_h
    z = float(normal_ppf(0.5 + confidence / 2))
    low, high = {}, {}
    for key, value in values.items():
        se = stderr[key]
        if value > 0 and math.isfinite(se) and se < 20.0 * value and not key.endswith("_phi"):
            low[key], high[key] = (
                value * math.exp(-z * se / value),
                value * math.exp(z * se / value),
            )
        else:
            low[key], high[key] = max(value - z * se, 0.0), value + z * se
    return GmwmFit(
        model=model,
        params=params,
        cov=cov,
        values=values,
        stderr=stderr,
        ci_low=low,
        ci_high=high,
        objective=obj,
        dof=dof,
        p_value=p_value,
        weights=weights,
        tau_s=problem.tau,
        wv=problem.nu,
        model_wv=model.wv(params, problem.tau, dt),
        sample_rate_hz=problem.wv.sample_rate_hz,
        n_samples=problem.wv.n_samples,
        free=tuple(bool(f) for f in free),
        confidence=confidence,
        model_error=model_error,
    )


def _as_model(model: GmwmModel | str) -> GmwmModel:
    return model if isinstance(model, GmwmModel) else GmwmModel.parse(model)


def gmwm_levels(n_samples: int) -> int:
    """Number of wavelet scales the GMWM takes from ``n_samples`` samples (``GMWM_MIN_BLOCKS``)."""
    return len(dyadic_m(n_samples, min_blocks=GMWM_MIN_BLOCKS))


def check_model_scales(model: GmwmModel, n_levels: int, n_samples: int) -> None:
    """Check that ``n_levels`` wavelet scales (of ``n_samples`` samples) identify ``model``:
    one degree of freedom at least, ``n_levels >= n_params + 1``.

    Raises
    ------
    TooFewSamplesError
        A model with as many parameters as scales or more.
    """
    if n_levels < model.n_params + 1:
        raise TooFewSamplesError(
            f"model {model.name} has {model.n_params} parameters, more than the "
            f"{n_levels} wavelet scales of {n_samples} samples can identify (at most "
            f"{max(n_levels - 1, 0)}); fit fewer terms or record longer"
        )


def _check(model: GmwmModel, wv: WaveletVariance) -> None:
    if np.ndim(wv.wv) != 1:
        raise FitError("fit one axis at a time: pass wv.axis(i)")
    check_model_scales(model, len(wv.tau_s), wv.n_samples)


def gmwm(wv: WaveletVariance, model: GmwmModel | str, *, weights: str = "efficient", steps: int = 2,
         confidence: float = ONE_SIGMA, model_error: float = DEFAULT_MODEL_ERROR) -> GmwmFit:
    """Fit a noise model to a single-axis Haar wavelet variance by the GMWM (eq. M1).

    Parameters
    ----------
    wv : WaveletVariance
        Empirical wavelet variance of one axis (deg/s)^2
        (:func:`analysis.gmwm.wavelet.haar_wavelet_variance`).
    model : GmwmModel or str
        E.g. ``"wn+gm+rw"`` (:mod:`analysis.gmwm.models`).
    weights : {"efficient", "diagonal"}
        ``V^-1`` of the model-based covariance (falling back to its diagonal when it is
        ill-conditioned), or its diagonal from the start.
    steps : int
        Re-estimations of ``V`` after the first (nonparametric, diagonal) step.
    confidence : float
        Two-sided level of the parameter intervals (default +-1 sigma).
    model_error : float
        Relative accuracy (of the WV) to which a model the J test rejects (p < ``REJECT_P``)
        is trusted: it is then refitted with the nonparametric variances plus this floor
        (default 2 %, the floor of the ``logwls`` Allan fit); 0 keeps the efficient weights
        whatever the fit.

    Returns
    -------
    GmwmFit

    Raises
    ------
    GmwmModelError
        An unknown model string.
    FitError, TooFewSamplesError
        A multi-axis WV, or fewer scales than parameters plus one.
    """
    if weights not in ("efficient", "diagonal"):
        raise FitError(f"weights must be 'efficient' or 'diagonal', got {weights!r}")
    model = _as_model(model)
    _check(model, wv)
    flat = ~(np.asarray(wv.variance, dtype=float) > 0)  # the first step's weights: 1 / variance
    if flat.any():
        raise FitError(f"the wavelet variance is constant at {int(flat.sum())} of {flat.size} "
                       "scales: a stuck (constant) record has no noise to fit")
    problem = _Problem(model, wv)
    problem.set_weights(np.diag(np.asarray(wv.variance, dtype=float)), diagonal=True)
    x = problem.solve()
    used, floor = "diagonal", 0.0
    for step in range(max(steps, 0)):
        v = weight_covariance(model, problem.theta(x), wv, floor)
        if not np.all(np.diag(v) > 0):  # the fit is nil at some scale: no model-based
            break                        # weights, the data's own (diagonal) stay
        used = problem.set_weights(v, diagonal=weights == "diagonal")
        # the last step searches afresh: the first, diagonal, weights can leave a local minimum
        # (a fast Gauss-Markov term at the finest scales) that the efficient ones do not prefer
        x = problem.solve(previous=x, fresh=step == steps - 1)
    dof = len(wv.tau_s) - int(problem.free(x).sum())
    if model_error > 0 < steps and dof > 0 and chi2_sf(problem.objective(x), dof) < REJECT_P:
        # the model does not hold: weights from the data, capped by the model error
        floor = model_error
        problem.set_weights(weight_covariance(model, problem.theta(x), wv, floor), diagonal=True)
        used = "nonparametric+floor"
        x = problem.solve(previous=x, fresh=True)
    return _finish(problem, x, used, confidence, floor)


def weight_covariance(model: GmwmModel, params: NDArray[np.float64], wv: WaveletVariance,
                      model_error: float = 0.0) -> NDArray[np.float64]:
    """``V`` ((deg/s)^4) of the weights of a fit: the model-based covariance of the WV
    (:mod:`analysis.gmwm.covariance`) at ``params`` for a model that holds
    (``model_error == 0``); for a rejected one (``model_error > 0``, the relative floor) the
    nonparametric variances of ``wv`` (diagonal) plus ``(model_error nu_hat)^2``."""
    if model_error > 0:
        return np.diag(np.asarray(wv.variance, dtype=float)
                       + (model_error * np.asarray(wv.wv, dtype=float)) ** 2)
    return wv_covariance(model, params, wv.m, wv.n_samples, wv.sample_rate_hz)


def gmwm_with_covariance(wv: WaveletVariance, model: GmwmModel | str, v: NDArray[np.float64], *,
                         confidence: float = ONE_SIGMA) -> GmwmFit:
    """Fit with fixed weights ``V^-1`` (``weights="reference"``): the objectives of models
    fitted with the same ``V`` compare, as model selection needs."""
    model = _as_model(model)
    _check(model, wv)
    problem = _Problem(model, wv)
    kind = problem.set_weights(v)
    x = problem.solve(allan=False)
    return _finish(problem, x, "reference" if kind == "efficient" else "diagonal", confidence)
