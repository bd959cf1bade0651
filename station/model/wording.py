"""Counts and durations in words, as every view prints them ("1 axis", "3 axes", "3 min 20 s")."""

from __future__ import annotations

#: Irregular plurals of the nouns the station counts.
PLURALS = {"axis": "axes"}


def plural(n: int, noun: str) -> str:
    """``"1 axis"``, ``"3 axes"``, ``"2 samples"``."""
    return f"{n} {noun if n == 1 else PLURALS.get(noun, noun + 's')}"


def duration_text(seconds: float) -> str:
    """``"45 s"``, ``"3 min 20 s"``, ``"2 h 05 min"``."""
    s = max(0, round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"
