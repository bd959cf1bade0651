"""The settings of the reconciliation loop and the thresholds they default to, without the
loop: ``station reconcile --help`` shows the defaults by importing this alone."""

from __future__ import annotations

from dataclasses import dataclass

#: Delta BIC (C2) a candidate needs to be considered at all.
BIC_THRESHOLD = 10.0
#: Relative accuracy (in Allan variance) of a library curve, ``f`` of G1.
MODEL_FLOOR = 0.05


@dataclass(frozen=True)
class ReconcileOptions:
    """Settings of :func:`analysis.reconcile.loop.reconcile` (defaults are the stated thresholds).

    Attributes
    ----------
    runs, seed : int
        Monte Carlo runs per comparison and the seed they are drawn from.
    alpha : float
        Level of the gap test: the model disagrees when ``p < alpha``.
    bic_threshold : float
        Delta BIC (C2) a candidate needs.
    shrink_sigmas : float
        How many simulated standard deviations of G the gap must drop by.
    max_effects, max_tries : int
        Most changes to the model; most candidates tried per round.
    max_samples : int
        Longer records are decimated by block means to at most this many samples.
    points_per_octave, min_clusters : int
        Tau grid of the comparison.
    floor : float
        Relative accuracy of a library curve (``f`` of eq. G1).
    min_shrink : float
        Least relative drop of the gap an effect must bring, besides ``shrink_sigmas``.
    gmwm : bool
        Let the GMWM order the candidates the Allan curve cannot tell apart
        (:mod:`analysis.reconcile.gmwm_naming`); False keeps the Allan curve's order alone.
    """

    runs: int = 20
    seed: int = 0
    alpha: float = 0.01
    bic_threshold: float = BIC_THRESHOLD
    shrink_sigmas: float = 3.0
    max_effects: int = 4
    max_tries: int = 3
    max_samples: int = 1 << 20
    points_per_octave: int = 4
    min_clusters: int = 4
    floor: float = MODEL_FLOOR
    min_shrink: float = 0.1
    gmwm: bool = True
