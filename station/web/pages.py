"""The pages' bodies, server-rendered from the services' JSON documents (the same numbers
``/api/...`` gives): line overview, a figure's page, a unit's page, runs in progress, and
the page saying the database cannot be read."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from analysis.units.conversions import UnitFamily
from station.evaluation.capability import CAPABILITY_NOTE
from station.web.charts import capability_chart, yield_chart
from station.web.html import clock, interval, link, number, query, segment, table, text, utc

#: Seconds the database-unavailable page waits before it tries again.
RETRY_S = 10.0
#: Seconds between two polls of a runs-in-progress page.
POLL_S = 2.0


def _select(name: str, choices: Sequence[str], chosen: str | None) -> str:
    options = ['<option value="">all</option>'] + [
        f'<option value="{text(c)}"{" selected" if c == chosen else ""}>{text(c)}</option>'
        for c in choices]
    return f'<label>{name} <select name="{name}">{"".join(options)}</select></label>'


def _filters_form(doc: Mapping[str, Any], family: UnitFamily) -> str:
    f = doc["filters"]
    dates = "".join(
        f'<label>{name} <input type="date" name="{name}" value="{text(f[name] or "")}"></label>'
        for name in ("since", "until"))
    lot = f'<label>lot <input name="lot" value="{text(f["lot"] or "")}" size="10"></label>'
    units = f'<input type="hidden" name="units" value="{family.name}">'
    return (f'<form class="filters" method="get" action="/">{dates}'
            f'{_select("model", doc["models"], f["model"])}{lot}'
            f'{_select("station", doc["stations"], f["station"])}'
            f'{_select("operator", doc["operators"], f["operator"])}{units}'
            '<button type="submit">show</button></form>')


def _unit_link(serial: str, family: UnitFamily) -> str:
    return link(f"/units/{segment(serial)}{query({'units': _units(family)})}", serial,
                data_serial=serial)


def _units(family: UnitFamily) -> str | None:
    return None if family.name == "deg" else family.name


def overview_body(doc: Mapping[str, Any], stats: Sequence[Mapping[str, Any]],
                  family: UnitFamily) -> str:
    """Filters, yield per model and lot, per model the capability of each figure (``stats``:
    each model's ``results --stats --model M --json`` document of the filter's lot and
    first date; the models never pooled), the newest gradings."""
    lots = [
        f'<tr data-model="{text(r["model"])}" data-lot="{text(r["lot"])}">'
        f'<td>{text(r["model"])}</td><td>{text(r["lot"] or "-")}</td>'
        f'<td class="num">{r["total"]}</td><td class="num">{r["passed"]}</td>'
        f'<td class="num">{r["failed"]}</td><td class="num">{r["indeterminate"]}</td>'
        f'{number(100 * r["yield"], digits=3)}'
        f'{interval([100 * v for v in r["yield_ci"]] if r["yield_ci"] else None)}'
        f'<td>{text(", ".join(f"{g}: {n}" for g, n in r["grades"].items()))}</td></tr>'
        for r in doc["lots"]]
    gradings = [
        f'<tr class="{text(g["verdict"])}" data-grading="{g["id"]}">'
        f'<td>{text(utc(g["test_date"], zone=False))}</td>'
        f'<td>{_unit_link(g["serial_number"], family)}</td><td>{text(g["model"])}</td>'
        f'<td>{text(g["lot"] or "-")}</td><td>{text(g["grade"])}</td>'
        f'<td class="verdict">{text(g["verdict"])}</td><td>{text(g["profile"])}</td>'
        f'<td>{"REVIEW" if g["review"] else "-"}</td></tr>'
        for g in doc["gradings"]]
    return "\n".join([
        _filters_form(doc, family),
        "<h2>Yield per model and lot</h2>",
        yield_chart(doc["lots"]),
        table(["model", "lot", "units", "pass", "fail", "indeterminate", "yield %",
               "95 % interval (Wilson) %", "grades"], lots, "lots"),
        '<p class="note">The latest grading of each unit the filters select.</p>',
        "<h2>Capability per model</h2>",
        *([_capability_section(s, family) for s in stats]
          or ["<p>No graded unit the filters select.</p>"]),
        f'<p class="note">Model, lot and "since" select these units (as station results '
        f"--stats); each model apart, against its own profile; {text(CAPABILITY_NOTE)}</p>",
        "<h2>Last graded units</h2>",
        table(["test date (UTC)", "serial", "model", "lot", "grade", "verdict", "profile",
               "review"], gradings, "gradings"),
    ])


def _capability_section(stats: Mapping[str, Any], family: UnitFamily) -> str:
    """One model's yield per grade and capability table (``stats``: its ``results --stats
    --model M --json`` document), its figures linked to their pages of that model."""
    scope = {"model": stats["model"], "lot": stats["lot"], "since": stats["since"],
             "units": _units(family)}
    figures = [
        f'<tr data-figure="{text(name)}"><td>'
        f'{link(f"/figures/{segment(name)}{query(scope)}", name)}</td>'
        f'<td>{text(family.label(f["unit"]))}</td><td class="num">{f["n"]}</td>'
        f'{number(f["mean"], family, f["unit"])}{number(f["std"], family, f["unit"])}'
        f'{number(f["limit"], family, f["unit"])}{number(f["cpk"], digits=3)}'
        f'{interval(f["cpk_ci"])}{number(f["cpk_fitted"], digits=3)}'
        f'<td class="num">{len(f["out_of_control"])}</td></tr>'
        for name, f in stats["figures"].items()]
    grade_rows = [f'<tr data-grade="{text(g)}"><td>{text(g)}</td>'
                  f'{number(100 * share, digits=3)}</tr>' for g, share in stats["yield"].items()]
    return "\n".join([
        f'<section class="model" data-model="{text(stats["model"])}">',
        f"<h3>{text(stats['model'])}: {stats['units']} units, profile "
        f"{text(stats['profile'] or '-')}</h3>",
        table(["grade", "share %"], grade_rows, "grades"),
        capability_chart(stats),
        table(["figure", "unit", "n", "mean", "std", "limit", "Ppk (upper)", "95 % CI",
               "Ppk fitted", "out of control"], figures, "capability"),
        "</section>",
    ])


RULE_TEXT = {
    "beyond_3_sigma": "beyond a control limit (3 sigma)",
    "2_of_3_beyond_2_sigma": "2 of 3 in a row beyond 2 sigma, one side",
    "4_of_5_beyond_1_sigma": "4 of 5 in a row beyond 1 sigma, one side",
    "8_on_one_side": "8 in a row on one side of the centre line",
}


def figures_body(doc: Mapping[str, Any], scope: Mapping[str, str | None],
                 family: UnitFamily) -> str:
    """A figure's page: of the filter's model (``doc``:
    :func:`station.services.line.figure_json`), or, without one, a section per model that
    grades it (``doc``: ``{"name", "models": {model: figure_json}}``), each with its own
    limits, control chart and run rules."""
    if "models" not in doc:
        return figure_body(doc, scope, family)
    sections = [
        f'<section class="model" data-model="{text(model)}"><h2>Model {text(model)}</h2>\n'
        + figure_body(f, {**scope, "model": model}, family, heading="h3") + "</section>"
        for model, f in doc["models"].items()]
    return "\n".join([
        f'<p class="note">{len(sections)} models grade {text(doc["name"])}: each has its own '
        "section, against its own profile's limits, with its own control chart and run rules "
        "(never pooled).</p>", *sections])


def figure_body(f: Mapping[str, Any], scope: Mapping[str, str | None],
                family: UnitFamily, heading: str = "h2") -> str:
    """A figure's capability with intervals, its control chart and histogram, the run
    rules' flags and its trend over lots (``f``: :func:`station.services.line.figure_json`
    of one model; ``heading``: the tag of its sections' headings)."""
    u = f["unit"]
    limits = ", ".join(f"{g} {family.value(v, u):.4g}"
                       for g, v in zip(f["limit_grades"], f["limits"], strict=True))
    cap = [
        f"<tr><td>{text(family.label(u))}</td><td class=\"num\">{f['n']}</td>"
        f"{number(f['mean'], family, u)}{number(f['std'], family, u)}<td>{text(limits)}</td>"
        f"{number(f['cpu'], digits=3)}{number(f['cpk'], digits=3)}{interval(f['cpk_ci'])}"
        f"{number(f['cpk_fitted'], digits=3)}{interval(f['cpk_fitted_ci'])}"
        f"<td>{text(f['fitted_distribution'] or '-')}</td>"
        f"{number(f['center'], family, u)}{number(f['ucl'], family, u)}"
        f"{number(f['lcl'], family, u)}</tr>"]
    rules = []
    for rule, flagged in f["run_rules"].items():
        who = ", ".join(f"{f['values'][i]['serial_number']} {f['values'][i]['axis'] or 'unit'}"
                        for i in flagged)
        rules.append(f'<tr data-rule="{text(rule)}"><td>{text(RULE_TEXT[rule])}</td>'
                     f'<td class="num">{len(flagged)}</td><td>{text(who or "-")}</td></tr>')
    charts = query({"model": scope.get("model"), "lot": scope.get("lot"),
                    "since": scope.get("since")})
    base = f"/figures/{segment(f['name'])}"
    return "\n".join([
        f"<p>Units of {text(scope.get('model') or 'all models')}, "
        f"{text(scope.get('lot') or 'all lots')}"
        + (f", tested since {text(scope['since'])}" if scope.get("since") else "")
        + " (the latest grading of each unit).</p>",
        table(["unit", "n", "mean", "std", "limits", "Cpu", "Ppk (upper)", "95 % CI",
               "Ppk fitted", "95 % CI", "fit", "centre", "UCL", "LCL"], cap, "capability"),
        f'<p class="note">{text(CAPABILITY_NOTE)}</p>',
        f"<{heading}>Control chart and histogram</{heading}>",
        f'<img class="chart control-chart" data-model="{text(scope.get("model") or "")}" '
        f'src="{text(base + "/chart.svg" + charts)}" '
        f'alt="histogram against the limits and individuals control chart of '
        f'{text(f["name"])}">',
        '<p class="note">Values in the unit the database stores (the figure\'s deg unit).</p>',
        f"<{heading}>Run rules</{heading}>",
        table(["rule (Western Electric)", "values flagged", "units"], rules, "run-rules"),
        f"<{heading}>Trend over lots</{heading}>",
        f'<img class="chart" src="{text(base + "/trend.svg" + charts)}" '
        f'alt="{text(f["name"])} per lot">',
    ])


def unit_body(doc: Mapping[str, Any], family: UnitFamily, sheet_url: str | None,
              rendering: bool = False) -> str:
    """A unit's gradings (newest first), its latest grading's figures (a test sequence's
    too) and its spec sheet in a frame; ``rendering``: the sheet is not rendered yet, and a
    note says it is being rendered until the frame has loaded (``static/sheet.js``)."""
    history = [
        f'<tr class="{text(g["verdict"])}" data-grading="{g["id"]}"><td>{g["id"]}</td>'
        f'<td>{text(utc(g["test_date"], zone=False))}</td><td>{text(g["model"])}</td>'
        f'<td>{text(g["lot"] or "-")}</td><td>{text(g["grade"])}</td>'
        f'<td class="verdict">{text(g["verdict"])}</td><td>{text(g["profile"])}</td>'
        f'<td>{text(g["run_path"])} ({text(g["run_unit"])})</td><td>{g["revision"]}</td>'
        f'<td>{text(g["review"] or "-")}</td></tr>'
        for g in reversed(doc["gradings"])]
    latest = doc["gradings"][-1]
    figures = [
        f'<tr class="{text(x["verdict"] or "info")}" data-figure="{text(x["name"])}" '
        f'data-axis="{text(x["axis"])}"><td>{text(x["axis"] or "sequence")}</td>'
        f'<td>{text(x["name"])}</td><td>{text(family.label(x["unit"]))}</td>'
        f'{number(x["value"], family, x["unit"])}'
        f'{interval(_ci(x), family, x["unit"])}{number(x["limit"], family, x["unit"])}'
        f'<td class="verdict">{text(x["verdict"] or "info")}</td></tr>'
        for x in latest["figures"]]
    busy = ('<p class="rendering" id="sheet-rendering">Rendering the spec sheet of this '
            "grading (its plots are drawn afresh on a first view, which takes several "
            "seconds); it appears below when ready.</p>" if rendering else "")
    sheet = (f'<p>{link(sheet_url, "open the spec sheet alone", id="sheet-link")}</p>{busy}'
             f'<iframe class="sheet" sandbox src="{text(sheet_url)}" title="spec sheet">'
             "</iframe>" if sheet_url else "<p>No grading to show a sheet of.</p>")
    return "\n".join([
        "<h2>Gradings</h2>",
        table(["id", "test date (UTC)", "model", "lot", "grade", "verdict", "profile", "run",
               "revision", "review"], history, "history"),
        f"<h2>Figures of grading {latest['id']} (axis 'sequence': the test sequence's)</h2>",
        table(["axis", "figure", "unit", "value", "interval", "limit", "verdict"], figures,
              "figures"),
        "<h2>Spec sheet</h2>", sheet,
    ])


def _ci(x: Mapping[str, Any]) -> list[float] | None:
    return None if x["ci_low"] is None or x["ci_high"] is None else [x["ci_low"], x["ci_high"]]


def allan_svg(curve: Mapping[str, Any], width: int = 320, height: int = 200) -> str:
    """A unit's live Allan deviation as a small log-log SVG (one polyline per axis, the
    ranges of tau and of the deviation written in its corners); the page's script redraws
    it from ``/api/runs`` the same way (``static/live.js``)."""
    tau = curve["tau_s"]
    lines = []
    values = [v for axis in curve["adev_deg_h"] for v in axis if v]
    corners = {"adev-max": "", "adev-min": "", "tau-range": ""}
    if tau and values:
        from math import log10

        x0, x1 = log10(min(tau)), log10(max(tau)) + 1e-9
        y0, y1 = log10(min(values)), log10(max(values)) + 1e-9
        for i, axis in enumerate(curve["adev_deg_h"]):
            pts = " ".join(
                f"{(log10(t) - x0) / (x1 - x0) * (width - 10) + 5:.1f},"
                f"{height - 5 - (log10(v) - y0) / (y1 - y0) * (height - 10):.1f}"
                for t, v in zip(tau, axis, strict=True) if v)
            lines.append(f'<polyline fill="none" stroke="{AXIS_COLORS[i % 3]}" '
                         f'points="{pts}"></polyline>')
        corners = {"adev-max": f"{max(values):.3g} deg/h", "adev-min": f"{min(values):.3g} deg/h",
                   "tau-range": f"tau {min(tau):.3g} to {max(tau):.3g} s"}
    places = {"adev-max": (6, 14, "start"), "adev-min": (6, height - 8, "start"),
              "tau-range": (width - 6, height - 8, "end")}
    labels = "".join(
        f'<text class="{name}" x="{x}" y="{y}" text-anchor="{anchor}" font-size="10" '
        f'fill="#555">{text(corners[name])}</text>' for name, (x, y, anchor) in places.items())
    return (f'<svg class="allan" data-unit="{text(curve["unit"])}" width="{width}" '
            f'height="{height}" viewBox="0 0 {width} {height}">'
            f'<rect width="{width}" height="{height}" fill="#fafafa" stroke="#bbb"></rect>'
            + labels + "".join(lines) + "</svg>")


AXIS_COLORS = ("#1565c0", "#2e7d32", "#c62828")
#: The unit columns of the runs page: the JSON field, its header, how it is written
#: (``static/live.js`` writes each format alike: ``clock``, h:mm:ss, tenths under a
#: minute; ``countdown``, h:mm:ss; ``percent``; ``number``).
UNIT_COLUMNS = (("model", "model", "text"), ("serial_number", "serial", "text"),
                ("progress", "progress", "percent"), ("time_left_s", "time left", "countdown"),
                ("t_s", "recorded (run time)", "clock"), ("samples_recorded", "samples", "number"),
                ("sample_rate_hz", "rate Hz", "number"), ("gaps", "gaps", "number"),
                ("samples_missing_declared", "missing", "number"),
                ("crc_errors", "CRC errors", "number"), ("reconnects", "reconnects", "number"))


def run_phase(run: Mapping[str, Any]) -> str:
    """``live`` (being recorded by a running recorder), ``gone`` (the file says recording
    but its recorder is gone) or ``finished`` (stopped or interrupted)."""
    if run["state"] != "recording":
        return "finished"
    return "gone" if run["recorder_gone"] else "live"


def _shown(value: object, how: str) -> str:
    if value is None:
        return "-"
    if how in ("clock", "countdown"):
        seconds = float(value)  # type: ignore[arg-type]
        return clock(seconds, 0 if how == "countdown" or seconds >= 60 else 1)
    if how == "percent":
        return f"{100 * float(value):.0f} %"  # type: ignore[arg-type]
    if how == "number" and isinstance(value, float):
        return f"{value:g}"
    return text(value)


def _state_text(run: Mapping[str, Any]) -> str:
    phase = run_phase(run)
    if phase == "live":
        return "recording"
    if phase == "gone":
        return "recorder gone: the file was left open (interrupted)"
    stop = f" at {utc(run['stop_utc'])}" if run.get("stop_utc") else ""
    why = f" ({run['stop_reason']})" if run.get("stop_reason") else ""
    return f"{run['state']}{stop}{why}"


def _run_section(run: Mapping[str, Any]) -> str:
    curves = {c["unit"]: c for c in run["allan"]}
    rows = []
    for u in run["units"]:
        cells = []
        for key, _, how in UNIT_COLUMNS:
            css = "" if how == "text" else ' class="num"'
            shown = f'<span data-field="{key}" data-format="{how}">{_shown(u.get(key), how)}</span>'
            if key == "progress" and u.get("progress") is not None:
                shown = (f'<progress data-bar="progress" max="1" value="{u["progress"]}">'
                         f"</progress> {shown}")
            cells.append(f"<td{css}>{shown}</td>")
        rows.append(f'<tr data-unit="{text(u["unit"])}"><td>{text(u["unit"])}</td>'
                    + "".join(cells) + f"<td>{allan_svg(curves[u['unit']])}</td></tr>")
    phase = run_phase(run)
    about = ", ".join(f"{name} {text(run.get(key))}" for key, name in
                      (("lot", "lot"), ("operator", "operator")) if run.get(key))
    if run.get("start_utc"):
        about += (", " if about else "") + f"started {utc(run['start_utc'])}"
    planned = run.get("duration_requested_s")
    if planned:
        about += (", " if about else "") + f"duration requested {clock(planned, 0)}"
    return (
        f'<section class="run {phase}" data-run="{text(run["run"])}" data-phase="{phase}">'
        f'<h3>{text(run["run"].rsplit("/", 1)[-1])}</h3>'
        f'<p>state: <span class="state {phase}" data-field="state_text">'
        f'{text(_state_text(run))}</span>; last flush '
        f'<span data-field="last_flush_utc">{text(utc(run["last_flush_utc"]))}</span>'
        + (f' <span class="damaged">{text(run["advice"])}</span>' if run["advice"] else "")
        + f'</p><p class="note">{text(run["run"])}{"; " + about if about else ""}</p>'
        + table(["unit", *(h for _, h, _ in UNIT_COLUMNS), "Allan deviation"], rows, "units")
        + "</section>")


def runs_body(doc: Mapping[str, Any]) -> str:
    """The run files under ``--runs``: those being recorded first (per unit its model,
    serial, progress, time left and counts, the live Allan deviation), then the finished
    ones and those whose recorder is gone, then the damaged files with the reason. The
    page's script keeps the numbers and curves current (``data-run``, ``data-unit``,
    ``data-field`` name the cells) and reloads when a run starts or ends."""
    parts = [f'<p class="note">Refreshed every {POLL_S:g} s from '
             f'{link("/api/runs", "/api/runs")}; times as h:mm:ss (time left in wall-clock '
             "time); Allan deviation in deg/h against tau (log-log; x blue, y green, "
             "z red).</p>"]
    if not doc["runs"] and not doc["damaged"]:
        parts.append("<p>No run files under the folders given to --runs.</p>")
    live = [r for r in doc["runs"] if run_phase(r) == "live"]
    ended = [r for r in doc["runs"] if run_phase(r) != "live"]
    if doc["runs"]:
        parts.append("<h2>Recording now</h2>")
        parts.extend(_run_section(r) for r in live)
        if not live:
            parts.append('<p id="none-live">No run is being recorded.</p>')
    if ended:
        parts.append("<h2>Finished, or recorder gone</h2>")
        parts.extend(_run_section(r) for r in ended)
    if doc["damaged"]:
        parts.append("<h2>Damaged run files</h2><ul class=\"damaged\">" + "".join(
            f'<li data-run="{text(d["run"])}">{text(d["run"])}: {text(d["reason"])}</li>'
            for d in doc["damaged"]) + "</ul>")
    return "\n".join(parts)


def unavailable_body(reason: str) -> str:
    """The database cannot be read: why, and that the page tries again."""
    return (f'<p class="damaged" id="unavailable">{text(reason)}</p>'
            f"<p>This page tries again every {RETRY_S:g} s.</p>")
