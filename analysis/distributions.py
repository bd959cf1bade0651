"""Quantiles and tail probabilities of the normal, chi-square and Student t distributions.

Each is the routine of ``scipy.special`` that ``scipy.stats`` itself calls for that
distribution (scipy 1.17, ``scipy/stats/_continuous_distns.py``: ``norm._ppf`` is
``ndtri``, ``chi2._sf`` is ``chdtrc``, ``chi2._ppf`` is ``2 gammaincinv(df/2, q)``,
``t._ppf`` is ``stdtrit``), so the numbers are the same bit for bit for arguments inside
the distribution's support. ``import scipy.stats`` costs 1-1.4 s on the station's
machines and ``scipy.special`` 0.3 s (``python -c "import numpy, time; t = time.time();
import scipy.stats; print(time.time() - t)"``), and each is imported here only when a
function is first called: a command's ``--help`` and a module's import stay free of scipy.
Each returns what scipy's routine does: an array of the arguments' broadcast shape, a numpy
float for scalars.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: sqrt(2 pi), the normal density's constant as scipy.stats writes it.
_NORM_PDF_C = math.sqrt(2 * math.pi)


def normal_ppf(q: ArrayLike) -> NDArray[np.float64]:
    """Standard normal quantile at probability ``q`` (``scipy.stats.norm.ppf``)."""
    from scipy import special

    return special.ndtri(q)  # type: ignore[no-any-return]


def normal_isf(q: ArrayLike) -> NDArray[np.float64]:
    """Standard normal upper quantile: ``x`` with ``P(X > x) = q`` (``norm.isf``)."""
    return -normal_ppf(q)


def normal_cdf(x: ArrayLike) -> NDArray[np.float64]:
    """Standard normal distribution function (``norm.cdf``)."""
    from scipy import special

    return special.ndtr(x)  # type: ignore[no-any-return]


def normal_sf(x: ArrayLike) -> NDArray[np.float64]:
    """Standard normal upper tail ``P(X > x)`` (``norm.sf``)."""
    return normal_cdf(-np.asarray(x, dtype=np.float64))


def normal_pdf(x: ArrayLike) -> NDArray[np.float64]:
    """Standard normal density (``norm.pdf``)."""
    x = np.asarray(x, dtype=np.float64)
    return np.exp(-(x**2) / 2.0) / _NORM_PDF_C


def chi2_sf(x: ArrayLike, df: ArrayLike) -> NDArray[np.float64]:
    """Chi-square upper tail ``P(X > x)`` with ``df`` degrees of freedom (``chi2.sf``)."""
    from scipy import special

    return special.chdtrc(df, x)  # type: ignore[no-any-return]


def chi2_ppf(q: ArrayLike, df: ArrayLike) -> NDArray[np.float64]:
    """Chi-square quantile at probability ``q`` with ``df`` degrees of freedom (``chi2.ppf``)."""
    from scipy import special

    return 2 * special.gammaincinv(np.asarray(df) / 2, q)  # type: ignore[no-any-return]


def t_ppf(q: ArrayLike, df: ArrayLike) -> NDArray[np.float64]:
    """Student t quantile at probability ``q`` with ``df`` degrees of freedom (``t.ppf``)."""
    from scipy import special

    return special.stdtrit(df, q)  # type: ignore[no-any-return]
