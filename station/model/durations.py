"""Durations as people type them: ``12h``, ``1h30m``, ``90s``, ``2.5min``, ``1e3s``, ``250ms``."""

from __future__ import annotations

import math
import re

from station.errors import UsageError

_DURATION_RE = re.compile(r"((?:\d+(?:\.\d*)?|\.\d+)(?:e[-+]?\d+)?)\s*(ms|min|d|h|m|s)?",
                          re.IGNORECASE)
_UNIT_S = {"d": 86400.0, "h": 3600.0, "min": 60.0, "m": 60.0, "s": 1.0, "ms": 1e-3, None: 1.0}


def parse_duration(text: str) -> float:
    """A duration in seconds from ``12h``, ``1h30m``, ``90s``, ``2.5min``, ``1d``, ``250ms``,
    ``1e3s`` or plain seconds (``m`` and ``min`` are minutes).

    Raises
    ------
    UsageError
        Not a duration, or not > 0.
    """
    s = text.strip().replace(" ", "")
    pos, total = 0, 0.0
    for m in _DURATION_RE.finditer(s):
        if m.start() != pos:
            break
        total += float(m.group(1)) * _UNIT_S[m.group(2).lower() if m.group(2) else None]
        pos = m.end()
    if pos != len(s) or not s or not total > 0 or not math.isfinite(total):
        raise UsageError(f"duration {text!r}: use e.g. 12h, 1h30m, 90s or a number of seconds")
    return total
