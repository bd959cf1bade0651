"""Exceptions of the station layer; each also inherits the builtin that fits."""

from __future__ import annotations


class StationError(Exception):
    """Base class of every error the station raises on purpose; the CLI prints its message."""


class RecordFormatError(StationError, ValueError):
    """A record file (CSV, HDF5) cannot be read as a rate record; the message says why."""


class UsageError(StationError, ValueError):
    """Command-line arguments that do not fit together."""
