"""The guide: a short README whose links lead somewhere, and a documentation site (mkdocs.yml)
whose navigation holds every page of docs/ and whose pages' links resolve."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: a Markdown link or image whose target is a relative path (not a URL, not an anchor)
LINK = re.compile(r"!?\[[^\]]*\]\((?!https?:|#|mailto:)([^)\s#]+)(?:#[^)]*)?\)")
#: a Sphinx role left as text in a built page (docs/hooks/sphinx_roles.py renders them)
LITERAL_ROLE = re.compile(r":(?:py:)?(?:func|meth|class|mod|data|attr|exc|obj|const):")


def _nav_pages(nav: list) -> list[str]:
    pages: list[str] = []
    for entry in nav:
        for value in entry.values():
            pages += _nav_pages(value) if isinstance(value, list) else [value]
    return pages


def _broken_links(page: Path) -> list[str]:
    return [f"{page.relative_to(ROOT)}: {target}" for target in LINK.findall(page.read_text())
            if not (page.parent / target).exists()]


def test_readme_is_short_and_its_links_resolve() -> None:
    readme = ROOT / "README.md"
    lines = readme.read_text().splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines; move detail to docs/"
    assert _broken_links(readme) == []
    assert "pip install -e . && station demo" in readme.read_text()
    assert "pip install -e '.[test]' && python -m pytest -q" in readme.read_text()


def test_every_docs_page_is_in_the_site_and_every_link_resolves() -> None:
    # mkdocs.yml's own tags (none here) would need a loader of their own; safe_load reads it
    site = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    assert site["docs_dir"] == "docs"
    nav = _nav_pages(site["nav"])
    pages = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md"))
    assert sorted(nav) == pages, "every page of docs/ in mkdocs.yml's nav, and no other"
    broken = [link for page in DOCS.rglob("*.md") for link in _broken_links(page)]
    assert broken == []


def test_the_command_reference_is_the_live_help() -> None:
    from tests.command_reference import PAGE, render

    assert PAGE.read_text() == render(), (
        "docs/reference/commands.md is stale: python -m tests.command_reference rewrites it")


@pytest.mark.slow
def test_the_site_builds_strict_and_its_api_pages_link_the_docstrings_roles(
        tmp_path: Path) -> None:
    # the docs extras (pyproject.toml), which .ci/run installs
    pytest.importorskip("mkdocstrings", reason="the site needs pip install -e '.[docs]'")
    site = tmp_path / "site"
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir", str(site)],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stdout + done.stderr
    pages = {p.relative_to(site).as_posix(): p.read_text() for p in site.rglob("*.html")}
    left = {name: LITERAL_ROLE.findall(text) for name, text in pages.items()
            if LITERAL_ROLE.search(text)}
    assert left == {}, "Sphinx roles left as text in the built site"
    assert not (site / "hooks").exists(), "docs/hooks/ is the build's code, not a page"
    davar = pages["reference/api/davar/index.html"]
    # by full dotted path, to another page (an imported name followed to its definition) ...
    assert ('href="../allan/#analysis.allan.estimators.overlapping_allan_variance">'
            "<code>analysis.allan.overlapping_allan_variance</code></a>") in davar
    # ... and relative to the docstring's module, on the same page
    assert 'href="#analysis.davar.estimators.davar_plain"><code>davar_plain</code></a>' in davar
    # a name the site does not render (a module-level constant) is inline code, no link
    allan = pages["reference/api/allan/index.html"]
    # (imported into analysis.allan.deviations, followed to where it is defined)
    assert ('<span title="analysis.allan.kinds.DEVIATION_KINDS"><code>DEVIATION_KINDS'
            "</code></span>") in allan
