"""Fixtures shared by several test modules, and the order the suite's files run in."""

from __future__ import annotations

import pytest

from tests.allantools_reference import allantools_tests  # noqa: F401  (a session fixture)
from tests.postgres_server import postgres_server, postgres_url  # noqa: F401  (a server per session)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Files holding ``slow`` tests first, the ones holding the most of them first.

    The two workers take a file each (``--dist loadfile``, in this order, pyproject.toml's
    ``--no-loadscope-reorder``): a file of one long test started last keeps one worker busy
    while the other has nothing left, so the long files start first and the short ones
    fill in behind them. The order within a file is kept.
    """
    def path(item: pytest.Item) -> str:
        return item.nodeid.split("::")[0]

    slow: dict[str, int] = {}
    for item in items:
        slow[path(item)] = slow.get(path(item), 0) + (item.get_closest_marker("slow") is not None)
    rank = {p: i for i, p in enumerate(slow)}
    items.sort(key=lambda item: (-slow[path(item)], rank[path(item)]))
