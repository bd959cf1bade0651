"""The spec sheet as one self-contained HTML file: inline CSS, PNG plots embedded as data URIs.

Each unit is a ``<section class="unit">`` (a new page when printed) laid out as the PDF
sheet: the header table, the figures table (``<table class="figures">``, one ``<tr>`` per
axis and figure with ``data-axis``, ``data-figure`` and ``data-verdict`` attributes for
machines; the specification's figures first, then those shown for information, marked
``info``), the Allan and DAVAR images, the verdict and the approval block; then its test
record (``<div class="test-record">``, a page of its own when printed: events, analysis,
notes); every part ends with the footer naming the test as it was run.
"""

from __future__ import annotations

import base64
import re
from html import escape
from pathlib import Path
from typing import TYPE_CHECKING

from station.evaluation.grading import RunGrade, UnitGrade
from station.output.colors import VERDICT_COLORS
from station.output.report.common import (
    SPEC_CAPTION,
    UnitSheet,
    fmt,
    fmt_interval,
    unit_sheet,
)
from station.output.report.gmwm_sheet import gmwm_png, gmwm_section, has_gmwm
from station.output.report.panels import accel_plot_unit, allan_png, davar_png, has_accel
from station.output.report.plateau_sheet import plateau_cells, plateau_headings, plateau_png
from station.output.report.sequence_sheet import sequence_png, sequence_rows

if TYPE_CHECKING:
    from station.evaluation.sequence_grading import UnitSequence

CSS = """
body { font-family: sans-serif; font-size: 11pt; margin: 2em; color: #222; }
section.unit { page-break-before: always; margin-bottom: 3em; }
section.unit:first-of-type { page-break-before: auto; }
h1 { font-size: 16pt; } h2 { font-size: 13pt; }
.grade { display: inline-block; padding: 0.2em 0.6em; border-radius: 0.3em; color: white;
         font-weight: bold; background: #2e7d32; }
.grade.reject { background: #d9534f; } .grade.indeterminate { background: #e0a800; }
table { border-collapse: collapse; margin: 0.5em 0; }
td, th { border: 1px solid #bbb; padding: 0.15em 0.5em; text-align: left; }
th { background: #eee; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
img { max-width: 100%; }
.company img { height: 3em; vertical-align: middle; }
.company { font-size: 13pt; font-weight: bold; }
table.approval td { height: 3em; min-width: 14em; color: #888; font-size: 8pt;
                    vertical-align: bottom; }
p.convention { font-size: 9pt; color: #444; }
tr.info td { color: #666; font-style: italic; }
div.test-record { page-break-before: always; }
footer.test { font-size: 8pt; color: #555; border-top: 1px solid #bbb; margin-top: 1.5em;
              padding-top: 0.3em; }
""" + "".join(f"tr.{v} td.verdict {{ background: {c}; }}\n" for v, c in VERDICT_COLORS.items() if v)


def _img(png: bytes, alt: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return f'<img alt="{escape(alt)}" src="data:image/png;base64,{data}">'


def unit_section(graded: RunGrade, unit: UnitGrade) -> str:
    """The HTML ``<section>`` of one unit."""
    sheet = unit_sheet(graded, unit)
    grade_class = "reject" if sheet.rejected else re.sub(r"\W+", "-", sheet.grade)
    head = graded.sheet
    parts = [
        f'<section class="unit" id="unit-{escape(sheet.unit_id)}" '
        f'data-grade="{escape(sheet.grade)}">'
    ]
    company = ""
    if head is not None and (head.logo is not None or head.company):
        logo = _img(head.logo.read_bytes(), "logo") if head.logo is not None else ""
        company = f'<div class="company">{logo} {escape(head.company)}</div>'
        parts.append(company)
    parts += [
        f"<h1>{escape(sheet.title)} "
        f'<span class="grade {escape(grade_class)}">GRADE {escape(sheet.grade.upper())}'
        f"</span></h1>",
        '<table class="header">',
    ]
    parts += [f"<tr><th>{escape(k)}</th><td>{escape(v)}</td></tr>" for k, v in sheet.header]
    parts.append("</table><h2>Figures</h2>")
    parts.append(
        '<table class="figures"><tr><th>axis</th><th>figure</th><th>unit</th><th>value</th>'
        "<th>confidence interval</th><th>limit</th><th>grade</th><th>verdict</th>"
        "<th>note</th></tr>"
    )
    for r in sheet.spec_rows + sheet.info_rows:  # the specification first
        verdict = r.verdict or "info"
        parts.append(
            f'<tr class="{verdict}" data-axis="{escape(r.axis)}" data-figure="{escape(r.name)}" '
            f'data-value="{"" if r.value is None else repr(r.value)}" data-verdict="{verdict}">'
            f"<td>{escape(r.axis)}</td><td>{escape(r.label)}</td><td>{escape(r.unit)}</td>"
            f'<td class="num">{fmt(r.value)}</td>'
            f'<td class="num">{fmt_interval(r.ci_low, r.ci_high)}</td>'
            f'<td class="num">{fmt(r.limit) if r.verdict else ""}</td>'
            f'<td>{escape(r.grade) if r.verdict else "not graded"}</td>'
            f'<td class="verdict">{verdict}</td><td>{escape(r.note)}</td></tr>'
        )
    parts.append(f'</table><p class="convention">{escape(SPEC_CAPTION)}</p>')
    if unit.axes:
        parts.append("<h2>Allan deviation</h2>")
        parts.append(_img(allan_png(unit, graded.output_units),
                          "Allan deviation with confidence band, fitted terms and limits"))
        if has_accel(unit):
            accel_unit = accel_plot_unit(graded.profile)
            parts.append("<h2>Allan deviation of the accelerometers</h2>")
            parts.append(_img(allan_png(unit, quantity="acceleration", accel_unit=accel_unit),
                              "Allan deviation of the accelerometers with confidence band "
                              "and fitted terms"))
            parts.append(_img(davar_png(unit, quantity="acceleration", accel_unit=accel_unit),
                              "DAVAR heat map per accelerometer axis"))
        parts.append("<h2>Dynamic Allan deviation</h2>")
        parts.append(_img(davar_png(unit, graded.output_units), "DAVAR heat map per axis"))
    else:
        parts.append("<p>No noise figures: see the test record.</p>")
    if has_gmwm(unit):
        parts.append(gmwm_section(unit))
        parts.append(_img(gmwm_png(unit), "Haar wavelet variance with its interval, the GMWM "
                                          "model and the Allan fit's model as a wavelet variance"))
    if unit.sequence is not None:
        parts.append(sequence_section(unit.sequence))
    said = sheet.verdict_lines()
    parts.append(f'<h2>Verdict</h2><p class="verdict"><b>{escape(said[0])}</b><br>'
                 + "<br>".join(escape(line) for line in said[1:]) + "</p>")
    if head is not None and head.approval:
        parts.append(
            '<table class="approval"><tr>'
            + "".join(f"<th>{escape(label)}</th>" for label in head.approval)
            + "</tr><tr>"
            + "<td>name, date, signature</td>" * len(head.approval)
            + "</tr></table>"
        )
    footer = _footer(graded, sheet)
    parts += [footer, f'<div class="test-record">{company}<h1>{escape(sheet.title)}: test '
                      f"record</h1>"]
    for heading, lines in sheet.record_sections():
        parts.append(f'<h2>{escape(heading)}</h2><ul class="{escape(heading.lower())}">')
        parts += [f"<li>{escape(line)}</li>" for line in lines]
        parts.append("</ul>")
    parts += [footer, "</div>"]
    parts.append("</section>")
    return "\n".join(parts)


def _footer(graded: RunGrade, sheet: UnitSheet) -> str:
    """The footer of each part of a unit's section: the company and the test as it was
    run, the software."""
    company = graded.sheet.company if graded.sheet is not None else ""
    return (f'<footer class="test">{escape(company) + " - " if company else ""}'
            f"{escape(sheet.test)}<br>{escape(sheet.title)} - generated by gyro-station "
            f"{escape(graded.software_version)}</footer>")


def sequence_section(seq: UnitSequence) -> str:
    """The test sequence's figures table (``<table class="sequence">``, rows with
    ``data-figure`` and ``data-verdict``) and its three plots."""
    parts = [f"<h2>Test sequence {escape(seq.sequence)}: {len(seq.cycles)} switch-on(s)"
             + (f", grade {escape(seq.grade)}" if seq.grade else "") + "</h2>",
             '<table class="sequence"><tr><th>figure</th><th>unit</th><th>value</th>'
             "<th>confidence interval</th><th>limit</th><th>grade</th><th>verdict</th>"
             "<th>note</th></tr>"]
    for r in sequence_rows(seq):
        verdict = r.verdict or "info"
        parts.append(
            f'<tr class="{verdict}" data-figure="{escape(r.name)}" data-verdict="{verdict}">'
            f"<td>{escape(r.label)}</td><td>{escape(r.unit)}</td>"
            f'<td class="num">{fmt(r.value)}</td>'
            f'<td class="num">{fmt_interval(r.ci_low, r.ci_high)}</td>'
            f'<td class="num">{fmt(r.limit) if r.verdict else ""}</td><td>{escape(r.grade)}</td>'
            f'<td class="verdict">{verdict}</td><td>{escape(r.note)}</td></tr>')
    parts.append("</table>")
    parts.append(_img(sequence_png(seq), "bias per switch-on, warm-up curves, bias against "
                                         "temperature"))
    if seq.plateaus:
        parts.append("<h2>Temperature plateaus</h2>"
                     '<table class="plateaus"><tr>'
                     + "".join(f"<th>{escape(h)}</th>" for h in plateau_headings())
                     + "<th>note</th></tr>")
        for p in seq.plateaus:
            cells = plateau_cells(p)
            parts.append(f'<tr data-axis="{escape(p.axis)}" data-set-point="{p.set_point_c:g}">'
                         f"<td>{escape(cells[0])}</td>"
                         + "".join(f'<td class="num">{escape(c)}</td>' for c in cells[1:])
                         + f"<td>{escape(p.note)}</td></tr>")
        parts.append("</table>")
        parts.append(_img(plateau_png(seq.plateaus), "Allan deviation of each temperature "
                                                     "plateau"))
    return "\n".join(parts)


def write_html(graded: RunGrade, path: str | Path) -> Path:
    """Write one self-contained HTML file with a section per unit."""
    path = Path(path)
    body = "\n".join(unit_section(graded, u) for u in graded.units)
    title = escape(f"Spec sheets {graded.profile.ref}: {Path(graded.run.path).name}")
    path.write_text(
        f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{title}</title>'
        f"<style>{CSS}</style></head>\n<body>\n{body}\n</body></html>\n",
        encoding="utf-8",
    )
    return path
