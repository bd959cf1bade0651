"""Colours every output shares: a verdict's background in the reports and the plots."""

from __future__ import annotations

from station.model.kinds import Verdict

#: Verdict -> colour (reports, plots); None is an informational figure.
VERDICT_COLORS: dict[Verdict | None, str] = {"pass": "#c8ecc8", "fail": "#f5c2c2",
                                             "indeterminate": "#fbe7a9", None: "#ffffff"}
