"""A slow Gauss-Markov process the record cannot tell from a bias instability or a walk.

A first-order Gauss-Markov process whose correlation time T is a sizeable part of the
record has an Allan curve that rises like a rate random walk below T, bends over near
1.89 T and falls slowly after: over the octaves a few hours hold, it is flattened into a
bias instability's floor or read as a walk. ``benchmarks/bench_bias_or_markov.py``
measured it: on N + B and N + GM records the GMWM's wavelet information criterion puts
the two models within :data:`analysis.figures.ambiguity.AMBIGUITY_MARGIN` in 30 of 40, and where
it decides, it is wrong in 4 of 10; slow Gauss-Markov records are printed ``N+K`` in 16 of
20.

So where the printed reading holds B (or, without B, K), the GMWM ranks that reading's
model against the same with a Gauss-Markov process in the term's place
(``wn+bi`` against ``wn+gm``, on the wavelet variance the walk check already made), and a
Gauss-Markov reading that is not ruled out (its criterion at most the margin above) is
listed as an alternative: the printed reading's other terms, the replaced term None, and
the process' sigma and correlation time with their standard errors
(:class:`analysis.fit.result.GaussMarkovReading`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from analysis.errors import AnalysisError
from analysis.fit.model import TERMS
from analysis.fit.result import Alternative, GaussMarkovReading, NoiseCoefficients
from analysis.gmwm.estimator import gmwm, gmwm_with_covariance, weight_covariance
from analysis.gmwm.models import GmwmModelError
from analysis.gmwm.wavelet import WaveletVariance

#: The GMWM term of each IEEE term.
GMWM_TERM = {"Q": "qn", "N": "wn", "B": "bi", "K": "rw", "R": "dr"}
#: The printed terms a slow Gauss-Markov process may be read as, the first present replaced.
MARKOV_LOOKALIKES = "BK"


def gmwm_model(terms: str) -> str:
    """The GMWM model string of an IEEE term set (``"NB"`` -> ``"wn+bi"``)."""
    return "+".join(GMWM_TERM[t] for t in terms)


def _finite(x: float | None) -> float | None:
    return x if x is not None and math.isfinite(x) else None


def markov_alternative(
    wavelet: WaveletVariance, printed: NoiseCoefficients, *, margin: float
) -> Alternative | None:
    """The Gauss-Markov reading of ``printed`` where the record allows it (module docstring).

    Parameters
    ----------
    wavelet : WaveletVariance
        The axis' Haar wavelet variance ((deg/s)^2 per scale).
    printed : NoiseCoefficients
        The reading the sheet prints.
    margin : float
        Wavelet information criterion units within which two readings are the same.

    Returns
    -------
    Alternative or None
        The reading with a Gauss-Markov process in place of B (or K), its
        ``wavelet_criterion_delta`` the process' criterion minus the printed model's and
        its ``criterion_delta`` None; None where the printed reading holds neither term,
        the models cannot be fitted on the record's scales, the process' criterion is
        more than ``margin`` above, or the fitted process is faster than the shortest
        scale (then it is white noise, not a lookalike).
    """
    replaced = next((t for t in MARKOV_LOOKALIKES if t in printed.terms), None)
    if replaced is None:
        return None
    kept = "".join(t for t in TERMS if t in printed.terms)
    term_model = gmwm_model(kept)
    markov_model = term_model.replace(GMWM_TERM[replaced], "gm")
    try:
        # As analysis.gmwm.selection.select_model ranks two candidates (the weights of the
        # larger, here the Gauss-Markov model), less the winner's refit: the efficient fit
        # of the Gauss-Markov model is the reference and gives its values. One re-estimation
        # of its weights, not two: half the cost on every B or K reading, and the second
        # moved sigma and tau by well under their standard errors on the records tried.
        markov = gmwm(wavelet, markov_model, steps=1)
        v_ref = weight_covariance(markov.model, markov.params, wavelet, markov.model_error)
        criteria = [fit.objective + 2.0 * fit.n_free
                    for fit in (gmwm_with_covariance(wavelet, m, v_ref)
                                for m in (term_model, markov_model))]
    except (GmwmModelError, AnalysisError, np.linalg.LinAlgError):
        return None
    delta = criteria[1] - criteria[0]
    sigma, tau = markov.values.get("gm_sigma_deg_h"), markov.values.get("gm_tau_s")
    if (delta > margin or sigma is None or tau is None or not sigma > 0
            or not tau >= wavelet.tau_s[0]):
        return None
    reading = GaussMarkovReading(sigma, _finite(markov.stderr.get("gm_sigma_deg_h")), tau,
                                 _finite(markov.stderr.get("gm_tau_s")))
    beta = printed.beta.copy()
    beta[TERMS.index(replaced)] = np.nan
    fit = replace(printed, terms=kept.replace(replaced, ""),
                  values={**printed.values, replaced: None},
                  stderr={**printed.stderr, replaced: None}, beta=beta, notes=(),
                  alternatives=())
    return Alternative(fit, None, delta, reading)
