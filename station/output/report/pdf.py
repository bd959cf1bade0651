"""The spec sheet as PDF: one A4 portrait page per unit, drawn with matplotlib.

Page layout, top to bottom: title and grade, header (two columns), figures table
(verdicts coloured), Allan deviation plot, DAVAR heat maps (one per axis), event summary,
review flags, tones and notes.
Fonts are 7.5-11 pt so the page reads when printed.
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
    LIMIT_LINE_NOTE,
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
from station.output.report.plateau_sheet import (  # noqa: E402
    draw_plateaus,
    plateau_cells,
    plateau_headings,
)
from station.output.report.sequence_sheet import draw_sequence, sequence_rows  # noqa: E402

if TYPE_CHECKING:
    from station.evaluation.sequence_grading import UnitSequence

A4_IN = (8.27, 11.69)
GRADE_COLORS = {"reject": "#d9534f", "indeterminate": "#e0a800"}
#: The foot of the page: characters per line of events, review, tones and notes.
PDF_LINE_CHARS = 150
#: Lines of notes the sequence and plateau pages show below their plots.
PDF_NOTE_LINES = 6
#: The foot's notes: top of their block, font size and line spacing; the footer line's top
#: and the signature lines' top (page fractions): the notes end above them.
NOTES_TOP, NOTES_FONT, NOTES_SPACING = 0.081, 6.5, 1.3
FOOTER_TOP, SIGNATURES_TOP = 0.016, 0.036
#: Bottom of the DAVAR row, above the notes.
DAVAR_BOTTOM = 0.12


def foot_lines(graded: RunGrade, sheet: UnitSheet) -> tuple[list[str], list[str]]:
    """The foot's lines that fit above the footer (and the signature lines), and those that
    continue on a notes page of their own (none when all fit)."""
    lines = ["; ".join(sheet.events.lines(brief=True)), *sheet.analysis]
    lines += [f"note: {n}" for n in sheet.notes]
    lines.append(LIMIT_LINE_NOTE)
    wrapped = [part for line in lines
               for part in textwrap.wrap(line, PDF_LINE_CHARS, subsequent_indent="  ")]
    approval = graded.sheet.approval if graded.sheet is not None else ()
    line_h = NOTES_FONT * NOTES_SPACING / (A4_IN[1] * 72)
    room = int((NOTES_TOP - (SIGNATURES_TOP if approval else FOOTER_TOP)) / line_h)
    if len(wrapped) <= room:
        return wrapped, []
    rest = wrapped[room - 1:]
    return [*wrapped[: room - 1], f"(continued on the next page: {len(rest)} more lines)"], rest


def _grade_color(grade: str, graded: RunGrade) -> str:
    if grade == graded.profile.reject:
        return GRADE_COLORS["reject"]
    return GRADE_COLORS.get(grade, "#2e7d32")


def unit_page(graded: RunGrade, unit: UnitGrade) -> Figure:
    """The matplotlib figure of one unit's spec sheet page."""
    fig = plt.figure(figsize=A4_IN)
    p = graded.profile
    sheet = unit_sheet(graded, unit)
    title = sheet.title
    left = 0.06
    if graded.sheet is not None and graded.sheet.logo is not None:
        logo = fig.add_axes((0.06, 0.948, 0.12, 0.035))
        logo.imshow(plt.imread(graded.sheet.logo))
        logo.set_anchor("W")
        logo.axis("off")
        left = 0.19
    chars = 52 if left == 0.06 else 42
    fig.text(left, 0.972, title if len(title) <= chars else title[:chars - 1] + "...", fontsize=14,
             weight="bold", va="top")
    fig.text(
        0.94,
        0.972,
        f"GRADE {unit.grade.upper()}",
        fontsize=13,
        weight="bold",
        va="top",
        ha="right",
        color="white",
        bbox={"boxstyle": "round,pad=0.35", "fc": _grade_color(unit.grade, graded)},
    )
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
    davar_h = 0.13
    allan_bottom = DAVAR_BOTTOM + davar_h + 0.065
    ax = fig.add_axes((0.1, allan_bottom, 0.84, max(allan_top - allan_bottom, 0.15)))
    if unit.axes:
        draw_allan(ax, unit.axes, fontsize=7.5, family=graded.output_units)
        ax.set_title("Allan deviation: band = confidence interval, dotted = fitted terms, "
                     "dashed = limits", fontsize=8.5)
    else:
        placeholder(ax, "no noise figures: see the notes", fontsize=8)
    rates = [i for i, a in enumerate(unit.axes) if a.analysis.accel is None]  # maps: rates
    width = 0.84 / max(len(rates), 1)
    for k, i in enumerate(rates):
        dax = fig.add_axes((0.1 + k * width, DAVAR_BOTTOM, width * 0.68, davar_h))
        draw_davar(dax, unit, i, fontsize=6.5, family=graded.output_units)
    shown, _ = foot_lines(graded, sheet)
    approval = graded.sheet.approval if graded.sheet is not None else ()
    fig.text(0.06, NOTES_TOP, "\n".join(shown), fontsize=NOTES_FONT, va="top",
             linespacing=NOTES_SPACING)
    if approval:  # one signature line each, above the footer
        width = 0.88 / len(approval)
        for i, label in enumerate(approval):
            x = 0.06 + i * width
            fig.text(
                x,
                0.024,
                f"{label} (name, date, signature):",
                fontsize=7,
                weight="bold",
                va="bottom",
            )
            fig.add_artist(
                plt.Line2D([x + 0.27, x + width - 0.02], [0.024, 0.024], lw=0.5, color="0.3")
            )
    company = (
        f"{graded.sheet.company}  -  " if graded.sheet is not None and graded.sheet.company else ""
    )
    fig.text(
        0.5,
        0.006,
        f"{company}{p.ref}: {p.description}  -  generated by gyro-station "
        f"{graded.software_version}",
        fontsize=6.5,
        ha="center",
        color="0.4",
    )
    return fig


def _figures_table(fig: Figure, sheet: UnitSheet, top: float) -> float:
    """Draw the figures table below ``top`` (figure fraction); returns its bottom."""
    columns = ["axis", "figure", "unit", "value", "conf. interval", "limit", "grade", "verdict"]
    rows, colors = [], []
    for r in sheet.rows:
        rows.append(
            [
                r.axis,
                r.label,
                r.unit,
                fmt(r.value),
                fmt_interval(r.ci_low, r.ci_high),
                fmt(r.limit) if r.verdict else "",
                r.grade,
                r.verdict or "info",
            ]
        )
        colors.append(["white"] * 7 + [VERDICT_COLORS[r.verdict]])
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
    for i, axis in enumerate(sheet.axes):
        reach = f", indeterminate at {axis.could_reach}" if axis.could_reach else ""
        fig.text(
            0.94,
            bottom - 0.004 - i * 0.012,
            f"axis {axis.axis}: grade {axis.grade}{reach}",
            fontsize=7.5,
            ha="right",
            va="top",
        )
    return bottom - 0.012 * len(sheet.axes)


def sequence_page(graded: RunGrade, seq: UnitSequence, unit_id: str) -> Figure:
    """The page of a unit's test sequence: its figures table and its three plots."""
    fig = plt.figure(figsize=A4_IN)
    fig.text(0.06, 0.972, f"{unit_id}: test sequence {seq.sequence}", fontsize=14,
             weight="bold", va="top")
    if seq.grade:
        fig.text(0.94, 0.972, f"SEQUENCE {seq.grade.upper()}", fontsize=12, weight="bold",
                 va="top", ha="right", color="white",
                 bbox={"boxstyle": "round,pad=0.35", "fc": _grade_color(seq.grade, graded)})
    rows = sequence_rows(seq)
    columns = ["figure", "unit", "value", "conf. interval", "limit", "grade", "verdict"]
    cells = [[r.label, r.unit, fmt(r.value), fmt_interval(r.ci_low, r.ci_high),
              fmt(r.limit) if r.verdict else "", r.grade, r.verdict or "info"] for r in rows]
    colors = [["white"] * 6 + [VERDICT_COLORS[r.verdict]] for r in rows]
    height = 0.018 * (len(rows) + 1)
    top = 0.93
    if rows:
        tax = fig.add_axes((0.06, top - height, 0.88, height))
        tax.axis("off")
        table = tax.table(cellText=cells, colLabels=columns, cellColours=colors,
                          colWidths=[0.34, 0.1, 0.1, 0.18, 0.08, 0.08, 0.12],
                          bbox=Bbox.from_bounds(0, 0, 1, 1), cellLoc="center")
        table.auto_set_font_size(False)
        table.set_fontsize(7.5)
    axes = [fig.add_axes((0.1, y, 0.84, 0.2)) for y in (0.54, 0.29, 0.05)]
    draw_sequence(axes, seq, fontsize=7.5)
    lines = [f"note: {n}" for n in seq.notes]
    wrapped = [part for line in lines for part in textwrap.wrap(line, PDF_LINE_CHARS)]
    fig.text(0.06, top - height - 0.015, "\n".join(wrapped[:PDF_NOTE_LINES]), fontsize=6.5,
             va="top", linespacing=1.3)
    return fig


def plateau_page(seq: UnitSequence, unit_id: str) -> Figure:
    """The page of a temperature test's plateaus: their table and Allan deviations overlaid."""
    fig = plt.figure(figsize=A4_IN)
    fig.text(0.06, 0.972, f"{unit_id}: temperature plateaus of {seq.sequence}", fontsize=14,
             weight="bold", va="top")
    cells = [plateau_cells(p) for p in seq.plateaus]
    row_h = min(0.018, 0.36 / (len(cells) + 2))  # many plateaus: the rows shrink
    height = row_h * (len(cells) + 2)  # the heading takes two rows' height
    top = 0.93
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


def accel_page(graded: RunGrade, unit: UnitGrade, title: str) -> Figure:
    """The page of a unit's accelerometers: their Allan deviation in their own unit
    (:func:`accel_plot_unit`); their figures and limits are in the sheet's table."""
    fig = plt.figure(figsize=A4_IN)
    fig.text(0.06, 0.972, f"{title}: accelerometers", fontsize=12, weight="bold", va="top")
    accel_unit = accel_plot_unit(graded.profile)
    ax = fig.add_axes((0.1, 0.5, 0.84, 0.42))
    draw_allan(ax, unit.axes, fontsize=8, quantity="acceleration", accel_unit=accel_unit)
    ax.set_title(ALLAN_TITLES["acceleration"], fontsize=9)
    shown = quantity_axes(unit, "acceleration")
    width = 0.84 / max(len(shown), 1)
    for k, i in enumerate(shown):
        dax = fig.add_axes((0.1 + k * width, DAVAR_BOTTOM + 0.1, width * 0.68, 0.18))
        draw_davar(dax, unit, i, fontsize=6.5, accel_unit=accel_unit)
    return fig


def notes_page(title: str, lines: list[str]) -> Figure:
    """A page of the notes a unit's sheet had no room for."""
    fig = plt.figure(figsize=A4_IN)
    fig.text(0.06, 0.972, f"{title}: notes (continued)", fontsize=12, weight="bold", va="top")
    fig.text(0.06, 0.94, "\n".join(lines), fontsize=NOTES_FONT, va="top",
             linespacing=NOTES_SPACING)
    return fig


def write_pdf(graded: RunGrade, path: str | Path) -> Path:
    """Write the spec sheets of every unit of ``graded`` into one PDF, one page per unit."""
    path = Path(path)
    with PdfPages(
        path,
        metadata={
            "Title": f"Spec sheets {graded.profile.ref}",
            "Creator": f"gyro-station {graded.software_version}",
        },
    ) as pdf:
        for unit in graded.units:
            fig = unit_page(graded, unit)
            pdf.savefig(draw_literally(fig))
            plt.close(fig)
            sheet = unit_sheet(graded, unit)
            _, rest = foot_lines(graded, sheet)
            if rest:
                fig = notes_page(sheet.title, rest)
                pdf.savefig(draw_literally(fig))
                plt.close(fig)
            if has_accel(unit):  # the accelerometers' Allan deviation, in their own unit
                fig = accel_page(graded, unit, sheet.title)
                pdf.savefig(draw_literally(fig))
                plt.close(fig)
            if has_gmwm(unit):  # the GMWM page follows the unit's sheet
                fig = gmwm_page(unit, unit_sheet(graded, unit).title, A4_IN)
                pdf.savefig(draw_literally(fig))
                plt.close(fig)
            if unit.sequence is not None:
                fig = sequence_page(graded, unit.sequence, unit.unit.unit_id)
                pdf.savefig(draw_literally(fig))
                plt.close(fig)
                if unit.sequence.plateaus:
                    fig = plateau_page(unit.sequence, unit.unit.unit_id)
                    pdf.savefig(draw_literally(fig))
                    plt.close(fig)
    return path
