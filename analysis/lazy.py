"""Names a package of analysis/ re-exports, imported from their module on first
use."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any


def import_export(namespace: dict[str, Any], exports: Mapping[str, str], name: str) -> object:
    """The value of a package's re-exported ``name``, imported from its module (PEP 562).

    Parameters
    ----------
    namespace : dict
        The package's ``globals()``: the value is kept there, so the next look-up is plain.
    exports : mapping
        Public name -> the dotted module that defines it.
    name : str
        The attribute looked up.

    Raises
    ------
    AttributeError
        ``name`` is not one of ``exports`` (``from package import submodule`` then imports
        the submodule).
    """
    module = exports.get(name)
    if module is None:
        raise AttributeError(f"module {namespace['__name__']!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    namespace[name] = value
    return value
