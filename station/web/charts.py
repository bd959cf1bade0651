"""The overview's charts as inline SVG text, drawn from the same JSON documents as its
tables (no image request, no script): the yield of each lot with its 95 % interval
(:func:`yield_chart`), and each model's capability, Ppk of each figure with its interval
(:func:`capability_chart`). Every text from the database goes through
:func:`station.web.html.text`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from math import isfinite, log10
from typing import Any

from station.web.html import text

#: Ppk references drawn on the capability chart: 1.0 (limit at 3 sigma from the mean) and
#: 1.33 (4 sigma), the customary minimum of a capable process (AIAG, Statistical Process
#: Control, 2nd ed., ch. IV).
PPK_REFERENCES = (1.0, 1.33)
#: The capability chart's logarithmic Ppk axis: from PPK_AXIS_MIN to the largest Ppk or
#: interval end (at least PPK_AXIS_LEAST, at most PPK_AXIS_MAX); one outside is drawn at
#: the edge, its value written with ``<`` or ``>``.
PPK_AXIS_MIN, PPK_AXIS_LEAST, PPK_AXIS_MAX = 0.3, 4.0, 1000.0
PPK_TICKS = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0)
INK = "#37474f"
GOOD, BAD = "#2e7d32", "#c62828"


def _frame(css: str, width: int, height: int, title: str, body: str) -> str:
    return (f'<svg class="chart {css}" role="img" aria-label="{text(title)}" '
            f'width="{width}" height="{height}" viewBox="0 0 {width} {height}" '
            f'xmlns="http://www.w3.org/2000/svg" font-family="sans-serif" font-size="11">'
            f"<title>{text(title)}</title>{body}</svg>")


def yield_chart(lots: Sequence[Mapping[str, Any]], width: int = 760) -> str:
    """Each lot's yield (%, a dot) with its 95 % Wilson interval (a bar) over the lots in
    the overview's order (``lots``: ``/api/overview``'s ``"lots"`` rows), labelled
    ``model lot (n)``; the axis spans from 10 % under the lowest interval to 100 %."""
    if not lots:
        return ""
    height, left, right, top, bottom = 230, 48, 12, 22, 62
    lows = [100 * (r["yield_ci"][0] if r["yield_ci"] else r["yield"]) for r in lots]
    floor = max(0.0, (min(lows) // 10) * 10 - 10) if min(lows) > 10 else 0.0
    plot_w, plot_h = width - left - right, height - top - bottom

    def y(v: float) -> float:
        return top + (100.0 - v) / (100.0 - floor) * plot_h

    step = plot_w / len(lots)
    parts = [f'<text x="{left}" y="14" fill="{INK}">yield % per lot, with its 95 % interval '
             "(Wilson)</text>"]
    for tick in range(int(floor), 101, 10 if 100 - floor > 30 else 5):
        parts.append(f'<line x1="{left}" x2="{width - right}" y1="{y(tick):.1f}" '
                     f'y2="{y(tick):.1f}" stroke="#ddd"></line>'
                     f'<text x="{left - 4}" y="{y(tick) + 4:.1f}" text-anchor="end" '
                     f'fill="#555">{tick}</text>')
    for i, r in enumerate(lots):
        x = left + step * (i + 0.5)
        v = 100 * r["yield"]
        ci = [100 * c for c in r["yield_ci"]] if r["yield_ci"] else [v, v]
        color = GOOD if v >= 100 * 0.95 else INK if v >= 80 else BAD
        label = f'{r["model"]} {r["lot"] or "-"} (n={r["total"]})'
        parts.append(
            f'<g class="lot" data-model="{text(r["model"])}" data-lot="{text(r["lot"])}">'
            f"<title>{text(label)}: yield {v:.1f} %, 95 % interval [{ci[0]:.1f}, "
            f"{ci[1]:.1f}] %</title>"
            f'<line x1="{x:.1f}" x2="{x:.1f}" y1="{y(ci[1]):.1f}" y2="{y(ci[0]):.1f}" '
            f'stroke="{INK}" stroke-width="2"></line>'
            f'<line x1="{x - 6:.1f}" x2="{x + 6:.1f}" y1="{y(ci[1]):.1f}" y2="{y(ci[1]):.1f}" '
            f'stroke="{INK}"></line><line x1="{x - 6:.1f}" x2="{x + 6:.1f}" '
            f'y1="{y(ci[0]):.1f}" y2="{y(ci[0]):.1f}" stroke="{INK}"></line>'
            f'<circle cx="{x:.1f}" cy="{y(v):.1f}" r="5" fill="{color}"></circle>'
            f'<text x="{x + 9:.1f}" y="{y(v) + 4:.1f}" fill="{color}">{v:.1f}</text>'
            f'<text x="{x:.1f}" y="{height - bottom + 16}" text-anchor="middle">'
            f'{text(r["model"])}</text><text x="{x:.1f}" y="{height - bottom + 30}" '
            f'text-anchor="middle">{text(r["lot"] or "-")}</text>'
            f'<text x="{x:.1f}" y="{height - bottom + 44}" text-anchor="middle" '
            f'fill="#555">n={r["total"]}</text></g>')
    parts.append(f'<line x1="{left}" x2="{left}" y1="{top}" y2="{height - bottom}" '
                 f'stroke="{INK}"></line>')
    return _frame("yield-chart", width, height, "yield per lot", "".join(parts))


def capability_chart(stats: Mapping[str, Any], width: int = 760) -> str:
    """One model's Ppk of each figure (a dot) with its 95 % interval (a bar), on a
    logarithmic axis (a line's Ppk spans 0.5 to 100), against the references 1.0 and 1.33
    (``stats``: the model's ``results --stats --json`` document); a figure below 1.33 is
    drawn red; a Ppk off the axis (:data:`PPK_AXIS_MIN`, :data:`PPK_AXIS_MAX`) sits at its
    edge."""
    figures = [(name, f) for name, f in stats["figures"].items()]
    if not figures:
        return ""
    row, left, right, top = 20, 190, 70, 34
    height = top + row * len(figures) + 26
    plot_w = width - left - right
    ends = [v for _, f in figures for v in [f["cpk"], *(f["cpk_ci"] or [])]
            if v is not None and isfinite(v)]
    axis_lo = log10(PPK_AXIS_MIN)
    axis_hi = log10(min(PPK_AXIS_MAX, max([PPK_AXIS_LEAST, *ends]) * 1.2))

    def x(v: float) -> float:
        at = log10(min(max(v, PPK_AXIS_MIN), 10 ** axis_hi))
        return left + (at - axis_lo) / (axis_hi - axis_lo) * plot_w

    parts = [f'<text x="4" y="14" fill="{INK}">{text(stats["model"])}: Ppk (upper) per figure, '
             "with its 95 % interval (log axis); references 1.0 and 1.33</text>"]
    bottom = top + row * len(figures)
    for tick in (t for t in PPK_TICKS if log10(t) <= axis_hi + 1e-9):
        parts.append(f'<line x1="{x(tick):.1f}" x2="{x(tick):.1f}" y1="{top}" y2="{bottom}" '
                     f'stroke="#ddd"></line><text x="{x(tick):.1f}" y="{bottom + 14}" '
                     f'text-anchor="middle" fill="#555">{tick:g}</text>')
    for ref in PPK_REFERENCES:
        color = BAD if ref < PPK_REFERENCES[1] else GOOD
        parts.append(f'<line class="reference" x1="{x(ref):.1f}" x2="{x(ref):.1f}" y1="{top - 4}" '
                     f'y2="{bottom}" stroke="{color}" stroke-dasharray="4 3"></line>'
                     f'<text x="{x(ref):.1f}" y="{top - 6}" text-anchor="middle" '
                     f'font-size="9" fill="{color}">{ref:g}</text>')
    for i, (name, f) in enumerate(figures):
        cy = top + row * (i + 0.5)
        parts.append(f'<text x="{left - 6}" y="{cy + 4:.1f}" text-anchor="end">'
                     f"{text(name)}</text>")
        cpk = f["cpk"]
        if cpk is None or not isfinite(cpk):
            parts.append(f'<text x="{left + 4}" y="{cy + 4:.1f}" fill="#555">no Ppk '
                         "(no limit, or too few values)</text>")
            continue
        color = GOOD if cpk >= PPK_REFERENCES[1] else BAD
        bar = ""
        if f["cpk_ci"]:
            lo, hi = f["cpk_ci"]
            bar = (f'<line x1="{x(lo):.1f}" x2="{x(hi):.1f}" y1="{cy:.1f}" y2="{cy:.1f}" '
                   f'stroke="{INK}" stroke-width="2"></line>')
        parts.append(
            f'<g class="figure" data-figure="{text(name)}"><title>{text(name)}: Ppk '
            f'{cpk:.3g}' + (f', 95 % interval [{f["cpk_ci"][0]:.3g}, {f["cpk_ci"][1]:.3g}]'
                            if f["cpk_ci"] else "") + f' (n={f["n"]})</title>{bar}'
            f'<circle cx="{x(cpk):.1f}" cy="{cy:.1f}" r="5" fill="{color}"></circle>'
            f'<text x="{width - right + 6}" y="{cy + 4:.1f}" fill="{color}">'
            f'{"&gt;" if cpk > 10 ** axis_hi else "&lt;" if cpk < PPK_AXIS_MIN else ""}{cpk:.3g}'
            "</text></g>")
    return _frame("capability-chart", width, height, f"capability of {stats['model']}",
                  "".join(parts))
