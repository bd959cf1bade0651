"""The Western Electric run rules of an individuals control chart: the patterns that flag a
drift before a value crosses a control limit.

Over values in test order with the chart's centre line ``c`` and sigma ``s`` (from the
moving range, :func:`station.evaluation.capability.individuals_chart`), a value is flagged
when it completes (Western Electric, *Statistical Quality Control Handbook*, 1956;
Montgomery, *Introduction to Statistical Quality Control*, 6th ed., sec. 5.3.6):

1. ``beyond_3_sigma``: it lies beyond ``c +- 3 s`` (the control limits);
2. ``2_of_3_beyond_2_sigma``: two of three consecutive values beyond ``2 s`` on one side;
3. ``4_of_5_beyond_1_sigma``: four of five consecutive values beyond ``1 s`` on one side;
4. ``8_on_one_side``: eight consecutive values on one side of the centre line.

Only the value completing a pattern (and itself on that side) is flagged; NaN values break
no pattern and are never flagged.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

RunRule = Literal["beyond_3_sigma", "2_of_3_beyond_2_sigma", "4_of_5_beyond_1_sigma",
                  "8_on_one_side"]
#: (rule, window length, values in the window that must be beyond, sigmas beyond the centre)
RULES: tuple[tuple[RunRule, int, int, float], ...] = (
    ("beyond_3_sigma", 1, 1, 3.0),
    ("2_of_3_beyond_2_sigma", 3, 2, 2.0),
    ("4_of_5_beyond_1_sigma", 5, 4, 1.0),
    ("8_on_one_side", 8, 8, 0.0),
)


def run_rule_flags(values: ArrayLike, center: float | None, sigma: float | None
                   ) -> dict[RunRule, tuple[int, ...]]:
    """The indexes of the values each run rule flags (module docstring).

    Parameters
    ----------
    values : array_like
        The figure's values in test order (the figure's unit; NaN for a missing one).
    center, sigma : float or None
        The chart's centre line and sigma, in the values' unit; None (no chart): nothing
        is flagged.

    Returns
    -------
    dict
        Rule name -> indexes into ``values`` (ascending), every rule present.
    """
    x = np.asarray(values, dtype=float)
    flags: dict[RunRule, tuple[int, ...]] = {rule: () for rule, *_ in RULES}
    if center is None or sigma is None or not sigma > 0:
        return flags
    z = (x - center) / sigma
    for rule, window, needed, k in RULES:
        hits: list[int] = []
        for side in (1.0, -1.0):
            beyond = np.nan_to_num(side * z, nan=-np.inf) > k
            for i in range(window - 1, len(x)):
                if beyond[i] and int(np.sum(beyond[i - window + 1:i + 1])) >= needed:
                    hits.append(i)
        flags[rule] = tuple(sorted(set(hits)))
    return flags
