"""The line's charts as SVG text (``station serve``'s figure page): the histogram against
the limits beside the individuals control chart with the run rules' flags
(:func:`figure_svg`), and a figure's trend over lots (:func:`trend_svg`).

The histogram and the chart are :func:`station.output.production_report.figure_plot`'s,
the ones ``station results --stats --html`` draws; the values are in the figure's stored
unit.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from station.evaluation.run_rules import RunRule, run_rule_flags
from station.output.literal_text import draw_literally
from station.output.production_report import figure_plot

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from station.output.production_stats import FigureStats

#: Marker of each run rule on the control chart (rule 1 is figure_plot's red ring).
RULE_MARKERS: dict[RunRule, tuple[str, str]] = {
    "2_of_3_beyond_2_sigma": ("s", "#e65100"),
    "4_of_5_beyond_1_sigma": ("D", "#6a1b9a"),
    "8_on_one_side": ("^", "#00838f"),
}


def _svg(fig: Figure) -> str:
    buf = io.StringIO()
    draw_literally(fig).savefig(buf, format="svg")
    return buf.getvalue()


def figure_svg(f: FigureStats) -> str:
    """Histogram with the limits and the individuals chart of ``f``, the values each run
    rule flags marked (:func:`station.evaluation.run_rules.run_rule_flags`), as SVG text."""
    fig = figure_plot(f)
    chart = fig.axes[1]
    y = [float("nan") if v.value is None else v.value for v in f.values]
    flags = run_rule_flags(y, f.chart.center, f.chart.sigma)
    for rule, (marker, color) in RULE_MARKERS.items():
        flagged = list(flags[rule])
        if flagged:
            chart.plot(flagged, [y[i] for i in flagged], marker, ms=9, mfc="none", mec=color,
                       mew=1.5, label=rule.replace("_", " "))
    chart.legend(fontsize=7)
    return _svg(fig)


def trend_svg(name: str, unit: str, lots: Sequence[Mapping[str, object]],
              limit: float | None) -> str:
    """A figure's mean per lot with the range of its values (``lots``: ``{"lot", "n",
    "mean", "min", "max"}`` in test order) and the acceptance limit, as SVG text."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 3.0), layout="constrained")
    ax = fig.subplots()
    x = list(range(len(lots)))
    mean = [float(str(p["mean"])) for p in lots]
    low = [m - float(str(p["min"])) for m, p in zip(mean, lots, strict=True)]
    high = [float(str(p["max"])) - m for m, p in zip(mean, lots, strict=True)]
    ax.errorbar(x, mean, yerr=[low, high], fmt="o-", color="#37474f", capsize=4,
                label="mean, min to max")
    if limit is not None:
        ax.axhline(limit, color="#d9534f", ls="--", lw=1.2, label=f"limit {limit:.4g}")
    ax.set_xticks(x, [f"{p['lot'] or '-'} (n={p['n']})" for p in lots], fontsize=8)
    ax.set_xlabel("lot, in test order")
    ax.set_ylabel(f"{name} [{unit}]")
    ax.set_title(f"{name} over lots", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    return _svg(fig)
