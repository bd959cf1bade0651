"""Fixtures shared by several test modules."""

from tests.allantools_reference import allantools_tests  # noqa: F401  (a session fixture)
from tests.postgres_server import postgres_server, postgres_url  # noqa: F401  (a server per session)
