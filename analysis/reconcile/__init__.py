"""Model versus measurement: where a noise model and a record disagree, the candidate
effects, the judges that confirm one (time-series evidence, spectral lines, the GMWM)
and the reconcile loop.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "Attempt": "analysis.reconcile.loop",
    "Comparison": "analysis.reconcile.discrepancy",
    "Effect": "analysis.reconcile.loop",
    "GmwmJudgement": "analysis.reconcile.gmwm_naming",
    "ReconcileOptions": "analysis.reconcile.loop",
    "ReconcileResult": "analysis.reconcile.loop",
    "ReconcileRound": "analysis.reconcile.loop",
    "compare": "analysis.reconcile.discrepancy",
    "judge": "analysis.reconcile.gmwm_naming",
    "measure_curve": "analysis.reconcile.discrepancy",
    "reconcile": "analysis.reconcile.loop",
    "reconcile_curve": "analysis.reconcile.loop",
    "term_avar": "analysis.reconcile.loop",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.reconcile.discrepancy import (
        Comparison as Comparison,
        compare as compare,
        measure_curve as measure_curve,
    )
    from analysis.reconcile.gmwm_naming import GmwmJudgement as GmwmJudgement, judge as judge
    from analysis.reconcile.loop import (
        Attempt as Attempt,
        Effect as Effect,
        ReconcileOptions as ReconcileOptions,
        ReconcileResult as ReconcileResult,
        ReconcileRound as ReconcileRound,
        reconcile as reconcile,
        reconcile_curve as reconcile_curve,
        term_avar as term_avar,
    )


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
