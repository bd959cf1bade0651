"""A device URL as text: whether it is a simulation, its query keys, the same URL with keys
set. Plain ``urllib``: nothing here opens or imports a device (the station's models and
its command line read URLs through it without loading the device libraries)."""

from __future__ import annotations

from collections.abc import Mapping
from urllib.parse import parse_qsl, urlencode, urlsplit, urlunsplit


def is_simulated(url: str) -> bool:
    """Whether ``url`` names a simulated device (a ``sim+`` scheme)."""
    return urlsplit(url.strip()).scheme.lower().startswith("sim+")


def url_keys(url: str) -> dict[str, str]:
    """The query keys of ``url`` as given (the last of a repeated key; no check)."""
    return dict(parse_qsl(urlsplit(url).query, keep_blank_values=True))


def with_keys(url: str, keys: Mapping[str, str], *, keep_given: bool = False) -> str:
    """``url`` with the query ``keys`` set (``keep_given``: keys the URL has keep their
    value); paths and ``:``/``,`` in values stay readable."""
    parts = urlsplit(url)
    query = dict(parse_qsl(parts.query, keep_blank_values=True))
    for key, value in keys.items():
        if not (keep_given and key in query):
            query[key] = value
    return urlunsplit(parts._replace(query=urlencode(query, safe="/:,")))
