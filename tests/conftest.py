"""Fixtures shared by several test modules."""

from tests.allantools_reference import allantools_tests  # noqa: F401  (a session fixture)
