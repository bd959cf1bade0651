"""The guide: a short README whose links lead somewhere, and a documentation site (mkdocs.yml)
whose navigation holds every page of docs/ and whose pages' links resolve."""

from __future__ import annotations

import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: a Markdown link or image whose target is a relative path (not a URL, not an anchor)
LINK = re.compile(r"!?\[[^\]]*\]\((?!https?:|#|mailto:)([^)\s#]+)(?:#[^)]*)?\)")


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
