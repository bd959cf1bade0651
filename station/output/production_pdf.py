"""The producer's statistics as a PDF report (``station results --stats --pdf OUT``).

A4 landscape pages drawn with matplotlib, as the spec sheets are, model after model (the
models are never pooled). A model's first page: a title block (what the statistics cover,
the profile, when it was made), the yield per grade and per lot as tables with a bar chart
of each lot's grades, the capability table of every graded figure, and the units flagged
for review. Then a page per graded figure: its
numbers, its distribution against the profile's limits and its control chart
(:func:`station.output.production_report.draw_figure`, the plots the HTML page shows).
Every number is the one ``station results --stats --json`` prints, formatted as the HTML
page formats it.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from station.evaluation.capability import CAPABILITY_NOTE
from station.model.wording import plural
from station.output.production_report import (
    CAPABILITY_HEADER,
    capability_rows,
    draw_figure,
    interval_text,
    selection_text,
)
from station.output.report.common import fmt

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from station.output.production_stats import FigureStats, ProductionStats, StatsByModel

#: A4 landscape, inches.
PAGE_IN = (11.69, 8.27)
LEFT, RIGHT = 0.05, 0.95
ROW_H = 0.026
#: Rows a first-page table shows before it says how many more there are.
MAX_LOT_ROWS = 8
MAX_REVIEW_ROWS = 7
GRADE_COLORS = ("#2e7d32", "#7cb342", "#c0ca33", "#fbc02d", "#ef6c00", "#d9534f", "#6a1b9a")


def share_text(n: int, total: int) -> str:
    """``"83.3 %"``: ``n`` of ``total`` as a percentage (``-`` of none)."""
    return "-" if not total else f"{100 * n / total:.1f} %"


def lot_name(lot: str) -> str:
    """A lot as the tables name it (``(no lot)`` for units without one)."""
    return lot or "(no lot)"


def _title_block(page: Figure, stats: ProductionStats, heading: str) -> None:
    made = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    page.text(LEFT, 0.955, heading, fontsize=16, weight="bold", va="top")
    page.text(LEFT, 0.912, f"{selection_text(stats)}: {plural(stats.units, 'unit')}, the "
                           f"latest grading of each", fontsize=10, va="top")
    page.text(RIGHT, 0.955, f"profile {stats.profile or '-'}", fontsize=9, va="top",
              ha="right")
    page.text(RIGHT, 0.925, f"made {made}", fontsize=8, va="top", ha="right", color="#555")
    page.add_artist(_rule(page, 0.888))


def _rule(page: Figure, y: float) -> Line2D:
    from matplotlib.lines import Line2D

    return Line2D([LEFT, RIGHT], [y, y], transform=page.transFigure, color="#333", lw=0.8)


def _table(page: Figure, rect: tuple[float, float, float], header: Sequence[str],
           rows: Sequence[Sequence[str]], *, title: str, widths: Sequence[float] | None = None,
           numeric_from: int = 1) -> float:
    """A table under ``title`` at (left, top, width) of the page, text columns left and
    numbers right aligned; returns the y below it."""
    from matplotlib.transforms import Bbox

    left, top, width = rect
    page.text(left, top, title, fontsize=10.5, weight="bold", va="top")
    height = ROW_H * (len(rows) + 1)
    ax = page.add_axes((left, top - 0.03 - height, width, height))
    ax.axis("off")
    if not rows:
        ax.text(0, 1, "none", fontsize=8, va="top")
        return top - 0.03 - ROW_H
    table = ax.table(cellText=[list(r) for r in rows], colLabels=list(header),
                     colWidths=list(widths) if widths else None, loc="upper left",
                     bbox=Bbox.from_bounds(0.0, 0.0, 1.0, 1.0))
    table.auto_set_font_size(False)
    table.set_fontsize(7.5)
    for (row, col), cell in table.get_celld().items():
        cell.set_linewidth(0.3)
        cell.set_edgecolor("#999")
        if row == 0:
            cell.set_text_props(weight="bold")
            cell.set_facecolor("#e6e6e6")
        cell.get_text().set_horizontalalignment("right" if col >= numeric_from and row
                                                else "left")
        cell.PAD = 0.04
    return top - 0.03 - height


def grade_rows(stats: ProductionStats) -> list[list[str]]:
    """The yield-per-grade table: grade, units, share."""
    return [[g, str(n), share_text(n, stats.units)] for g, n in stats.grades.items()]


def lot_rows(stats: ProductionStats) -> list[list[str]]:
    """The yield-per-lot table: lot, units, the units of each grade, the sold share."""
    rows = []
    for lot, counts in stats.lots.items():
        n = sum(counts.values())
        sold = stats.lot_yield(lot)
        rows.append([lot_name(lot), str(n), *(str(counts.get(g, 0)) for g in stats.grades),
                     "-" if sold is None else f"{100 * sold:.1f} %"])
    return rows


def _lot_chart(ax: Axes, stats: ProductionStats) -> None:
    """Each lot's units as a bar stacked by grade, its sold share written above."""
    lots = list(stats.lots)
    bottoms = [0] * len(lots)
    for grade, color in zip(stats.grades, GRADE_COLORS * 3, strict=False):
        heights = [stats.lots[lot].get(grade, 0) for lot in lots]
        ax.bar([lot_name(x) for x in lots], heights, bottom=bottoms, color=color, label=grade,
               edgecolor="white", lw=0.5)
        bottoms = [b + h for b, h in zip(bottoms, heights, strict=True)]
    for i, lot in enumerate(lots):
        sold = stats.lot_yield(lot)
        if sold is not None:
            ax.text(i, bottoms[i], f"{100 * sold:.0f} %", ha="center", va="bottom", fontsize=7)
    ax.set_ylabel("units", fontsize=8)
    ax.set_title("yield per lot (units by grade; sold share above)", fontsize=9)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=7, ncols=min(4, max(1, len(stats.grades))), loc="upper left",
              bbox_to_anchor=(0, -0.12), frameon=False)
    ax.set_ylim(0, max(bottoms, default=1) * 1.18 + 0.5)


def summary_page(stats: ProductionStats) -> Figure:
    """The first page: title block, yield per grade and per lot, capability, review."""
    from matplotlib.figure import Figure

    page = Figure(figsize=PAGE_IN)
    _title_block(page, stats, "Production statistics")
    top = 0.86
    below_grades = _table(page, (LEFT, top, 0.2), ["grade", "units", "share"],
                          grade_rows(stats), title="Yield per grade", widths=(0.4, 0.3, 0.3))
    rows = lot_rows(stats)
    shown = rows[:MAX_LOT_ROWS]
    title = "Yield per lot" + (f" (first {len(shown)} of {len(rows)})" if len(rows) > len(shown)
                               else "")
    grades = list(stats.grades)
    each = [max(4, len(g)) for g in ("lot", "units", *grades, "sold")]
    below_lots = _table(page, (0.27, top, 0.38), ["lot", "units", *grades, "sold"], shown,
                        title=title, widths=[w / sum(each) for w in each])
    chart = page.add_axes((0.70, top - 0.25, 0.25, 0.22))
    _lot_chart(chart, stats)
    y = min(below_grades, below_lots, top - 0.33) - 0.03
    header = [h.replace("95 % CI", "95 % interval") for h in CAPABILITY_HEADER]
    y = _table(page, (LEFT, y, RIGHT - LEFT), header, capability_rows(stats),
               title="Capability of each graded figure against its acceptance limit",
               widths=(0.12, 0.09, 0.03, 0.07, 0.07, 0.06, 0.07, 0.125, 0.065, 0.125, 0.07, 0.07),
               numeric_from=2)
    note = textwrap.fill(CAPABILITY_NOTE, 190)
    page.text(LEFT, y - 0.008, note, fontsize=6.5, va="top", color="#444")
    y -= 0.02 + 0.012 * (note.count("\n") + 1)
    review = stats.review[:MAX_REVIEW_ROWS]
    title = f"Units flagged for review: {plural(len(stats.review), 'unit')}"
    if len(stats.review) > len(review):
        title += f" (first {len(review)}; every one in --json)"
    _table(page, (LEFT, y - 0.01, RIGHT - LEFT), ["serial number", "lot", "test date", "why"],
           [[u.serial_number, lot_name(u.lot), u.test_date,
             textwrap.shorten("; ".join(u.reasons), 150)] for u in review],
           title=title, widths=(0.12, 0.1, 0.16, 0.62), numeric_from=9)
    return page


def figure_page(stats: ProductionStats, f: FigureStats) -> Figure:
    """A graded figure's page: its numbers, its distribution against the limits and its
    control chart."""
    from matplotlib.figure import Figure

    page = Figure(figsize=PAGE_IN)
    _title_block(page, stats, f"{f.name} [{f.unit}]")
    c, k = f.capability, f.chart
    limits = ", ".join(f"{g} {fmt(v)}" for g, v in f.limits.items()) or "-"
    rows = [["values", str(c.n)], ["mean", fmt(c.mean)], ["std", fmt(c.std)],
            ["limits", limits], ["acceptance limit", fmt(c.limit)],
            ["above the limit", "-" if c.above_limit is None else f"{100 * c.above_limit:.1f} %"],
            ["Ppk (upper)", fmt(c.cpk, 3)], ["95 % interval", interval_text(c.cpk_ci)],
            ["out of control", str(len(k.out_of_control))]]
    _table(page, (LEFT, 0.86, 0.26), ["", f.unit], rows, title="Figures", widths=(0.5, 0.5))
    hist = page.add_axes((0.37, 0.50, 0.58, 0.34))
    chart = page.add_axes((0.08, 0.08, 0.87, 0.30))
    draw_figure(hist, chart, f)
    return page


def write_stats_pdf(stats: StatsByModel, path: Path) -> Path:
    """The statistics as a PDF report: per model, its summary page, then a page per graded
    figure (a selection of no unit: one summary page saying so); whole or not at all (a
    failure leaves an earlier file as it was)."""
    from matplotlib.backends.backend_pdf import PdfPages

    from station.output.literal_text import draw_literally
    from station.output.production_stats import ProductionStats
    from station.storage.atomic_files import replacing

    blocks = list(stats.models.values()) or [ProductionStats(None, stats.lot, stats.since)]
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as tmp, PdfPages(tmp) as pdf:  # a failure leaves the old file
        for block in blocks:
            pdf.savefig(draw_literally(summary_page(block)))
            for f in block.figures.values():
                pdf.savefig(draw_literally(figure_page(block, f)))
    return path


__all__ = ["figure_page", "summary_page", "write_stats_pdf"]
