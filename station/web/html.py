"""The pieces every page is built of: the frame (title, navigation, units switch, style),
escaped text, numbers with their exact value for machines, links and tables.

Every text from the database (a serial, a lot, a profile name, a figure name) goes through
:func:`text` (HTML-escaped, quotes too) and every URL path segment through :func:`segment`
(percent-encoded): markup in a serial is shown, never run.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from html import escape
from urllib.parse import quote, urlencode

from analysis.units.conversions import UnitFamily

STYLE = """
body { font-family: sans-serif; font-size: 11pt; margin: 0 2em 2em; color: #222; }
nav { background: #37474f; margin: 0 -2em 1em; padding: 0.5em 2em; }
nav a { color: white; margin-right: 1.5em; text-decoration: none; font-weight: bold; }
nav span.units { color: #cfd8dc; float: right; }
nav span.units a { margin: 0 0 0 0.7em; font-weight: normal; color: #cfd8dc; }
nav span.units b.active { margin: 0 0 0 0.7em; color: white; background: #546e7a;
  padding: 0.1em 0.5em; border-radius: 3px; }
h1 { font-size: 16pt; } h2 { font-size: 13pt; margin-top: 1.5em; }
table { border-collapse: collapse; margin: 0.5em 0; }
td, th { border: 1px solid #bbb; padding: 0.15em 0.5em; text-align: left; }
th { background: #eee; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.fail td.verdict, td.low { background: #f5c2c2; } tr.pass td.verdict { background: #c8e6c9; }
tr.indeterminate td.verdict { background: #ffe082; }
form.filters label { margin-right: 1em; } img.chart { max-width: 100%; }
iframe.sheet { width: 100%; height: 60em; border: 1px solid #bbb; }
p.note { font-size: 9pt; color: #555; } .damaged { color: #b71c1c; }
svg.chart { display: block; margin: 0.5em 0; } table.units td { white-space: nowrap; }
.state { padding: 0.1em 0.5em; border-radius: 3px; }
.state.live { background: #c8e6c9; } .state.gone { background: #f5c2c2; }
.state.finished { background: #e0e0e0; } progress { width: 6em; vertical-align: middle; }
p.rendering { background: #fff8e1; border: 1px solid #ffe082; padding: 0.4em 0.8em; }
"""


def text(value: object) -> str:
    """``value`` as HTML text: markup escaped, quotes too (safe inside an attribute)."""
    return escape("" if value is None else str(value), quote=True)


def segment(value: str) -> str:
    """``value`` as one URL path segment (every reserved character percent-encoded)."""
    return quote(value, safe="")


def number(value: float | None, family: UnitFamily | None = None, unit: str = "",
           digits: int = 4) -> str:
    """A ``<td class="num">`` of ``value`` (in ``family`` when given): ``digits``
    significant digits shown, the exact value in ``data-value`` (empty when missing)."""
    if value is not None and family is not None:
        value = family.value(value, unit)
    shown = "-" if value is None else f"{value:.{digits}g}"
    exact = "" if value is None else repr(float(value))
    return f'<td class="num" data-value="{exact}">{shown}</td>'


def clock(seconds: float | None, decimals: int = 1) -> str:
    """A duration as ``h:mm:ss.s`` (``mm:ss.s`` under an hour; ``decimals`` digits of the
    second, at most 3); ``-`` when there is none. ``static/live.js`` writes it alike."""
    if seconds is None:
        return "-"
    scale = 10 ** decimals
    total = round(max(0.0, float(seconds)) * scale)
    h, rest = divmod(total, 3600 * scale)
    m, s = divmod(rest, 60 * scale)
    sec = f"{s / scale:0{3 + decimals if decimals else 2}.{decimals}f}"
    return f"{h}:{m:02d}:{sec}" if h else f"{m}:{sec}"


def utc(stamp: str | None, zone: bool = True) -> str:
    """An ISO 8601 UTC time stamp (``2026-06-01T08:00:00.123456Z``) to the second,
    ``2026-06-01 08:00:00 UTC`` (without `` UTC`` where not ``zone``: a column that says
    so); ``-`` when there is none. ``static/live.js`` writes it alike."""
    if not stamp:
        return "-"
    if len(stamp) < 19 or stamp[10] != "T":
        return stamp
    return stamp[:19].replace("T", " ") + (" UTC" if zone else "")


def interval(ci: Iterable[float] | None, family: UnitFamily | None = None,
             unit: str = "") -> str:
    """A ``<td>`` of an interval ``[low, high]`` (``-`` when there is none)."""
    if ci is None:
        return '<td class="num">-</td>'
    low, high = (family.value(v, unit) if family is not None else v for v in ci)
    return f'<td class="num">[{low:.3g}, {high:.3g}]</td>'


def link(href: str, label: object, **attrs: str) -> str:
    """``<a href=...>label</a>`` (``label`` escaped; ``attrs`` as ``data-*`` and so on)."""
    extra = "".join(f' {k.replace("_", "-")}="{text(v)}"' for k, v in attrs.items())
    return f'<a href="{text(href)}"{extra}>{text(label)}</a>'


def query(params: Mapping[str, str | None]) -> str:
    """``?a=1&b=2`` of the parameters given (empty when none is)."""
    given = {k: v for k, v in params.items() if v}
    return "?" + urlencode(given) if given else ""


def table(header: Iterable[str], rows: Iterable[str], css_class: str = "") -> str:
    """A table of ``header`` (escaped) over ``rows`` (each a ready ``<tr>``)."""
    head = "".join(f"<th>{text(h)}</th>" for h in header)
    cls = f' class="{text(css_class)}"' if css_class else ""
    return f"<table{cls}><tr>{head}</tr>{''.join(rows)}</table>"


def page(title: str, body: str, *, family: UnitFamily, here: str,
         refresh_s: float | None = None, script: str | None = None) -> str:
    """A whole page: navigation, the units switch (``here`` is this page's path and query
    without ``units``), ``body``; ``refresh_s`` reloads it (meta refresh), ``script`` loads
    a script of this server."""
    sep = "&" if "?" in here else "?"
    switch = " ".join(
        f'<b class="active" aria-current="true">{name}</b>' if family.name == name
        else link(f"{here}{sep}units={name}", name)
        for name in ("deg", "rad"))
    meta = f'<meta http-equiv="refresh" content="{refresh_s:g}">' if refresh_s else ""
    tag = f'<script src="{text(script)}" defer></script>' if script else ""
    keep = "" if family.name == "deg" else f"?units={family.name}"
    return (
        f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">{meta}'
        f"<title>{text(title)}</title><style>{STYLE}</style>{tag}</head><body>"
        f'<nav><a href="/{keep}">Line overview</a><a href="/runs{keep}">Runs in progress</a>'
        f'<span class="units">units: {switch}</span></nav>'
        f"<h1>{text(title)}</h1>\n{body}\n</body></html>\n"
    )
