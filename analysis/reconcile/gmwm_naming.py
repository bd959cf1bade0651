"""Model versus measurement: the GMWM as the judge between candidate effects the Allan curve cannot
tell apart.

The reconcile workflow (:mod:`analysis.reconcile`) scores each candidate effect by how much
it improves a log-Allan fit with the rest of the model held (Delta BIC, C2 of
:mod:`analysis.reconcile.candidates`). That fit weights each tau by its own precision, as if the
Allan values were independent; they are not (neighbouring octaves correlate by 0.5-0.9,
:mod:`analysis.gmwm.covariance`), and two explanations of one bump, a Gauss-Markov process
or more bias instability, often come out within a few units, where the curve's order
tries the one with fewer parameters first. The GMWM compares them with the full
covariance of the wavelet variances.

For the candidates that have a GMWM term (``gauss_markov`` -> ``gm``, ``rate_random_walk``
-> ``rw``, ``bias_instability`` -> ``bi``, ``arw`` -> ``wn``, ``quantization`` -> ``qn``,
``rate_ramp`` -> ``dr``) the judge works on the wavelet variance of the record less the
model's deterministic terms and the events already located. Its weights are the
covariance under the union of every explanation (the model's stochastic terms and every
candidate's term, all fitted freely), so that no candidate is judged with the covariance
of its rival. Each candidate is then scored as reconcile fits it, its own term fitted
with the rest of the model held at its values (a refit: the model without that term,
plus the term fitted afresh):

    score = WIC(model as it is) - WIC(model with the candidate fitted)                    (N2)

with ``WIC = J + 2 (free parameters)`` (:mod:`analysis.gmwm.selection`): the drop of the
wavelet information criterion, on the scale of a Delta BIC (a difference of twice a
log-likelihood). ``held=False`` scores with every term of the model free instead,

    score = WIC(base) - WIC(base + term)                                                  (N1)

where a refit scores 0 (the base has that term free already).

**Naming.** When the candidates the Allan curve cannot tell apart (within
``INDISTINCT_BIC`` of the best) are all ones the GMWM can judge and the question is a new
process against more of one the model has (a Gauss-Markov process or more bias
instability), the GMWM answers it (:func:`new_or_more`): the higher score goes first,
where the curve's order would try the explanation with fewer parameters, the refit,
first. Between two added terms (a Gauss-Markov process or a random walk) the curve's order
stands: over an hour a random walk's realization often looks like a Gauss-Markov bump to
the GMWM as well (``benchmarks/bench_reconcile_naming.py``). Every explanation within
``ALTERNATIVE_SCORE`` of the named one, or above it, is reported beside it
(:class:`Alternative`), with its score.

**Scales.** The judge's wavelet variance runs to the longest Haar scale that has a
boundary-free coefficient (``2 m <= N``: ``tau`` up to a quarter to half of the record),
where the plotted wavelet variance stops at ``m <= N / 8``. The top scales have one to a
few equivalent degrees of freedom, and the efficient weights (the model-based covariance
``V`` of :mod:`analysis.gmwm.covariance`, exact for the boundary-free counts ``M_j``) give
them only that much say; but they are where a Gauss-Markov process of a correlation time
of 1/40 to 1/20 of the record turns down (its Allan variance peaks at ``1.89 T``) and where
flicker noise stays flat while a random walk rises. On the development seeds of
``benchmarks/bench_reconcile_naming.py`` (5000-5011, 6000-6011, three ranges) this took
hidden bias-instability increases named right from 10 to 15 of 72 (a Gauss-Markov process
11 -> 9, a random walk 4 -> 1) and Gauss-Markov processes from 62 to 63, and changed
nothing for random walks, sinusoids and clean records.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.errors import AnalysisError
from analysis.gmwm.estimator import gmwm, gmwm_with_covariance, weight_covariance
from analysis.gmwm.models import GmwmModel
from analysis.gmwm.wavelet import WaveletVariance, haar_wavelet_variance
from analysis.models.terms import NoiseModel

T = TypeVar("T")

#: GMWM term of each library term that has one.
GMWM_CODE = {"arw": "wn", "quantization": "qn", "bias_instability": "bi", "rate_random_walk": "rw",
             "rate_ramp": "dr", "gauss_markov": "gm"}
#: Two explanations whose scores differ by less than this are both reported (N1 units: twice a
#: log-likelihood; 6 is "strong" evidence on the scale of Kass and Raftery 1995).
ALTERNATIVE_SCORE = 6.0
#: The judge's Haar scales: every level with boundary-free MODWT coefficients, ``2 m <= N``
#: (``M_j = N - 2m + 1 >= 1``, Percival and Walden eq. 306b), not the ``m <= N / 8`` of a
#: plotted wavelet variance; the weights ``V^-1`` give the few-edf top scales their due.
JUDGE_MIN_BLOCKS = 2


@dataclass(frozen=True)
class GmwmJudgement:
    """N2 (or N1) scores of the candidates the GMWM can judge, and the models fitted for them.

    Attributes
    ----------
    scores : dict
        Candidate name -> score (N2; or N1, where a refitted term scores 0).
    models : dict
        Candidate name -> the GMWM model fitted for it (N2: its term, e.g. ``"gm"``; N1: the
        base with it, e.g. ``"wn+gm+bi"``).
    base : str
        The base GMWM model (the current model's stochastic terms).
    """

    scores: dict[str, float]
    models: dict[str, str]
    base: str


def base_codes(model: NoiseModel) -> list[str]:
    """GMWM terms of a noise model's stochastic terms (white noise always)."""
    codes = [GMWM_CODE[t.name] for t in model.terms if t.name in GMWM_CODE]
    return codes if "wn" in codes else ["wn", *codes]


def judge(rate_deg_s: ArrayLike, sample_rate_hz: float, model: NoiseModel,
          candidates: Sequence[tuple[str, str]], *, held: bool = True) -> GmwmJudgement | None:
    """Score ``(name, mode)`` candidates (mode ``"add"`` or ``"refit"``) by N1 (or N2 when
    ``held``).

    Parameters
    ----------
    rate_deg_s : array_like
        The record less the model's deterministic terms and located events (deg/s).
    sample_rate_hz : float
        Sample rate in Hz.
    model : NoiseModel
        The current model.
    candidates : sequence of (str, str)
        Candidate names and modes; those without a GMWM term are left out.
    held : bool
        Score as reconcile fits (N2): the model's other terms held at their values, only
        the candidate's term fitted; else every term free (N1).

    Returns
    -------
    GmwmJudgement or None
        None when fewer than two candidates can be judged or the record is too short.
    """
    base = base_codes(model)
    models: dict[str, str] = {}
    for name, mode in candidates:
        if name not in GMWM_CODE:
            continue
        code = GMWM_CODE[name]
        if held:
            models[name] = code
        else:
            codes = base if mode == "refit" or (code in base and code != "gm") else [*base, code]
            models[name] = GmwmModel.parse("+".join(codes)).name
    if len(models) < 2:
        return None
    union_codes = sorted(set(base) | {GMWM_CODE[n] for n in models})
    union = GmwmModel.parse(
        "+".join(union_codes + (["gm"] if "gm" in base and "gauss_markov" in models else []))
    )
    base_name = GmwmModel.parse("+".join(base)).name
    try:
        wv = haar_wavelet_variance(rate_deg_s, sample_rate_hz, ci="eta3",
                                   min_blocks=JUDGE_MIN_BLOCKS)
        if union.n_params >= len(wv.tau_s):
            return None
        # common weights: the covariance under the union of every explanation (model selection's
        # reference), so that no candidate is judged with weights made by its rival
        reference = gmwm(wv, union)
        v = weight_covariance(reference.model, reference.params, wv, reference.model_error)
        if held:
            scores = _held_scores(wv, model, models, v)
        else:
            wic = {}
            for name in {*models.values(), base_name}:
                fit = gmwm_with_covariance(wv, name, v)
                wic[name] = fit.objective + 2.0 * fit.n_free
            scores = {name: wic[base_name] - wic[m] for name, m in models.items()}
    except (AnalysisError, np.linalg.LinAlgError):
        return None
    return GmwmJudgement(scores=scores, models=models, base=base_name)


def _held_scores(wv: WaveletVariance, model: NoiseModel, codes: dict[str, str],
                 v: NDArray[np.float64]) -> dict[str, float]:
    """N2: ``WIC(model as it is) - WIC(model with the candidate's term fitted, the rest held)``."""
    duration = wv.n_samples / wv.sample_rate_hz

    def held_wv(terms: NoiseModel) -> NDArray[np.float64]:
        out = np.zeros(len(wv.tau_s))
        for term in terms.terms:
            if (
                term.name in GMWM_CODE and term.name != "rate_ramp"
            ):  # stochastic, still in the record
                out += term.avar(wv.tau_s, duration_s=duration) / 2.0
        return out

    r0 = wv.wv - held_wv(model)
    wic0 = float(r0 @ np.linalg.solve(v, r0))
    scores = {}
    for name, code in codes.items():
        rest = model.without_term(name) if name in model else model
        fit = gmwm_with_covariance(replace(wv, wv=wv.wv - held_wv(rest)), code, v)
        scores[name] = wic0 - (fit.objective + 2.0 * fit.n_free)
    return scores


@dataclass(frozen=True)
class Alternative:
    """Another explanation that fits about as well as the named one.

    ``score`` is N2 (``criterion="gmwm"``) or the Allan curve's Delta BIC (``"allan"``, C2
    of :mod:`analysis.reconcile.candidates`); ``change`` is ``"added"`` or what a refit did.
    """

    name: str
    score: float
    criterion: str
    change: str

    def as_json(self) -> dict[str, object]:
        """``{"name", "score", "criterion", "change"}``."""
        return {
            "name": self.name,
            "score": self.score,
            "criterion": self.criterion,
            "change": self.change,
        }


def new_or_more(group: Sequence[T], name_of: Callable[[T], str], added: Callable[[T], bool],
                judgement: GmwmJudgement) -> list[T]:
    """``group`` (in the order the Allan curve would try it) with the GMWM's answer to "a new
    process or more of one the model has?" in front.

    The first added term of the group and the best-scoring refit are compared by their
    scores; the higher goes first. Every other member keeps its place.
    """
    adds = [x for x in group if added(x) and name_of(x) in judgement.scores]
    refits = [x for x in group if not added(x) and name_of(x) in judgement.scores]
    if not adds or not refits:
        return list(group)
    new = adds[0]
    more = max(refits, key=lambda x: judgement.scores[name_of(x)])
    first = new if judgement.scores[name_of(new)] > judgement.scores[name_of(more)] else more
    return [first, *[x for x in group if x is not first]]
