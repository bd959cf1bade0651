"""Model versus measurement: the GMWM as the judge between candidate effects the Allan curve cannot
tell apart.

The reconcile workflow (:mod:`analysis.reconcile`) scores each candidate effect by how much
it improves a log-Allan fit with the rest of the model held (Delta BIC, C2 of
:mod:`analysis.candidates`). That fit weights each tau by its own precision, as if the
Allan values were independent; they are not (neighbouring octaves correlate by 0.5-0.9,
:mod:`analysis.gmwm_covariance`), and two explanations of one bump, a Gauss-Markov process
or more bias instability, a rate random walk or a long Gauss-Markov, often come out within
a few units. The GMWM compares them with the full covariance of the wavelet variances.

For the candidates that have a GMWM term (``gauss_markov`` -> ``gm``, ``rate_random_walk``
-> ``rw``, ``bias_instability`` -> ``bi``, ``arw`` -> ``wn``, ``quantization`` -> ``qn``,
``rate_ramp`` -> ``dr``) the model's stochastic terms form the *base* GMWM model, every
parameter free, on the wavelet variance of the record less the model's deterministic terms
and the events already located. An *added* term's model is the base plus its term; a
*refitted* term's is the base itself (its parameter is free there already). All are fitted
with the weights of the largest (:mod:`analysis.gmwm_selection`) and scored by

    score = WIC(base) - WIC(base + term)                                                (N1)

the drop of the wavelet information criterion, on the scale of a Delta BIC (a difference
of twice a log-likelihood); a refit scores 0. The weights are those of the union of all the
explanations (every candidate's term added to the base), so that no candidate is judged
with the covariance of its rival. The candidate with the higher score is the
better explanation; within ``ALTERNATIVE_SCORE`` of each other, both are reported.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike

from analysis.errors import AnalysisError
from analysis.gmwm import gmwm, gmwm_with_covariance, weight_covariance
from analysis.gmwm_models import GmwmModel
from analysis.models import NoiseModel
from analysis.wavelet import haar_wavelet_variance

T = TypeVar("T")

#: GMWM term of each library term that has one.
GMWM_CODE = {"arw": "wn", "quantization": "qn", "bias_instability": "bi", "rate_random_walk": "rw",
             "rate_ramp": "dr", "gauss_markov": "gm"}
#: Two explanations whose scores differ by less than this are both reported (N1 units: twice a
#: log-likelihood; 6 is "strong" evidence on the scale of Kass and Raftery 1995).
ALTERNATIVE_SCORE = 6.0


@dataclass(frozen=True)
class GmwmJudgement:
    """N1 scores of the candidates the GMWM can judge, and the models they were computed on.

    Attributes
    ----------
    scores : dict
        Candidate name -> score (N1); a refitted term scores 0.
    models : dict
        Candidate name -> the GMWM model it stands for (e.g. ``"wn+bi+gm"``).
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
          candidates: Sequence[tuple[str, str]]) -> GmwmJudgement | None:
    """Score ``(name, mode)`` candidates (mode ``"add"`` or ``"refit"``) by N1.

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
        codes = base if mode == "refit" or (code in base and code != "gm") else [*base, code]
        models[name] = GmwmModel.parse("+".join(codes)).name
    if len(models) < 2:
        return None
    union = GmwmModel.parse("+".join(sorted({c for m in models.values() for c in GmwmModel.parse(m).codes}
                                             | set(base)) + (["gm"] if any(
        GmwmModel.parse(m).codes.count("gm") > 1 for m in models.values()) else [])))
    try:
        wv = haar_wavelet_variance(rate_deg_s, sample_rate_hz, ci="eta3")
        if union.n_params >= len(wv.tau_s):
            return None
        # common weights: the covariance under the union of every explanation (model selection's
        # reference), so that no candidate is judged with weights made by its rival
        reference = gmwm(wv, union)
        v = weight_covariance(reference.model, reference.params, wv, reference.model_error)
        wic = {}
        for name in {*models.values(), GmwmModel.parse("+".join(base)).name}:
            fit = gmwm_with_covariance(wv, name, v)
            wic[name] = fit.objective + 2.0 * fit.n_free
    except (AnalysisError, np.linalg.LinAlgError):
        return None
    base_name = GmwmModel.parse("+".join(base)).name
    scores = {name: wic[base_name] - wic[m] for name, m in models.items()}
    return GmwmJudgement(scores=scores, models=models, base=base_name)


@dataclass(frozen=True)
class Alternative:
    """Another explanation that fits about as well as the named one.

    ``score`` is N1 (``criterion="gmwm"``) or the Allan curve's Delta BIC (``"allan"``, C2
    of :mod:`analysis.candidates`); ``change`` is ``"added"`` or what a refit did.
    """

    name: str
    score: float
    criterion: str
    change: str

    def as_json(self) -> dict[str, object]:
        """``{"name", "score", "criterion", "change"}``."""
        return {"name": self.name, "score": self.score, "criterion": self.criterion, "change": self.change}


def new_or_more(group: Sequence[T], name_of: Callable[[T], str], added: Callable[[T], bool],
                judgement: GmwmJudgement) -> list[T]:
    """``group`` (in the order the Allan curve would try it) with the GMWM's answer to "a new
    process or more of one the model has?" in front.

    The first added term of the group and the best-scoring refit are compared by their N1
    scores; the higher goes first (the added term on a tie, since its refit rival scores 0
    by construction only when the term adds nothing). Every other member keeps its place.
    """
    adds = [x for x in group if added(x) and name_of(x) in judgement.scores]
    refits = [x for x in group if not added(x) and name_of(x) in judgement.scores]
    if not adds or not refits:
        return list(group)
    new = adds[0]
    more = max(refits, key=lambda x: judgement.scores[name_of(x)])
    first = new if judgement.scores[name_of(new)] > judgement.scores[name_of(more)] else more
    return [first, *[x for x in group if x is not first]]
