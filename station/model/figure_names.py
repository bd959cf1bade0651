"""Names of the figures a profile may grade that carry a parameter: ``bias_stability_<T>s``."""

from __future__ import annotations

import re

#: ``bias_stability_<T>s``: std of T-second averages, any T.
BIAS_STABILITY_RE = re.compile(r"^bias_stability_(\d+(?:\.\d+)?)s$")


def bias_stability_average_s(name: str) -> float | None:
    """Averaging time (s) of a ``bias_stability_<T>s`` figure, None for other figures."""
    m = BIAS_STABILITY_RE.match(name)
    return float(m.group(1)) if m else None
