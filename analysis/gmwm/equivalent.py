"""The white noise a fast correlated GMWM term amounts to.

A Gauss-Markov or AR(1) term whose correlation time ``T`` is shorter than the shortest tau
the GMWM saw is, at every tau of the record, white noise: its Allan variance is
``N_eq^2 / tau`` there. On real MEMS records the ``wn+ar1+rw`` (or ``wn+gm+...``) fit
often drives the white term ``N`` to 0 and puts the white noise into such a term with a
correlation time of a few ms, so ``wn_deg_rt_h`` alone reads 0 for a gyro whose -1/2 slope
shows an angle random walk. The angle random walk the record shows is the white term's
and the fast terms' together, their spectral densities at frequencies below ``1 / T``
adding: ``N_eq^2 = N^2 + sum_i N_i^2`` (key ``wn_equivalent_deg_rt_h``).

Each term's ``N_i^2`` (in (deg/s)^2 s, the internal unit of ``N^2``) is the limit of
``tau avar(tau)`` as ``tau / T`` grows, exactly for the process as
:mod:`analysis.gmwm.models` defines it:

* ``gm`` (sample means of a continuous first-order Gauss-Markov process of variance
  ``s^2``; its Allan variance is IEEE Std 952-1997 Annex C's
  ``2 s^2 T / tau [1 - (3 - 4 e^-x + e^-2x) / (2x)]``, ``x = tau / T``): ``N_i^2 = 2 s^2 T``,
  the two-sided PSD ``2 s^2 T / (1 + (2 pi f T)^2)`` at f = 0.
* ``ar1`` (the point-sampled AR(1) ``x_t = phi x_(t-1) + e_t``, stationary variance ``s^2``,
  ``phi = exp(-dt / T)``): its Haar wavelet variance at ``tau = m dt`` is
  ``s^2 [m (1 - phi^2) - phi (3 - 4 phi^m + phi^2m)] / (2 m^2 (1 - phi)^2)``, whose leading
  term gives ``avar = 2 nu^2 -> s^2 dt (1 + phi) / (1 - phi) / tau``, so
  ``N_i^2 = s^2 dt (1 + phi) / (1 - phi)`` (the sum of the autocovariances,
  ``s^2 (1 + 2 sum_k phi^k)``, times ``dt``). For ``T >> dt`` this is ``2 s^2 T`` again; for
  ``T << dt`` (``phi -> 0``) it is ``s^2 dt``, the white noise of per-sample variance ``s^2``.

The remainder, ``-phi (3 - ...) / m^2`` for the AR(1), falls as ``tau^-2`` like quantization
noise and is below a share ``(T / tau)`` of the white part; it is not counted.

The standard error is the delta method's over the internal parameters (each term's
variance and ``log T``) with the fit's covariance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.gmwm.models import RT_H, GmwmModel

#: The GMWM parameter key of the angle random walk the white term and the fast
#: correlated terms amount to together.
WN_EQUIVALENT_KEY = "wn_equivalent_deg_rt_h"


@dataclass(frozen=True)
class WhiteEquivalent:
    """The angle random walk (deg/sqrt(h)) a fit's white term and its fast correlated terms
    amount to, and each part of it.

    Attributes
    ----------
    value_deg_rt_h, stderr_deg_rt_h : float
        ``sqrt(N^2 + sum_i N_i^2)`` and its standard error.
    parts : tuple of (str, float)
        Each contribution on its own, in deg/sqrt(h): ``("wn", N)`` when the model has a
        white term, then ``(label, N_i)`` of each fast term (``"ar1"``, ``"gm1"``...).
    correlation_times_s : tuple of (str, float)
        The correlation time (s) of each fast term, by label.
    """

    value_deg_rt_h: float
    stderr_deg_rt_h: float
    parts: tuple[tuple[str, float], ...]
    correlation_times_s: tuple[tuple[str, float], ...]

    def readings(self) -> tuple[str, ...]:
        """The alternative readings of the angle random walk, one phrase each."""
        times = dict(self.correlation_times_s)
        out = [f"white noise term alone {n:.4g} deg/sqrt(h)" if label == "wn" else
               f"{label} (T {times[label] * 1e3:.3g} ms) alone {n:.4g} deg/sqrt(h)"
               for label, n in self.parts]
        return (*out, f"together {self.value_deg_rt_h:.4g} +- {self.stderr_deg_rt_h:.2g} "
                      "deg/sqrt(h)")


def _white_part(code: str, v: float, shape: float, dt: float) -> tuple[float, float, float]:
    """(N_i^2 in (deg/s)^2 s, d/dv, d/dshape) of one term of variance parameter ``v`` and
    shape ``log T``."""
    if code == "gm":
        g = 2.0 * v * math.exp(shape)
        return g, 2.0 * math.exp(shape), g
    h = dt / math.exp(shape)  # ar1: phi = exp(-h)
    phi, q = math.exp(-h), -math.expm1(-h)
    ratio = (1.0 + phi) / q
    # d ratio / d shape = 2 / q^2 * d phi / d shape, d phi / d shape = phi h
    return v * dt * ratio, dt * ratio, v * dt * 2.0 * phi * h / (q * q)


def white_equivalent(model: GmwmModel, params: ArrayLike, cov: NDArray[np.float64] | None,
                     dt: float, shortest_tau_s: float) -> WhiteEquivalent | None:
    """The white-noise equivalent of ``model``'s white term and its Gauss-Markov / AR(1)
    terms whose correlation time is under ``shortest_tau_s`` (the module docstring); None
    when the model has no such fast term (its ``wn`` is then the white noise itself).

    Parameters
    ----------
    model : GmwmModel
    params : array_like
        Internal parameters (:mod:`analysis.gmwm.models`).
    cov : ndarray or None
        Their covariance (None: no standard error, NaN).
    dt : float
        Sample period, s.
    shortest_tau_s : float
        The shortest tau of the wavelet variance fitted, s.
    """
    p = np.asarray(params, dtype=float)
    labels = model.term_labels(p)
    total, grad = 0.0, np.zeros(len(p))
    parts: list[tuple[str, float]] = []
    times: list[tuple[str, float]] = []
    for code, label, (iv, ish) in zip(model.codes, labels, model.slices(), strict=True):
        v = max(float(p[iv]), 0.0)
        if code == "wn":
            total += v
            grad[iv] += 1.0
            parts.append((label, math.sqrt(v) * RT_H))
        elif code in ("gm", "ar1") and ish is not None and math.exp(p[ish]) < shortest_tau_s:
            g, dv, dshape = _white_part(code, v, float(p[ish]), dt)
            total += g
            grad[iv] += dv
            grad[ish] += dshape
            parts.append((label, math.sqrt(g) * RT_H))
            times.append((label, math.exp(float(p[ish]))))
    if not times:
        return None
    value = math.sqrt(total) * RT_H
    if cov is None or total <= 0:
        se = math.nan
    else:
        var_total = float(grad @ cov @ grad)
        se = math.sqrt(max(var_total, 0.0)) / (2.0 * math.sqrt(total)) * RT_H
    return WhiteEquivalent(value, se, tuple(parts), tuple(times))
