"""A griffe extension (mkdocs.yml, ``extensions`` of the python handler) that renders the
Sphinx cross-reference roles of the docstrings (``:func:`x```, ``:mod:``, ``:class:``,
``:data:``, ``:meth:``, ``:attr:``, ``:exc:``, ``:obj:``, ``:const:``) as links.

Each role's target is resolved by its full dotted path, or relative to the docstring's own
object, then its class and module and their packages (as Sphinx does); an imported name
resolves to the object it names. A resolved target becomes an optional cross-reference
(``<autoref identifier=... optional>``): a link where the object is rendered in the site, and
plain inline code where it is not (a private name, a module no page shows). A target griffe
does not know (numpy, the standard library) becomes plain inline code. ``~name`` shows the
last component only, and ``!name`` never links, as in Sphinx.

``tests/test_docs.py`` builds the site and checks that no role is left in its pages.
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

#: A Sphinx role in a docstring, with an optional ``py:`` domain and a target in backquotes.
ROLE = re.compile(
    r":(?:py:)?(?:func|meth|class|mod|data|attr|exc|obj|const):`(?P<target>[^`]+)`")


def _lookup(collection: griffe.ModulesCollection, path: str) -> str | None:
    """The canonical path of the object at dotted ``path`` (an alias followed to its
    target), None when griffe does not know it."""
    try:
        found = collection.get_member(path)
    except (KeyError, ValueError, AttributeError, griffe.AliasResolutionError):
        return None
    if isinstance(found, griffe.Alias):
        try:
            return found.final_target.path
        except (griffe.AliasResolutionError, griffe.CyclicAliasError):
            return None
    return str(found.path)


def _scopes(obj: griffe.Object) -> list[str]:
    """The dotted paths a relative name is looked up in: the object, then its parents."""
    scopes: list[str] = []
    node: griffe.Object | None = obj
    while node is not None:
        scopes.append(node.path)
        parent = node.parent
        node = parent if isinstance(parent, griffe.Object) else None
    return scopes


def resolve(collection: griffe.ModulesCollection, obj: griffe.Object, target: str) -> str | None:
    """The canonical path ``target`` (a role's target, without ``~``/``!``) names in the
    docstring of ``obj``, None when it names nothing griffe knows."""
    name = target.strip().removesuffix("()").lstrip(".")
    for scope in _scopes(obj):
        found = _lookup(collection, f"{scope}.{name}")
        if found is not None:
            return found
    return _lookup(collection, name)


def rewrite(text: str, collection: griffe.ModulesCollection, obj: griffe.Object) -> str:
    """``text`` (a docstring) with each Sphinx role made a cross-reference or inline code."""

    def replace(match: re.Match[str]) -> str:
        target = match["target"].strip()
        plain = target.startswith("!")
        short = target.startswith("~")
        target = target.lstrip("!~")
        shown = target.rsplit(".", 1)[-1] if short else target
        code = f"<code>{html.escape(shown)}</code>"
        path = None if plain else resolve(collection, obj, target)
        if path is None:
            return code
        return f'<autoref identifier="{html.escape(path)}" optional>{code}</autoref>'

    return ROLE.sub(replace, text)


def _objects(obj: griffe.Object) -> list[griffe.Object]:
    """``obj`` and every object defined in it (aliases, imported names, left out)."""
    found = [obj]
    for member in obj.members.values():
        if not isinstance(member, griffe.Alias):
            found += _objects(member)
    return found


class SphinxRoles(griffe.Extension):
    """Rewrites every docstring of a loaded package once the whole package is loaded, so
    that names defined anywhere in it resolve."""

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader,
                   **kwargs: Any) -> None:
        collection = loader.modules_collection
        for obj in _objects(pkg):
            if obj.docstring is not None and ROLE.search(obj.docstring.value):
                obj.docstring.value = rewrite(obj.docstring.value, collection, obj)
