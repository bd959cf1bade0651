"""analysis/ in packages by concern, with no module left at its top that only re-exports a
package's names; the top-level package offers the main entry points without importing them up
front."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import analysis

ANALYSIS = Path(analysis.__file__).parent


def test_the_top_of_analysis_holds_its_packages_and_no_moved_modules() -> None:
    """No module at the top of analysis/ only re-exports a package's names (the layout
    map in docs/architecture.md): the top holds the package's own few modules."""
    top = sorted(p.stem for p in ANALYSIS.glob("*.py"))
    assert len(top) <= 12, top  # the package's own few: its errors, lazy names, quantiles
    for name in top:  # none of them re-exports another module's names
        assert "warn_moved" not in (ANALYSIS / f"{name}.py").read_text(), name
    for old in ("fit_log", "gmwm_models", "blocks", "simulate", "accel", "moved"):
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(f"analysis.{old}")


def test_a_module_that_became_a_package_keeps_its_names_without_a_warning() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        from analysis.allan import AllanResult, allan_variance, overlapping_allan_variance
        from analysis.fit import fit_noise_terms
        from analysis.gmwm import gmwm
    from analysis.allan.variance import allan_variance as moved

    assert allan_variance is moved and callable(gmwm) and callable(fit_noise_terms)
    assert overlapping_allan_variance.__module__ == "analysis.allan.estimators"
    assert AllanResult.__module__ == "analysis.allan.estimators"


def test_the_top_level_and_the_packages_offer_their_names_lazily() -> None:
    for name in analysis.__all__:
        value = getattr(analysis, name)
        assert value.__module__ == analysis.ENTRY_POINTS[name], name
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        analysis.nothing  # noqa: B018
    # a module imports its package, and the package none of its other modules
    code = ("import sys, analysis.allan.blocks; "
            "print(sorted(m for m in sys.modules if m.startswith('analysis')))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == (
        "['analysis', 'analysis.allan', 'analysis.allan.blocks', 'analysis.lazy']")
