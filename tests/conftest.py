"""Fixtures shared by several test modules, and the order the suite's files run in."""

from __future__ import annotations

import compileall
import os
import sys
from pathlib import Path

import pytest

from tests.allantools_reference import allantools_tests  # noqa: F401  (a session fixture)
from tests.postgres_server import postgres_server, postgres_url  # noqa: F401  (a server per session)


def pytest_configure(config: pytest.Config) -> None:
    """The project's bytecode, compiled once before the workers start.

    Where ``PYTHONDONTWRITEBYTECODE`` is set (as on the machines that run the suite), no
    Python process writes its ``.pyc`` files, and every command, recorder unit, simulated
    device and worker the suite starts compiled the ~300 modules it imports again: about
    0.2 s of CPU each (``import station.services.grade, station.output.report``: 0.58 s
    from source, 0.38 s from bytecode). Compiled here, they read it (files up to date are
    skipped)."""
    if not sys.dont_write_bytecode or os.environ.get("PYTEST_XDIST_WORKER"):
        return
    root = Path(__file__).resolve().parents[1]
    for package in ("analysis", "devices", "station", "tests", "benchmarks"):
        compileall.compile_dir(root / package, quiet=2)


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
