"""Noise models of the GMWM: sums of terms, each with its theoretical Haar wavelet variance.

A model is a sum of independent terms, written ``"wn+qn+gm+gm+rw"``:

=======  ========================================  =========================  ===================
term     process (rate, deg/s)                     Haar WV nu^2(tau)          keys (units in names)
=======  ========================================  =========================  ===================
``wn``   white rate noise, ARW N                   ``N^2 / (2 tau)``          ``wn_deg_rt_h``
``qn``   quantization: white angle noise of std Q  ``3 Q^2 / (2 tau^2)``      ``qn_urad``
``rw``   rate random walk K                        ``K^2 tau / 6``            ``rw_deg_h_rt_h``
``dr``   drift: rate ramp R t                      ``R^2 tau^2 / 4``          ``dr_deg_h2``
``bi``   flicker rate noise (bias instability B)   ``B^2 ln 2 / pi``          ``bi_deg_h``
``gm``   first-order Gauss-Markov, std s, time T   ``avar_GM(tau) / 2`` (G1)  ``gm_sigma_deg_h``,
                                                                              ``gm_tau_s``
``ar1``  discrete AR(1), std s, coefficient phi    closed form (A1)           ``ar1_sigma_deg_h``,
                                                                              ``ar1_phi``
=======  ========================================  =========================  ===================

Every value is half the term's Allan variance (the Haar relation, :mod:`analysis.gmwm.wavelet`
eq. W3; IEEE Std 952-1997 Annex C and Lv 2015 eq. 3 for the IEEE terms). The samples
are taken as the station's simulator and an integrating gyro give them, each the mean
rate over its sample period, so the cumulative angle is the continuous angle at the
sample times and every formula is exact at ``tau = m / fs``, not only for ``tau >> 1/fs``.

* (G1) Gauss-Markov, ``x = tau / T``: ``avar = 2 s^2 T / tau [1 - (3 - 4 e^-x + e^-2x) / (2x)]``
  (IEEE Std 952-1997 Annex C; :func:`analysis.allan.curves.gauss_markov_avar`).
* (A1) AR(1) sampled at points, ``x_t = phi x_(t-1) + e_t``, stationary variance ``s^2``,
  ``m = tau fs``: adjacent sums of m samples have ``Var = s^2 [m (1+phi)/(1-phi) -
  2 phi (1-phi^m)/(1-phi)^2]`` and ``Cov = s^2 phi (1-phi^m)^2/(1-phi)^2``, so
  ``nu^2 = s^2 [m (1 - phi^2) - phi (3 - 4 phi^m + phi^2m)] / (2 m^2 (1-phi)^2)``
  (the Haar WV of an AR(1) of Guerrier et al., JASA 2013, in our tau).

Several Gauss-Markov terms are allowed (``"gm+gm"``); their keys are numbered in the
order of their correlation times (``gm1_...`` the shortest). The ``ar1`` term is the
point-sampled process of the GMWM papers; ``gm`` is the same process observed as sample
means, which is what a gyro and the station's simulator produce.

**Structure functions.** For the covariance of the empirical wavelet variances
(:mod:`analysis.gmwm.covariance`) each term also gives its angle structure function
``D(s) = Var(theta(t+s) - theta(t))`` (generalized for the non-stationary terms: it
holds for every combination of angles whose weights have zero sum and zero first moment,
as the Haar coefficients do): ``N^2 |s|``; ``2 Q^2`` (``s != 0``); ``-K^2 |s|^3 / 6``;
``-(B^2/pi) s^2 ln|s|``; ``2 s^2 T^2 (|s|/T - 1 + e^(-|s|/T))``; for AR(1) the variance
of a sum of ``|s| fs`` samples times ``dt^2``. The wavelet variance follows from it as
``nu^2(tau) = (4 D(tau) - D(2 tau)) / (4 tau^2)``, which the tests check against the
closed forms above. The drift is deterministic and has none.

Internally each term has a variance parameter ``v`` (``N^2``, ``Q^2``, ``K^2``, ``R^2``,
``B^2``, ``s^2`` in deg and s) by which its WV scales, and the Gauss-Markov and AR(1)
terms a shape parameter ``log(T / s)`` (for AR(1), ``phi = exp(-dt / T)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.curves import gauss_markov_avar
from analysis.errors import FitError
from analysis.units.conversions import DEG_PER_URAD, S_PER_H

FloatArray = NDArray[np.float64]

RT_H = math.sqrt(S_PER_H)


class GmwmModelError(FitError):
    """A GMWM model string that names no known term, or a term twice where it cannot be."""


@dataclass(frozen=True)
class TermKind:
    """One kind of term: its WV per unit variance, its structure function, its keys and units.

    ``scale_key`` converts the variance parameter ``v`` to the data-sheet value
    ``sqrt(v) * scale_factor``.
    """

    code: ClassVar[str] = ""
    title: ClassVar[str] = ""
    scale_key: ClassVar[str] = ""
    scale_factor: ClassVar[float] = 1.0
    has_shape: ClassVar[bool] = False
    stochastic: ClassVar[bool] = True

    def unit_wv(self, tau_s: NDArray[np.float64], shape: float | NDArray[np.float64],
                dt: float) -> NDArray[np.float64]:
        """WV ((deg/s)^2) of the term with ``v = 1`` at ``tau_s`` (broadcasts ``shape`` against
        it)."""
        raise NotImplementedError

    def unit_structure(
        self, lag_s: NDArray[np.float64], shape: float, dt: float
    ) -> NDArray[np.float64]:
        """Angle structure function (deg^2) with ``v = 1`` at lags ``lag_s`` (s, multiples of
        dt)."""
        raise NotImplementedError

    def shape_key(self) -> str:
        """Key of the shape parameter (terms that have one)."""
        return ""

    def shape_value(self, shape: float, dt: float) -> float:
        """The shape parameter in its data-sheet unit."""
        return math.exp(shape)


class WhiteNoise(TermKind):
    code, title, scale_key, scale_factor = "wn", "white noise (ARW)", "deg_rt_h", RT_H

    def unit_wv(self, tau_s: FloatArray, shape: float | FloatArray, dt: float) -> FloatArray:
        return 0.5 / tau_s

    def unit_structure(self, lag_s: FloatArray, shape: float, dt: float) -> FloatArray:
        return np.abs(lag_s)


class QuantizationNoise(TermKind):
    code, title, scale_key, scale_factor = "qn", "quantization noise", "urad", 1.0 / DEG_PER_URAD

    def unit_wv(self, tau_s: FloatArray, shape: float | FloatArray, dt: float) -> FloatArray:
        return 1.5 / tau_s**2

    def unit_structure(self, lag_s: FloatArray, shape: float, dt: float) -> FloatArray:
        return np.where(np.abs(lag_s) > 1e-9 * dt, 2.0, 0.0)


class RandomWalk(TermKind):
    code, title, scale_key, scale_factor = "rw", "rate random walk", "deg_h_rt_h", S_PER_H * RT_H

    def unit_wv(self, tau_s: FloatArray, shape: float | FloatArray, dt: float) -> FloatArray:
        return tau_s / 6.0

    def unit_structure(self, lag_s: FloatArray, shape: float, dt: float) -> FloatArray:
        return -np.abs(lag_s) ** 3 / 6.0


class Drift(TermKind):
    code, title, scale_key, scale_factor = "dr", "drift (rate ramp)", "deg_h2", S_PER_H**2
    stochastic = False

    def unit_wv(self, tau_s: FloatArray, shape: float | FloatArray, dt: float) -> FloatArray:
        return tau_s**2 / 4.0

    def unit_structure(self, lag_s: FloatArray, shape: float, dt: float) -> FloatArray:
        return np.zeros_like(lag_s)


class Flicker(TermKind):
    code, title, scale_key, scale_factor = "bi", "bias instability (flicker)", "deg_h", S_PER_H

    def unit_wv(self, tau_s: FloatArray, shape: float | FloatArray, dt: float) -> FloatArray:
        return np.full_like(tau_s, math.log(2.0) / math.pi)

    def unit_structure(self, lag_s: FloatArray, shape: float, dt: float) -> FloatArray:
        a = np.abs(lag_s)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(a > 0, -(a**2) * np.log(a) / math.pi, 0.0)


class GaussMarkovTerm(TermKind):
    code, title, scale_key, scale_factor = "gm", "Gauss-Markov", "sigma_deg_h", S_PER_H
    has_shape = True

    def unit_wv(self, tau_s: FloatArray, shape: float | FloatArray, dt: float) -> FloatArray:
        return 0.5 * gauss_markov_avar(tau_s, 1.0, np.exp(shape))

    def unit_structure(self, lag_s: FloatArray, shape: float, dt: float) -> FloatArray:
        t = math.exp(shape)
        x = np.abs(lag_s) / t
        small = x < 1e-3
        xs = np.where(small, x, 0.0)
        body: FloatArray = np.where(small, xs**2 / 2 - xs**3 / 6 + xs**4 / 24, x + np.expm1(-x))
        return 2.0 * t * t * body

    def shape_key(self) -> str:
        return "tau_s"


class Ar1Term(TermKind):
    code, title, scale_key, scale_factor = "ar1", "AR(1)", "sigma_deg_h", S_PER_H
    has_shape = True

    @staticmethod
    def _phi(shape: float | FloatArray, dt: float) -> tuple[FloatArray, FloatArray]:
        h = dt / np.exp(shape)
        return np.exp(-h), -np.expm1(-h)  # phi, 1 - phi

    def unit_wv(self, tau_s: FloatArray, shape: float | FloatArray, dt: float) -> FloatArray:
        phi, q = self._phi(shape, dt)
        m = tau_s / dt
        pm = phi**m
        num = m * q * (1.0 + phi) - phi * (3.0 - 4.0 * pm + pm * pm)
        return num / (2.0 * m * m * q * q)

    def unit_structure(self, lag_s: FloatArray, shape: float, dt: float) -> FloatArray:
        phi, q = self._phi(shape, dt)
        k = np.rint(np.abs(lag_s) / dt)
        return dt * dt * (k * (1.0 + phi) / q - 2.0 * phi * (1.0 - phi**k) / (q * q))

    def shape_key(self) -> str:
        return "phi"

    def shape_value(self, shape: float, dt: float) -> float:
        return float(self._phi(shape, dt)[0])


KINDS: dict[str, TermKind] = {
    k.code: k()
    for k in (WhiteNoise, QuantizationNoise, Ar1Term, GaussMarkovTerm, Flicker, RandomWalk, Drift)
}
#: Terms that may appear more than once in a model.
REPEATABLE = frozenset({"gm", "ar1"})
#: Most terms of a model: a record would need 2^(2 MAX_TERMS) samples for the scales of more.
MAX_TERMS = 31


@dataclass(frozen=True)
class GmwmModel:
    """A sum of terms, in canonical order (``wn, qn, ar1, gm, bi, rw, dr``).

    Attributes
    ----------
    codes : tuple of str
        Term codes, a repeatable term once per occurrence.
    """

    codes: tuple[str, ...]

    @classmethod
    def parse(cls, text: str) -> GmwmModel:
        """Model from ``"wn+gm+rw"`` (case and spaces ignored; ``2gm`` or ``gm*2`` repeat a term).

        Raises
        ------
        GmwmModelError
            An unknown term, a non-repeatable term twice, more than ``MAX_TERMS`` terms, or
            an empty model.
        """
        codes: list[str] = []
        for raw in str(text).lower().replace(" ", "").split("+"):
            if not raw:
                continue
            count, code = 1, raw
            if "*" in raw:
                code, _, times = raw.partition("*")
                count = int(times) if times.isdigit() else -1
            elif raw[0].isdigit():
                digits = len(raw) - len(raw.lstrip("0123456789"))
                count, code = int(raw[:digits]), raw[digits:]
            if code not in KINDS or count < 1:
                raise GmwmModelError(
                    f"unknown GMWM term {raw!r} in {text!r}; use {', '.join(KINDS)} joined by '+'"
                )
            if len(codes) + count > MAX_TERMS:
                raise GmwmModelError(
                    f"GMWM model {text!r} has more than {MAX_TERMS} terms, more than any record's "
                    f"wavelet scales can identify; fit fewer terms"
                )
            codes += [code] * count
        if not codes:
            raise GmwmModelError(f"empty GMWM model {text!r}; e.g. 'wn+gm+rw'")
        for code in set(codes):
            if codes.count(code) > 1 and code not in REPEATABLE:
                raise GmwmModelError(
                    f"term {code!r} appears twice in {text!r}; only "
                    f"{', '.join(sorted(REPEATABLE))} "
                    f"may repeat"
                )
        order = list(KINDS)
        return cls(tuple(sorted(codes, key=order.index)))

    @property
    def name(self) -> str:
        """Canonical string, e.g. ``"wn+gm+gm+rw"``."""
        return "+".join(self.codes)

    @property
    def kinds(self) -> tuple[TermKind, ...]:
        """The term kinds in order."""
        return tuple(KINDS[c] for c in self.codes)

    @property
    def n_params(self) -> int:
        """Number of internal parameters (a variance per term, a shape per GM/AR(1))."""
        return sum(1 + k.has_shape for k in self.kinds)

    def slices(self) -> list[tuple[int, int | None]]:
        """Per term: (index of its variance, index of its shape or None) in the parameter vector."""
        out, i = [], 0
        for k in self.kinds:
            out.append((i, i + 1 if k.has_shape else None))
            i += 1 + k.has_shape
        return out

    def term_wv(self, params: ArrayLike, tau_s: ArrayLike, dt: float) -> NDArray[np.float64]:
        """WV of each term, shape (n_terms, n_tau), in (deg/s)^2, for internal ``params``."""
        p = np.asarray(params, dtype=float)
        tau = np.asarray(tau_s, dtype=float)
        rows = []
        for kind, (iv, ish) in zip(self.kinds, self.slices(), strict=True):
            shape = float(p[ish]) if ish is not None else 0.0
            rows.append(p[iv] * kind.unit_wv(tau, shape, dt))
        return np.array(rows).reshape(len(rows), tau.size)

    def wv(self, params: ArrayLike, tau_s: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Model WV ((deg/s)^2) at ``tau_s`` for internal ``params``: the sum of the terms'."""
        total: NDArray[np.float64] = self.term_wv(params, tau_s, dt).sum(axis=0)
        return total

    def structure(
        self, params: ArrayLike, lag_s: NDArray[np.float64], dt: float
    ) -> NDArray[np.float64]:
        """Angle structure function (deg^2) of the model's stochastic terms at ``lag_s``."""
        p = np.asarray(params, dtype=float)
        total = np.zeros_like(lag_s, dtype=float)
        for kind, (iv, ish) in zip(self.kinds, self.slices(), strict=True):
            if kind.stochastic and p[iv] > 0:
                shape = float(p[ish]) if ish is not None else 0.0
                total += p[iv] * kind.unit_structure(lag_s, shape, dt)
        return total

    def correlation_times(self, params: ArrayLike) -> list[float]:
        """Correlation times (s) of the shaped terms (GM and AR(1)), in model order."""
        p = np.asarray(params, dtype=float)
        return [math.exp(p[ish]) for _, ish in self.slices() if ish is not None]

    def term_labels(self, params: ArrayLike | None = None) -> list[str]:
        """Label of each term in model order (``"wn"``, ``"gm1"``, ``"gm2"``, ...; see
        :meth:`keys`)."""
        scale_keys = [key for key, _, role in self.keys(params) if role == "scale"]
        return [
            key[: -len(kind.scale_key) - 1]
            for key, kind in zip(scale_keys, self.kinds, strict=True)
        ]

    def keys(self, params: ArrayLike | None = None) -> list[tuple[str, int, str]]:
        """(JSON key, internal index, "scale" or "shape") of every data-sheet parameter.

        Repeated terms are numbered by increasing correlation time when ``params`` is given
        (else in model order): ``gm1_sigma_deg_h``, ``gm1_tau_s``, ``gm2_...``; a single
        one is ``gm_sigma_deg_h``, ``gm_tau_s``.
        """
        slices = self.slices()
        order = list(range(len(self.codes)))
        if params is not None:
            p = np.asarray(params, dtype=float)
            order.sort(
                key=lambda i: (self.codes[i], p[slices[i][1]] if slices[i][1] is not None else 0.0)
            )
        else:
            order.sort(key=lambda i: self.codes[i])
        seen: dict[str, int] = {}
        labels: dict[int, str] = {}
        for i in order:
            code = self.codes[i]
            seen[code] = seen.get(code, 0) + 1
            labels[i] = f"{code}{seen[code]}" if self.codes.count(code) > 1 else code
        out = []
        for i, (kind, (iv, ish)) in enumerate(zip(self.kinds, slices, strict=True)):
            out.append((f"{labels[i]}_{kind.scale_key}", iv, "scale"))
            if ish is not None:
                out.append((f"{labels[i]}_{kind.shape_key()}", ish, "shape"))
        return out

    def physical(self, params: ArrayLike, cov: NDArray[np.float64] | None, dt: float
                 ) -> tuple[dict[str, float], dict[str, float]]:
        """Data-sheet values and standard errors (delta method) from internal params and covariance.

        A variance parameter at zero has value 0 and, as its standard error, the
        square root of its variance's standard error in the data-sheet unit (the size
        the data cannot exclude); one within half a standard error of zero has that
        bound too, where the delta method's ``se / (2 sqrt(v))`` would run off to infinity.
        """
        p = np.asarray(params, dtype=float)
        kinds = {iv: k for k, (iv, _) in zip(self.kinds, self.slices(), strict=True)}
        shaped = {
            ish: k for k, (_, ish) in zip(self.kinds, self.slices(), strict=True) if ish is not None
        }
        values, errors = {}, {}
        for key, idx, role in self.keys(p):
            var = float(cov[idx, idx]) if cov is not None else math.nan
            se = math.sqrt(var) if var >= 0 else math.nan
            if role == "scale":
                k = kinds[idx]
                v = max(float(p[idx]), 0.0)
                values[key] = math.sqrt(v) * k.scale_factor
                # the delta method se / (2 sqrt(v)) grows without bound as v nears zero;
                # within half a standard error of zero sqrt(se) bounds it (the same value)
                errors[key] = (
                    min(se / (2.0 * math.sqrt(v)), math.sqrt(se)) if v > 0 else math.sqrt(se)
                ) * k.scale_factor
            else:
                k = shaped[idx]
                x = k.shape_value(float(p[idx]), dt)
                values[key] = x
                # d value / d log T: T for a correlation time, phi log(1/phi) for AR(1)'s phi
                deriv = x if k.shape_key() == "tau_s" else -x * math.log(x)
                errors[key] = abs(deriv) * se
        return values, errors

    def internal(self, values: dict[str, float], dt: float) -> NDArray[np.float64]:
        """Internal parameters from data-sheet values keyed as :meth:`keys` (model order)."""
        p = np.zeros(self.n_params)
        kinds = {iv: k for k, (iv, _) in zip(self.kinds, self.slices(), strict=True)}
        for key, idx, role in self.keys():
            if key not in values:
                raise GmwmModelError(f"value {key!r} missing for model {self.name}")
            x = float(values[key])
            if role == "scale":
                p[idx] = (x / kinds[idx].scale_factor) ** 2
            elif key.endswith("_phi"):
                p[idx] = math.log(dt / -math.log(x))
            else:
                p[idx] = math.log(x)
        return p
