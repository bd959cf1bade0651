"""The spec sheet as PDF, drawn with matplotlib: per unit, its first page, the pages of
what it has besides (accelerometers, GMWM, test sequence, temperature plateaus) and its
test record, every page with the same header, footer and ``page N of M``
(:mod:`station.output.report.pdf_page`).

The first page is what a customer reads, top to bottom: title and grade, header (two
columns), the figures table (the specification's figures, graded, then the figures shown
for information, marked ``info``, not graded), the Allan deviation plot, the DAVAR heat maps
(one per axis), the verdict and the approval block. The event log, gaps, review items,
ambiguous readings and notes go to the test record at the sheet's end.
Fonts are 6.5-14 pt so the page reads when printed.
"""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.backends.backend_pdf import PdfPages  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.transforms import Bbox  # noqa: E402

from station.evaluation.grading import RunGrade, UnitGrade  # noqa: E402
from station.output.colors import VERDICT_COLORS  # noqa: E402
from station.output.literal_text import draw_literally  # noqa: E402
from station.output.report.common import (  # noqa: E402
    SPEC_CAPTION,
    FigureRow,
    UnitSheet,
    fmt,
    fmt_interval,
    unit_sheet,
)
from station.output.report.gmwm_sheet import gmwm_page, has_gmwm  # noqa: E402
from station.output.report.panels import (  # noqa: E402
    ALLAN_TITLES,
    accel_plot_unit,
    draw_allan,
    draw_davar,
    has_accel,
    placeholder,
    quantity_axes,
)
from station.output.report.pdf_page import (  # noqa: E402
    A4_IN,
    CONTENT_TOP,
    draw_footer,
    draw_header,
    grade_color,
    record_pages,
    subtitle,
)
from station.output.report.plateau_sheet import (  # noqa: E402
    draw_plateaus,
    plateau_cells,
    plateau_headings,
)
from station.output.report.sequence_sheet import draw_sequence, sequence_rows  # noqa: E402

if TYPE_CHECKING:
    from station.evaluation.sequence_grading import UnitSequence

#: Characters per line of the notes under the sequence and plateau plots, and how many lines.
PDF_LINE_CHARS, PDF_NOTE_LINES = 150, 6
#: The first page's foot: the verdict's font and line spacing, the signature lines' baseline
#: (page fractions).
VERDICT_FONT, VERDICT_SPACING, SIGNATURES_Y = 7.5, 1.35, 0.045
#: Bottom of the DAVAR row, above the verdict.
DAVAR_BOTTOM = 0.15


#: Resolution of the page's rasterized parts (the DAVAR heat maps, a 40 x 48 grid about
#: 1.6 x 1.4 in: 2 px a cell and more), dpi; text and lines stay vectors. The rasterizing
#: renderer holds a whole A4 page at this resolution while a map is drawn: 72 dpi against
#: the figure's 100 took the first page's save from +19 to +8 MB (10 min run, 3 axes).
RASTER_DPI = 72


def unit_page(graded: RunGrade, unit: UnitGrade) -> Figure:
    """The matplotlib figure of one unit's first page (without its footer:
    :func:`station.output.report.pdf_page.draw_footer`)."""
    fig = plt.figure(figsize=A4_IN)
    sheet = unit_sheet(graded, unit)
    draw_header(fig, graded, sheet)
    fields = sheet.header
    half = (len(fields) + 1) // 2
    for col, chunk in enumerate((fields[:half], fields[half:])):
        x = 0.06 + col * 0.47
        for row, (label, text) in enumerate(chunk):
            y = 0.935 - row * 0.0165
            fig.text(x, y, f"{label}:", fontsize=7.5, weight="bold", va="top")
            fig.text(x + 0.14, y, text, fontsize=7.5, va="top")
    table_top = 0.935 - half * 0.0165 - 0.01
    table_bottom = _figures_table(fig, sheet, table_top)
    allan_top = table_bottom - 0.035
    davar_h = 0.12
    allan_bottom = DAVAR_BOTTOM + davar_h + 0.06
    ax = fig.add_axes((0.1, allan_bottom, 0.84, max(allan_top - allan_bottom, 0.15)))
    if unit.axes:
        draw_allan(ax, unit.axes, fontsize=7.5, family=graded.output_units)
        ax.set_title("Allan deviation: band = confidence interval, dotted = fitted terms, "
                     "dashed = limits", fontsize=8.5)
    else:
        placeholder(ax, "no noise figures: see the test record", fontsize=8)
    rates = [i for i, a in enumerate(unit.axes) if a.analysis.accel is None]  # maps: rates
    width = 0.84 / max(len(rates), 1)
    for k, i in enumerate(rates):
        dax = fig.add_axes((0.1 + k * width, DAVAR_BOTTOM, width * 0.68, davar_h))
        draw_davar(dax, unit, i, fontsize=6.5, family=graded.output_units)
    approval = graded.sheet.approval if graded.sheet is not None else ()
    verdict = [part for line in sheet.verdict_lines()
               for part in textwrap.wrap(line, 125, subsequent_indent="  ")]
    fig.text(0.06, DAVAR_BOTTOM - 0.042, verdict[0], fontsize=VERDICT_FONT + 1, weight="bold",
             va="top")
    fig.text(0.06, DAVAR_BOTTOM - 0.058, "\n".join(verdict[1:]), fontsize=VERDICT_FONT,
             va="top", linespacing=VERDICT_SPACING)
    if approval:  # one signature line each, above the footer
        width = 0.88 / len(approval)
        for i, label in enumerate(approval):
            x = 0.06 + i * width
            fig.text(x, SIGNATURES_Y, f"{label} (name, date, signature):", fontsize=7,
                     weight="bold", va="bottom")
            fig.add_artist(plt.Line2D([x + 0.27, x + width - 0.02],
                                      [SIGNATURES_Y, SIGNATURES_Y], lw=0.5, color="0.3"))
    return fig


def _table_cells(r: FigureRow) -> list[str]:
    """One figure's cells: a specification figure with its limit, grade and verdict; an
    informational one marked ``not graded`` and ``info``."""
    return [r.axis, r.label, r.unit, fmt(r.value), fmt_interval(r.ci_low, r.ci_high),
            fmt(r.limit) if r.verdict else "", r.grade if r.verdict else "not graded",
            r.verdict or "info"]


def _figures_table(fig: Figure, sheet: UnitSheet, top: float) -> float:
    """Draw the figures table below ``top`` (figure fraction); returns its bottom."""
    columns = ["axis", "figure", "unit", "value", "conf. interval", "limit", "grade", "verdict"]
    ordered = sheet.spec_rows + sheet.info_rows  # the specification first
    rows = [_table_cells(r) for r in ordered]
    colors = [["white"] * 7 + [VERDICT_COLORS[r.verdict]] for r in ordered]
    if not rows:  # no noise figures (a sequence graded on its own figures)
        return top
    # long tables (an IMU: six axes) shrink to leave room for the plots
    row_h = min(0.0145, 0.32 / (len(rows) + 1))
    height = row_h * (len(rows) + 1)
    bottom = top - height
    ax = fig.add_axes((0.06, bottom, 0.88, height))
    ax.axis("off")
    table = ax.table(
        cellText=rows,
        colLabels=columns,
        cellColours=colors,
        loc="upper center",
        colWidths=[0.05, 0.26, 0.1, 0.1, 0.19, 0.09, 0.1, 0.11],
        bbox=Bbox.from_bounds(0, 0, 1, 1),
        cellLoc="center",
    )
    table.auto_set_font_size(False)
    table.set_fontsize(7.5 if row_h >= 0.0125 else 6.5 if row_h >= 0.0105 else 5.5)
    for (row, _col), cell in table.get_celld().items():
        cell.set_linewidth(0.3)
        if row == 0:
            cell.set_text_props(weight="bold")
            cell.set_facecolor("#e6e6e6")
        elif ordered[row - 1].verdict is None:  # information: grey, apart from the spec
            cell.set_text_props(color="0.4", style="italic")
    fig.text(0.06, bottom - 0.004, SPEC_CAPTION, fontsize=6.5, va="top", color="0.3")
    return bottom - 0.014


def sequence_page(graded: RunGrade, seq: UnitSequence) -> Figure:
    """The page of a unit's test sequence: its figures table and its three plots."""
    fig = plt.figure(figsize=A4_IN)
    subtitle(fig, f"Test sequence {seq.sequence}")
    if seq.grade:
        fig.text(0.94, 0.952, f"SEQUENCE {seq.grade.upper()}", fontsize=9, weight="bold",
                 va="top", ha="right", color="white",
                 bbox={"boxstyle": "round,pad=0.25", "fc": grade_color(seq.grade, graded)})
    rows = sequence_rows(seq)
    columns = ["figure", "unit", "value", "conf. interval", "limit", "grade", "verdict"]
    cells = [[r.label, r.unit, fmt(r.value), fmt_interval(r.ci_low, r.ci_high),
              fmt(r.limit) if r.verdict else "", r.grade, r.verdict or "info"] for r in rows]
    colors = [["white"] * 6 + [VERDICT_COLORS[r.verdict]] for r in rows]
    height = 0.018 * (len(rows) + 1)
    top = CONTENT_TOP
    if rows:
        tax = fig.add_axes((0.06, top - height, 0.88, height))
        tax.axis("off")
        table = tax.table(cellText=cells, colLabels=columns, cellColours=colors,
                          colWidths=[0.34, 0.1, 0.1, 0.18, 0.08, 0.08, 0.12],
                          bbox=Bbox.from_bounds(0, 0, 1, 1), cellLoc="center")
        table.auto_set_font_size(False)
        table.set_fontsize(7.5)
    axes = [fig.add_axes((0.1, y, 0.84, 0.19)) for y in (0.555, 0.315, 0.075)]
    draw_sequence(axes, seq, fontsize=7.5)
    lines = [f"note: {n}" for n in seq.notes]
    wrapped = [part for line in lines for part in textwrap.wrap(line, PDF_LINE_CHARS)]
    fig.text(0.06, top - height - 0.015, "\n".join(wrapped[:PDF_NOTE_LINES]), fontsize=6.5,
             va="top", linespacing=1.3)
    return fig


def plateau_page(seq: UnitSequence) -> Figure:
    """The page of a temperature test's plateaus: their table and Allan deviations overlaid."""
    fig = plt.figure(figsize=A4_IN)
    subtitle(fig, f"Temperature plateaus of {seq.sequence}")
    cells = [plateau_cells(p) for p in seq.plateaus]
    row_h = min(0.018, 0.36 / (len(cells) + 2))  # many plateaus: the rows shrink
    height = row_h * (len(cells) + 2)  # the heading takes two rows' height
    top = CONTENT_TOP
    tax = fig.add_axes((0.04, top - height, 0.92, height))
    tax.axis("off")
    table = tax.table(cellText=cells, colLabels=plateau_headings(sep="\n"),
                      bbox=Bbox.from_bounds(0, 0, 1, 1), cellLoc="center")
    table.auto_set_font_size(False)
    table.set_fontsize(7 if row_h >= 0.015 else 6)
    for (row, _col), cell in table.get_celld().items():
        cell.set_linewidth(0.3)
        if row == 0:
            cell.set_height(2 * cell.get_height())
            cell.set_facecolor("#e6e6e6")
    plot_top = top - height - 0.05
    ax = fig.add_axes((0.1, plot_top - 0.42, 0.84, 0.42))
    draw_plateaus(ax, seq.plateaus, fontsize=7.5)
    lines = [f"note: {p.axis} {p.set_point_c:g} degC: {p.note}" for p in seq.plateaus if p.note]
    wrapped = [part for line in lines for part in textwrap.wrap(line, PDF_LINE_CHARS)]
    fig.text(0.06, plot_top - 0.48, "\n".join(wrapped[:PDF_NOTE_LINES]), fontsize=6.5,
             va="top", linespacing=1.3)
    return fig


def accel_page(graded: RunGrade, unit: UnitGrade) -> Figure:
    """The page of a unit's accelerometers: their Allan deviation in their own unit
    (:func:`accel_plot_unit`); their figures and limits are in the sheet's table."""
    fig = plt.figure(figsize=A4_IN)
    subtitle(fig, "Accelerometers")
    accel_unit = accel_plot_unit(graded.profile)
    ax = fig.add_axes((0.1, 0.48, 0.84, 0.42))
    draw_allan(ax, unit.axes, fontsize=8, quantity="acceleration", accel_unit=accel_unit)
    ax.set_title(ALLAN_TITLES["acceleration"], fontsize=9)
    shown = quantity_axes(unit, "acceleration")
    width = 0.84 / max(len(shown), 1)
    for k, i in enumerate(shown):
        dax = fig.add_axes((0.1 + k * width, DAVAR_BOTTOM + 0.1, width * 0.68, 0.18))
        draw_davar(dax, unit, i, fontsize=6.5, accel_unit=accel_unit)
    return fig


def unit_pages(graded: RunGrade, unit: UnitGrade) -> list[Figure]:
    """Every page of one unit's sheet, in order, each with its header and footer: the first
    page, the accelerometers', the GMWM's, the test sequence's and its plateaus', the test
    record."""
    sheet = unit_sheet(graded, unit)
    figs = [unit_page(graded, unit)]
    if has_accel(unit):  # the accelerometers' Allan deviation, in their own unit
        figs.append(accel_page(graded, unit))
    if has_gmwm(unit):  # the GMWM page follows the unit's first page
        figs.append(gmwm_page(unit, A4_IN))
    if unit.sequence is not None:
        figs.append(sequence_page(graded, unit.sequence))
        if unit.sequence.plateaus:
            figs.append(plateau_page(unit.sequence))
    records = record_pages(sheet)
    for fig in figs[1:] + records:  # the first page drew its own header
        draw_header(fig, graded, sheet)
    figs += records
    for n, fig in enumerate(figs, start=1):
        draw_footer(fig, graded, sheet, n, len(figs))
    return figs


def write_pdf(graded: RunGrade, path: str | Path) -> Path:
    """Write the spec sheets of every unit of ``graded`` into one PDF (:func:`unit_pages`
    per unit)."""
    path = Path(path)
    with PdfPages(
        path,
        metadata={
            "Title": f"Spec sheets {graded.profile.ref}",
            "Creator": f"gyro-station {graded.software_version}",
        },
    ) as pdf:
        for unit in graded.units:
            for fig in unit_pages(graded, unit):
                pdf.savefig(draw_literally(fig), dpi=RASTER_DPI)
                plt.close(fig)
    return path
