"""The installed station software's version, as run files, gradings and reports record it."""

from __future__ import annotations


def software_version() -> str:
    """Version of the installed gyro-station package (``"unknown"`` when not installed)."""
    # imported here: importlib.metadata (with email, zipfile, csv) costs 40-60 ms, and every
    # command's parser imports this module for ``--version``
    from importlib import metadata

    try:
        return metadata.version("gyro-station")
    except metadata.PackageNotFoundError:
        return "unknown"
