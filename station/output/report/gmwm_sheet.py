"""The spec sheet's GMWM page: each axis' GMWM terms beside the Allan read-offs, and the
wavelet variance with both models' curves.

Shown when the report service added the GMWM to the graded axes
(:mod:`station.evaluation.gmwm_run`): per axis a table of the GMWM terms (value, unit,
standard error) with the Allan figure of the same term where there is one (the ARW and
bias-instability read-offs, the fitted Q, K and R; a Gauss-Markov term has none), one
line with the selected model, its J test and the ranking's runner-up, and a plot of the
empirical Haar wavelet variance with its interval, the GMWM model's WV and the Allan
fit's model as a WV (AVAR / 2). :func:`gmwm_page` is the PDF page, :func:`gmwm_section`
the HTML table (:func:`gmwm_png` the plot under it); the rows themselves come from
:mod:`station.output.report.gmwm_terms`.
"""

from __future__ import annotations

import textwrap
from html import escape

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.transforms import Bbox  # noqa: E402

from station.evaluation.grading import UnitGrade  # noqa: E402
from station.output.plots import draw_wavelet  # noqa: E402
from station.output.report.common import fmt  # noqa: E402
from station.output.report.gmwm_terms import (  # noqa: E402
    fitted_axes,
    gmwm_rows,
    gmwm_summary,
    has_gmwm,
)
from station.output.report.panels import figure_png  # noqa: E402
from station.output.report.pdf_page import CONTENT_TOP, subtitle  # noqa: E402

__all__ = ["gmwm_page", "gmwm_png", "gmwm_section", "has_gmwm"]

def gmwm_page(unit: UnitGrade, size_in: tuple[float, float]) -> Figure:
    """The PDF page of a unit's GMWM: the table, the model lines and a plot per axis (the
    sheet's header and footer are drawn on it by :mod:`station.output.report.pdf`)."""
    fig = plt.figure(figsize=size_in)
    subtitle(fig, "GMWM noise model")
    axes = fitted_axes(unit)
    rows = [r for a in axes for r in gmwm_rows(a)]
    cells = [[r.axis, r.term, r.unit, fmt(r.value), fmt(r.stderr), r.allan or "-"] for r in rows]
    row_h = min(0.016, 0.30 / (len(rows) + 1))
    top = CONTENT_TOP
    height = row_h * (len(rows) + 1)
    tax = fig.add_axes((0.06, top - height, 0.88, height))
    tax.axis("off")
    table = tax.table(cellText=cells, colLabels=["axis", "GMWM term", "unit", "value",
                                                 "std. error", "Allan figure, same term"],
                      colWidths=[0.06, 0.3, 0.13, 0.11, 0.11, 0.29],
                      bbox=Bbox.from_bounds(0, 0, 1, 1), cellLoc="center")
    table.auto_set_font_size(False)
    table.set_fontsize(7.5)
    for (row, _col), cell in table.get_celld().items():
        cell.set_linewidth(0.3)
        if row == 0:
            cell.set_text_props(weight="bold")
            cell.set_facecolor("#e6e6e6")
    lines = [part for a in axes for part in textwrap.wrap(gmwm_summary(a), 130,
                                                          subsequent_indent="  ")]
    y = top - height - 0.012
    fig.text(0.06, y, "\n".join(lines), fontsize=7, va="top", linespacing=1.3)
    plot_top = y - 0.014 * len(lines) - 0.04
    n = max(len(axes), 1)
    gap = 0.06
    each = (plot_top - 0.08 - gap * (n - 1)) / n
    for i, a in enumerate(axes):
        bottom = plot_top - (i + 1) * each - i * gap
        draw_wavelet(fig.add_axes((0.12, bottom, 0.82, each)), a.analysis, fontsize=7,
                     title="Haar wavelet variance, GMWM model (solid) and Allan fit (dashed):")
    return fig


def gmwm_png(unit: UnitGrade) -> bytes:
    """The wavelet-variance plot of every fitted axis of ``unit`` as a PNG."""
    axes = fitted_axes(unit)
    fig, panels = plt.subplots(len(axes), 1, figsize=(8, 4.2 * len(axes)), squeeze=False,
                               layout="constrained")
    for ax, a in zip(panels[:, 0], axes, strict=True):
        draw_wavelet(ax, a.analysis, fontsize=8, title="Haar wavelet variance:")
    return figure_png(fig)


def gmwm_section(unit: UnitGrade) -> str:
    """The HTML of a unit's GMWM table: ``<table class="gmwm">`` (a ``<tr>`` per axis and
    parameter with ``data-axis``, ``data-key`` and ``data-value``) and the model lines; the
    writer adds :func:`gmwm_png` under it."""
    parts = ["<h2>GMWM noise model</h2>",
             '<table class="gmwm"><tr><th>axis</th><th>GMWM term</th><th>unit</th>'
             "<th>value</th><th>std. error</th><th>Allan figure, same term</th></tr>"]
    axes = fitted_axes(unit)
    for r in (r for a in axes for r in gmwm_rows(a)):
        parts.append(
            f'<tr data-axis="{escape(r.axis)}" data-key="{escape(r.key)}" '
            f'data-value="{"" if r.value is None else repr(r.value)}">'
            f"<td>{escape(r.axis)}</td><td>{escape(r.term)}</td><td>{escape(r.unit)}</td>"
            f'<td class="num">{fmt(r.value)}</td><td class="num">{fmt(r.stderr)}</td>'
            f"<td>{escape(r.allan or '-')}</td></tr>")
    parts.append('</table><ul class="gmwm">')
    parts += [f"<li>{escape(gmwm_summary(a))}</li>" for a in axes]
    parts.append("</ul>")
    return "\n".join(parts)
