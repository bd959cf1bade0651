"""analysis/ in packages by concern: the old module paths still import,
with a DeprecationWarning naming the new path, and re-export the same objects; the top-level
package offers the main entry points without importing them up front."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import analysis

ANALYSIS = Path(analysis.__file__).parent
#: the old flat modules kept as thin re-exports (every module of analysis/ but these)
COMPAT = sorted(p.stem for p in ANALYSIS.glob("*.py")
                if p.stem not in {"__init__", "errors", "moved", "lazy"})


def _moved_to(name: str) -> str:
    """The new module a compatibility module names in its ``warn_moved`` call."""
    tree = ast.parse((ANALYSIS / f"{name}.py").read_text())
    call = next(n for n in ast.walk(tree) if isinstance(n, ast.Call)
                and getattr(n.func, "id", "") == "warn_moved")
    return call.args[1].value  # type: ignore[attr-defined]


def test_there_are_compatibility_modules() -> None:
    assert {"fit_log", "gmwm_models", "blocks", "simulate"} <= set(COMPAT)


@pytest.mark.parametrize("name", COMPAT)
def test_an_old_module_path_still_imports_and_warns(name: str) -> None:
    new = importlib.import_module(_moved_to(name))
    sys.modules.pop(f"analysis.{name}", None)
    with pytest.warns(DeprecationWarning, match=rf"analysis\.{name} moved to {new.__name__}"):
        old = importlib.import_module(f"analysis.{name}")
    public = [n for n in vars(new) if not n.startswith("_")
              and getattr(vars(new)[n], "__module__", None) == new.__name__]
    assert public and all(getattr(old, n) is getattr(new, n) for n in public)


def test_the_warning_points_at_the_importer() -> None:
    sys.modules.pop("analysis.fit_log", None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from analysis.fit_log import fit_log  # noqa: F401
    moved = [w for w in caught if issubclass(w.category, DeprecationWarning)]
    assert [Path(w.filename).name for w in moved] == [Path(__file__).name]


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
