"""The dynamic Allan variance (DAVAR) of a record, in memory or a window group at a time,
and what it tells: when the gyro has warmed up.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "DavarPlan": "analysis.davar.estimators",
    "DavarResult": "analysis.davar.estimators",
    "WarmupVerdict": "analysis.davar.warmup",
    "davar_plain": "analysis.davar.estimators",
    "davar_recursive": "analysis.davar.estimators",
    "detect_warmup": "analysis.davar.warmup",
    "dynamic_allan_variance": "analysis.davar.estimators",
    "dynamic_allan_variance_long": "analysis.davar.long",
    "dynamic_allan_variance_slices": "analysis.davar.estimators",
    "dynamic_allan_variance_stream": "analysis.davar.estimators",
    "finish_davar": "analysis.davar.estimators",
    "plan_davar": "analysis.davar.estimators",
    "window_starts": "analysis.davar.estimators",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.davar.estimators import (
        DavarPlan as DavarPlan,
        DavarResult as DavarResult,
        davar_plain as davar_plain,
        davar_recursive as davar_recursive,
        dynamic_allan_variance as dynamic_allan_variance,
        dynamic_allan_variance_slices as dynamic_allan_variance_slices,
        dynamic_allan_variance_stream as dynamic_allan_variance_stream,
        finish_davar as finish_davar,
        plan_davar as plan_davar,
        window_starts as window_starts,
    )
    from analysis.davar.long import dynamic_allan_variance_long as dynamic_allan_variance_long
    from analysis.davar.warmup import WarmupVerdict as WarmupVerdict, detect_warmup as detect_warmup


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
