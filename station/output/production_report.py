"""The producer's statistics drawn: a self-contained HTML page, and the plots the PDF
report (:mod:`station.output.production_pdf`) shares with it.

Per graded figure, two plots side by side: the histogram of the units' values with every
grade's limit drawn as a vertical line, and the individuals control chart (values in test
order, the mean, the 3-sigma control limits, out-of-control points marked in red); then
the yield per grade, the Cp/Cpk table and the units flagged for review; the page has a
section of these per model (the models are never pooled).
"""

from __future__ import annotations

import base64
import io
from html import escape
from pathlib import Path
from typing import TYPE_CHECKING

from station.evaluation.capability import CAPABILITY_NOTE
from station.model.wording import plural
from station.output.literal_text import draw_literally
from station.output.report.common import fmt
from station.storage.atomic_files import write_text_atomically

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from station.output.production_stats import FigureStats, ProductionStats, StatsByModel

LIMIT_COLORS = ("#2e7d32", "#e0a800", "#d9534f", "#6a1b9a")

CSS = """
body { font-family: sans-serif; font-size: 11pt; margin: 2em; color: #222; }
h1 { font-size: 16pt; } h2 { font-size: 13pt; margin-top: 1.5em; } h3 { font-size: 12pt; }
table { border-collapse: collapse; margin: 0.5em 0; }
td, th { border: 1px solid #bbb; padding: 0.15em 0.5em; text-align: left; }
th { background: #eee; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
td.low { background: #f5c2c2; } img { max-width: 100%; }
"""


def selection_text(stats: ProductionStats | StatsByModel) -> str:
    """``"model TG-1, all lots, tested since 2026-06-01"``: what the statistics cover."""
    r = stats
    parts = [
        f"model {r.model}" if r.model else "all models",
        f"lot {r.lot}" if r.lot else "all lots",
    ]
    if r.since:
        parts.append(f"tested since {r.since}")
    return ", ".join(parts)


def _title(stats: ProductionStats | StatsByModel) -> str:
    return f"Production statistics: {selection_text(stats)} ({plural(stats.units, 'unit')})"


def figure_plot(f: FigureStats) -> Figure:
    """Histogram against the limits (left) and the individuals control chart (right)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 3.6), layout="constrained")
    hist, chart = fig.subplots(1, 2, width_ratios=(1, 1.6))
    draw_figure(hist, chart, f)
    return fig


#: The most serials written under a control chart (beyond, every n-th value is named).
MAX_SERIAL_TICKS = 40
#: The narrowest histogram bar, as a share of the span the histogram's axis shows.
MIN_BAR_SHARE = 1 / 60


def histogram_edges(x: list[float], marks: list[float | None]) -> list[float]:
    """Bin edges of a histogram of ``x`` drawn on an axis that also shows ``marks`` (the
    limits, the mean): ``len(x) // 3`` bins (5 to 30) over the values, each bar at least
    :data:`MIN_BAR_SHARE` of the axis wide, so that a few close values far from a limit
    still show as a bar (a bar of a 1e-6 share is not drawn at all)."""
    lo, hi = min(x), max(x)
    shown = [v for v in (*x, *marks) if v is not None]
    span = max(shown) - min(shown)
    bins = min(30, max(5, len(x) // 3))
    width = max((hi - lo) / bins, span * MIN_BAR_SHARE)
    if width <= 0:  # every value the same, no limit elsewhere
        width = abs(lo) * 0.01 or 1.0
    count = max(1, int(-(-(hi - lo) // width)))
    start = (lo + hi) / 2 - count * width / 2
    return [start + i * width for i in range(count + 1)]


def draw_figure(hist: Axes, chart: Axes, f: FigureStats) -> None:
    """Draw a figure's histogram against its limits on ``hist`` and its individuals control
    chart on ``chart``."""
    x = [v.value for v in f.values if v.value is not None]
    if x:
        hist.hist(x, bins=histogram_edges(x, [*f.limits.values(), f.capability.mean]),
                  color="#90a4ae", edgecolor="#37474f")
    for (grade, limit), color in zip(f.limits.items(), LIMIT_COLORS, strict=False):
        hist.axvline(limit, color=color, ls="--", lw=1.5, label=f"limit {grade} = {limit:.4g}")
    if f.capability.mean is not None:
        hist.axvline(f.capability.mean, color="k", lw=1, label=f"mean {f.capability.mean:.4g}")
    hist.set_xlabel(f"{f.name} [{f.unit}]")
    hist.set_ylabel("units x axes")
    hist.legend(fontsize=7)
    c = f.capability
    fitted = c.fitted.cpk if c.fitted is not None else None
    hist.set_title(f"{f.name}: Ppk {fmt(c.cpk, 3)} (normal), {fmt(fitted, 3)} (fitted)",
                   fontsize=9)
    k = f.chart
    idx = list(range(len(f.values)))
    y = [float("nan") if v.value is None else v.value for v in f.values]
    chart.plot(idx, y, "o-", ms=3, lw=0.7, color="#37474f")
    for value, style, label in (
        (k.center, "-", "mean"),
        (k.ucl, "--", "UCL"),
        (k.lcl, "--", "LCL"),
    ):
        if value is not None:
            chart.axhline(value, color="#1565c0", ls=style, lw=1, label=f"{label} {value:.4g}")
    if k.out_of_control:
        chart.plot(
            list(k.out_of_control),
            [y[i] for i in k.out_of_control],
            "o",
            ms=8,
            mfc="none",
            mec="#d9534f",
            mew=2,
            label="out of control",
        )
    step = max(1, -(-len(idx) // MAX_SERIAL_TICKS))  # every value named, or every step-th
    chart.set_xticks(idx[::step], [f"{v.serial_number} {v.axis}".strip()
                                   for v in f.values[::step]], rotation=60, ha="right",
                     fontsize=6)
    chart.set_xlabel("unit and axis, in test order")
    chart.set_ylabel(f"{f.name} [{f.unit}]")
    chart.set_title(
        f"control chart (individuals, 3-sigma from the moving range): "
        f"{len(k.out_of_control)} out of control",
        fontsize=9,
    )
    chart.legend(fontsize=7)
    chart.grid(True, alpha=0.3)


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    draw_literally(fig).savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def capability_rows(stats: ProductionStats) -> list[list[str]]:
    return [
        [
            name,
            f.unit,
            str(f.capability.n),
            fmt(f.capability.mean),
            fmt(f.capability.std),
            fmt(f.capability.limit),
            fmt(f.capability.cpk, 3),
            interval_text(f.capability.cpk_ci),
            fmt(fitted.cpk if fitted is not None else None, 3),
            interval_text(fitted.cpk_ci if fitted is not None else None),
            fitted.distribution if fitted is not None else "-",
            str(len(f.chart.out_of_control)),
        ]
        for name, f in stats.figures.items()
        for fitted in (f.capability.fitted,)
    ]


def interval_text(ci: tuple[float, float] | None) -> str:
    return "-" if ci is None else f"[{ci[0]:.3g}, {ci[1]:.3g}]"


CAPABILITY_HEADER = ["figure", "unit", "n", "mean", "std", "limit", "Ppk (upper)", "95 % CI",
                     "Ppk fitted", "95 % CI", "fit", "out of control"]


def write_stats_html(stats: StatsByModel, path: Path) -> Path:
    """The statistics as one self-contained HTML file (plots embedded as PNG data URIs), a
    section per model."""
    title = _title(stats)
    parts = [
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{escape(title)}</title>"
        f"<style>{CSS}</style></head><body><h1>{escape(title)}</h1>",
    ]
    if not stats.models:
        parts.append("<p>No graded unit is selected.</p>")
    for block in stats.models.values():
        parts += _model_section(block)
    parts.append("</body></html>")
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_text_atomically(path, "\n".join(parts))


def _model_section(stats: ProductionStats) -> list[str]:
    """One model's section: yield per grade, capability, plots, units flagged for review."""
    parts = [
        f"<section class='model' data-model='{escape(stats.model or '')}'>"
        f"<h2>Model {escape(stats.model or 'all')}: {plural(stats.units, 'unit')}</h2>",
        f"<p>Profile {escape(stats.profile or '-')}; the latest grading of each unit.</p>",
        "<h3>Yield per grade</h3><table class='yield'><tr><th>grade</th><th>units</th>"
        "<th>share</th></tr>",
    ]
    parts += [
        f"<tr data-grade='{escape(g)}'><td>{escape(g)}</td><td class='num'>{n}</td>"
        f"<td class='num'>{100 * n / stats.units:.1f} %</td></tr>"
        for g, n in stats.grades.items()
    ]
    parts.append(
        "</table><h3>Capability</h3><table class='capability'><tr>"
        + "".join(f"<th>{h}</th>" for h in CAPABILITY_HEADER)
        + "</tr>"
    )
    for row in capability_rows(stats):
        low = stats.figures[row[0]].capability.cpk
        cls = " class='num low'" if low is not None and low < 1.33 else " class='num'"
        parts.append(
            f"<tr data-figure='{escape(row[0])}'>"
            + "".join(
                f"<td{cls if i == 6 else ' class=num' if i > 1 else ''}>{escape(c)}</td>"
                for i, c in enumerate(row)
            )
            + "</tr>"
        )
    parts.append(f"</table><p>{escape(CAPABILITY_NOTE)}</p>")
    for name, f in stats.figures.items():
        data = base64.b64encode(_png(figure_plot(f))).decode("ascii")
        parts.append(
            f"<h3>{escape(name)} [{escape(f.unit)}]</h3>"
            f"<img alt='{escape(name)}: histogram and control chart' "
            f"src='data:image/png;base64,{data}'>"
        )
    parts.append(f"<h3>Units flagged for review ({len(stats.review)})</h3><ul class='review'>")
    for u in stats.review:
        parts.append(
            f"<li>{escape(u.serial_number)} ({escape(u.lot or '-')}, {escape(u.test_date)}): "
            + "; ".join(escape(r) for r in u.reasons)
            + "</li>"
        )
    parts.append("</ul></section>")
    return parts
