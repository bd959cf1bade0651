"""The installed station software's version, as run files, gradings and reports record it."""

from __future__ import annotations

from importlib import metadata


def software_version() -> str:
    """Version of the installed gyro-station package (``"unknown"`` when not installed)."""
    try:
        return metadata.version("gyro-station")
    except metadata.PackageNotFoundError:
        return "unknown"
