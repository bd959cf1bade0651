"""The options of an analysis a command's parser offers (fit method, GMWM, spike policy),
without the analysis: ``station analyze --help`` imports this, not
:mod:`station.evaluation.analyze`."""

from __future__ import annotations

from typing import Literal

from analysis.fit.methods import FitMethod

DEFAULT_METHOD: FitMethod = "logwls"
#: ``--method gmwm``: the GMWM beside the default Allan fit (whose read-offs and terms stay).
GMWM_METHOD: Literal["gmwm"] = "gmwm"
#: What ``method`` may name: an Allan fit method, or the GMWM beside the default one.
AnalysisMethod = FitMethod | Literal["gmwm"]
#: What to do with isolated spikes: remove them when the rule of :mod:`analysis.allan.outliers`
#: says they are few (default), always keep them, or remove whatever is flagged.
OutlierPolicy = Literal["auto", "keep", "remove"]
OUTLIER_POLICIES: tuple[str, ...] = ("auto", "keep", "remove")
