"""The five-term Allan variance model that every fit estimates (Lv 2015 eq. 3, 5-6).

    avar(tau) = 3 Q^2 / tau^2 + N^2 / tau + (0.664 B)^2 + K^2 tau / 3 + R^2 tau^2 / 2

is linear in ``beta = [3 Q^2, N^2, (0.664 B)^2, K^2/3, R^2/2]`` with design columns
``[tau^-2, tau^-1, 1, tau, tau^2]``. The paper's printed beta vector ends in ``K^2/2``;
that is a typo for ``R^2/2`` (the rate-ramp term of eq. 3), and ``R^2/2`` is used here.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.units.conversions import DEG_PER_URAD, S_PER_H

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


def design_matrix(tau_s: ArrayLike, terms: str = TERMS) -> NDArray[np.float64]:
    """Columns ``tau^p`` of eq. 5 for the chosen terms (p = -2, -1, 0, 1, 2 for Q, N, B, K, R)."""
    tau = np.asarray(tau_s, dtype=float)
    return np.column_stack([tau ** TAU_POWER[t] for t in terms])


def full_beta(terms: str, values: ArrayLike) -> NDArray[np.float64]:
    """The five-entry beta (QNBKR order) with ``values`` at ``terms`` and NaN elsewhere."""
    beta = np.full(len(TERMS), np.nan)
    for term, value in zip(terms, np.asarray(values, dtype=float), strict=True):
        beta[TERMS.index(term)] = value
    return beta


def coefficient(term: str, beta_term: float) -> float:
    """Data-sheet coefficient of one term from its variance coefficient (>= 0)."""
    return float(math.sqrt(max(beta_term, 0.0) / BETA_FACTOR[term]) * TO_DATASHEET[term])


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
