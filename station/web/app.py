"""The ASGI application of ``station serve``: read-only pages and their JSON under ``/api``.

Routes (every one GET or HEAD; any other method is answered 405)::

    /                          line overview          /api/overview, /api/stats
    /figures/{name}            a figure's page         /api/figures/{name}
    /figures/{name}/chart.svg, /figures/{name}/trend.svg
    /units/{serial}            a unit's page           /api/units/{serial}
    /sheets/{serial}           its spec sheet (?grading=ID: that grading's)
    /runs                      runs in progress        /api/runs
    /static/live.js            the runs page's script  /static/sheet.js (a unit page's)
    /api                       the index of the API (JSON)

Every page and document takes ``?units=deg|rad`` (``--output-units``); the overview and
the figure pages take the filters ``since``, ``until``, ``model``, ``lot``, ``station``,
``operator``. ``/api/stats`` is ``station results --stats --json`` of ``model``, ``lot``
and ``since``, key for key. Without ``model`` every model has its own capability table,
charts and run rules (never pooled); a chart's URL names its model.

With a token (:class:`ServeConfig`), a request must carry it: ``Authorization: Bearer
TOKEN``, or ``?token=TOKEN`` once (the answer sets a cookie the browser sends after);
without it the answer is 401. Every failure under ``/api`` (400, 401, 404, 405, 503) is
JSON, ``{"error": reason}``; elsewhere it is a page.
"""

from __future__ import annotations

import hmac
import threading
from collections import OrderedDict
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Any, cast

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.middleware.base import BaseHTTPMiddleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import Route

import station.web.pages as pages
from analysis.units.conversions import UnitFamily, unit_family
from station.errors import UsageError
from station.output.json_units import in_family
from station.output.production_stats import FigureStats, StatsByModel
from station.output.results_backends import DatabaseLocation
from station.services.line import (
    DatabaseUnavailableError,
    LineFilter,
    figure_json,
    figure_models_json,
    line_overview,
    line_state,
    line_stats,
    one_model_figure,
    unit_history,
    unit_sheet_html,
)
from station.services.run_watch import runs_in_progress
from station.web.html import page, query, segment, text
from station.web.render_cache import RenderCache

#: The cookie a browser keeps the access token in.
TOKEN_COOKIE = "station_token"
#: What a page may load: its own scripts and images, inline styles, data: images (the
#: spec sheet's plots); nothing from elsewhere.
CONTENT_SECURITY_POLICY = ("default-src 'self'; img-src 'self' data:; "
                           "style-src 'self' 'unsafe-inline'; script-src 'self'; "
                           "frame-ancestors 'self'; form-action 'self'")
#: How many rendered spec sheets the server keeps (a sheet rendered afresh takes seconds).
SHEETS_KEPT = 32
FILTERS = ("since", "until", "model", "lot", "station", "operator")
#: The scripts under /static/.
SCRIPTS = ("live.js", "sheet.js")
#: What ``/api`` answers: each document's path, its parameters and what it holds.
API_INDEX: tuple[dict[str, str], ...] = (
    {"path": "/api", "params": "", "what": "this index"},
    {"path": "/api/overview", "params": "since, until, model, lot, station, operator, units",
     "what": "the filters' choices, yield per model and lot with its 95 % interval "
             "(Wilson), the newest gradings"},
    {"path": "/api/stats", "params": "model, lot, since, units",
     "what": "station results --stats --json: per model, yield per grade and each "
             "figure's capability"},
    {"path": "/api/figures/{name}", "params": "model, lot, since, units",
     "what": "a figure's capability, control chart, run rules and trend over lots "
             "(per model where none is named)"},
    {"path": "/api/units/{serial}", "params": "units",
     "what": "a unit's gradings and their figures"},
    {"path": "/api/runs", "params": "units",
     "what": "the run files under --runs: state, per unit model, serial, progress, time "
             "left, counts and the live Allan deviation; the damaged files"},
)


@dataclass(frozen=True)
class ServeConfig:
    """What ``station serve`` shows: the results database (None: the default one), the
    folders of run files in progress, and the access token (None: none asked for)."""

    db: DatabaseLocation | None = None
    runs: tuple[Path, ...] = ()
    token: str | None = None


def _family(request: Request) -> UnitFamily:
    try:
        return unit_family(request.query_params.get("units", "deg"))
    except ValueError as exc:
        raise UsageError(f"units={request.query_params.get('units')!r}: give deg or rad"
                         ) from exc


def _filter(config: ServeConfig, request: Request) -> LineFilter:
    given = {k: request.query_params.get(k) or None for k in FILTERS}
    return LineFilter(config.db, **given)


def _here(request: Request) -> str:
    """This page's path and query without ``units`` (the units switch adds it)."""
    params = {k: v for k, v in request.query_params.items() if k not in ("units", "token")}
    return request.url.path + query(params)


Handler = Callable[[Request], Awaitable[Response]]


class NotFoundError(LookupError):
    """What a page names is not in the database (a figure, a unit, a grading): 404."""


def create_app(config: ServeConfig) -> Starlette:
    """The application serving ``config``'s database and run folders (:mod:`station.web.app`)."""
    cache = RenderCache()

    async def stats_of(request: Request) -> StatsByModel:
        """``line_stats`` of the request's filter, computed once per database state."""
        where = _filter(config, request)
        state = await run_in_threadpool(line_state, where)
        key = ("stats", where.model, where.lot, where.since, state)
        return cast(StatsByModel, await cache.get(key, lambda: line_stats(where)))

    def html_page(title: str, build: Callable[[Request, UnitFamily, StatsByModel | None], str],
                  *, script: str | None = None, stats: bool = False) -> Handler:
        async def endpoint(request: Request) -> Response:
            family = _family(request)
            found = await stats_of(request) if stats else None
            body = await run_in_threadpool(build, request, family, found)
            return HTMLResponse(page(title.format(**request.path_params), body, family=family,
                                     here=_here(request), script=script))
        return endpoint

    def api(build: Callable[[Request], object]) -> Handler:
        async def endpoint(request: Request) -> Response:
            family = _family(request)
            doc = await run_in_threadpool(build, request)
            return JSONResponse(in_family(doc, family))
        return endpoint

    async def stats_api(request: Request) -> Response:
        family = _family(request)
        return JSONResponse(in_family((await stats_of(request)).as_json(), family))

    def overview(request: Request, family: UnitFamily, stats: StatsByModel | None) -> str:
        assert stats is not None
        blocks = [s.as_json() for s in stats.models.values()]
        return pages.overview_body(line_overview(_filter(config, request)), blocks, family)

    def figure_doc(request: Request, stats: StatsByModel) -> dict[str, Any]:
        """The figure of each model that grades it (one model's where the filter names it)."""
        try:
            return figure_models_json(stats, request.path_params["name"])
        except LookupError as exc:  # no selected model grades it
            raise NotFoundError(str(exc)) from exc

    def figure_stats(request: Request, stats: StatsByModel) -> FigureStats:
        """The figure of the one model a chart is drawn of (400 where several grade it)."""
        try:
            return one_model_figure(stats, request.path_params["name"])
        except LookupError as exc:  # no selected model grades it
            raise NotFoundError(str(exc)) from exc

    async def figure_api(request: Request) -> Response:
        family = _family(request)
        stats = await stats_of(request)
        return JSONResponse(in_family(await run_in_threadpool(figure_doc, request, stats),
                                      family))

    def figure_page(request: Request, family: UnitFamily, stats: StatsByModel | None) -> str:
        assert stats is not None
        return pages.figures_body(figure_doc(request, stats), _filter(config, request).__dict__,
                                  family)

    def unit(request: Request) -> dict[str, Any]:
        history = unit_history(_filter(config, request), request.path_params["serial"])
        if not history.gradings:
            raise NotFoundError(f"no grading of a unit {request.path_params['serial']!r}")
        return history.as_json()

    sheets: OrderedDict[tuple[int, tuple[str, ...]], str] = OrderedDict()
    sheets_lock = threading.Lock()

    def unit_page(request: Request, family: UnitFamily, stats: StatsByModel | None) -> str:
        doc = unit(request)
        grading = doc["gradings"][-1]["id"]
        sheet = (f"/sheets/{segment(request.path_params['serial'])}"
                 + query({"grading": str(grading)}))
        with sheets_lock:
            kept = any(key[0] == grading for key in sheets)
        return pages.unit_body(doc, family, sheet, rendering=not kept)

    def sheet(request: Request) -> str:
        where = _filter(config, request)
        history = unit_history(where, request.path_params["serial"])
        wanted = request.query_params.get("grading")
        chosen = [g for g in history.gradings if wanted is None or str(g.id) == wanted]
        if not chosen:
            raise NotFoundError(f"no grading {wanted} of a unit "
                                f"{request.path_params['serial']!r}")
        grading, reports = chosen[-1], history.reports[chosen[-1].id]
        # a stored grading does not change: its sheet, rendered once, is kept (a few)
        key = (grading.id, tuple(r["path"] for r in reports))
        with sheets_lock:
            kept = sheets.get(key)
        if kept is not None:
            return kept
        html = unit_sheet_html(where, grading, reports)
        with sheets_lock:
            sheets[key] = html
            while len(sheets) > SHEETS_KEPT:
                sheets.popitem(last=False)
        return html

    async def sheet_endpoint(request: Request) -> Response:
        html = await run_in_threadpool(sheet, request)
        # the sheet is the station's own file: shown in a sandboxed frame, no script runs
        return HTMLResponse(html, headers={"Content-Security-Policy":
                                           "default-src 'none'; img-src data:; "
                                           "style-src 'unsafe-inline'; frame-ancestors 'self'"})

    def svg(kind: str, draw: Callable[[FigureStats], str]) -> Handler:
        """A figure's chart, drawn once per database state and filter (:class:`RenderCache`)."""
        async def endpoint(request: Request) -> Response:
            where = _filter(config, request)
            stats = await stats_of(request)
            f = figure_stats(request, stats)
            state = await run_in_threadpool(line_state, where)
            key = (kind, f.name, where.model, where.lot, where.since, state)
            return Response(await cache.get(key, lambda: draw(f)), media_type="image/svg+xml")
        return endpoint

    def trend(f: FigureStats) -> str:
        from station.output.line_charts import trend_svg

        doc = figure_json(f)
        return trend_svg(f.name, str(doc["unit"]), cast(list[dict[str, Any]], doc["lots"]),
                         cast(float | None, doc["limit"]))

    def chart(f: FigureStats) -> str:
        from station.output.line_charts import figure_svg

        return figure_svg(f)

    def runs(request: Request, family: UnitFamily, stats: StatsByModel | None) -> str:
        return pages.runs_body(runs_in_progress(config.runs).as_json())

    async def script(request: Request) -> Response:
        name = request.path_params["name"]
        if name not in SCRIPTS:
            raise NotFoundError(f"no script {name!r}")
        source = files("station.web").joinpath(name).read_text(encoding="utf-8")
        return Response(source, media_type="text/javascript")

    async def api_index(request: Request) -> Response:
        return JSONResponse({"api": list(API_INDEX), "errors": '{"error": reason}, with '
                             "the status 400, 401, 404, 405 or 503",
                             "pages": ["/", "/figures/{name}", "/units/{serial}", "/runs"]})

    routes = [
        Route("/", html_page("Line overview", overview, stats=True)),
        Route("/api/overview", api(lambda r: line_overview(_filter(config, r)))),
        Route("/api/stats", stats_api),
        Route("/figures/{name}", html_page("Figure {name}", figure_page, stats=True)),
        Route("/figures/{name}/chart.svg", svg("chart", chart)),
        Route("/figures/{name}/trend.svg", svg("trend", trend)),
        Route("/api/figures/{name}", figure_api),
        Route("/units/{serial:path}", html_page("Unit {serial}", unit_page,
                                                script="/static/sheet.js")),
        Route("/sheets/{serial:path}", sheet_endpoint),
        Route("/api/units/{serial:path}", api(unit)),
        Route("/runs", html_page("Runs in progress", runs, script="/static/live.js")),
        Route("/api/runs", api(lambda r: runs_in_progress(config.runs).as_json())),
        Route("/static/{name}", script),
        Route("/api", api_index),
    ]
    middleware = [Middleware(BaseHTTPMiddleware, dispatch=_guard(config.token))]

    @asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        yield
        cache.close()

    async def http_error(request: Request, exc: Exception) -> Response:
        assert isinstance(exc, HTTPException)
        answer = _failure(request, exc.status_code, str(exc.detail), str(exc.detail))
        answer.headers.update(exc.headers or {})
        return answer

    app = Starlette(routes=routes, middleware=middleware, lifespan=lifespan,
                    exception_handlers={HTTPException: http_error})
    app.state.render_cache = cache  # its ``computed`` count: what was computed, not kept
    return app


def _guard(token: str | None) -> Callable[[Request, Handler], Awaitable[Response]]:
    """The middleware: the token checked, failures answered as pages (or JSON under /api),
    security headers on every answer."""

    async def dispatch(request: Request, call_next: Handler) -> Response:
        given = _token_of(request)
        if token is not None and not (given and _same_token(given, token)):
            answer = _failure(request, 401, "Access token needed",
                              "this station's page needs its access token (Authorization: "
                              "Bearer TOKEN, or ?token=TOKEN)")
            answer.headers["WWW-Authenticate"] = "Bearer"
        else:
            try:
                answer = await call_next(request)
            except DatabaseUnavailableError as exc:
                answer = _failure(request, 503, "Results database unavailable", str(exc))
            except NotFoundError as exc:
                answer = _failure(request, 404, "Not found", str(exc.args[0]))
            except UsageError as exc:
                answer = _failure(request, 400, "Bad request", str(exc))
            if token is not None and _same_token(request.query_params.get("token") or "",
                                                 token):
                answer.set_cookie(TOKEN_COOKIE, token, httponly=True, samesite="strict")
        answer.headers.setdefault("Content-Security-Policy", CONTENT_SECURITY_POLICY)
        answer.headers["X-Content-Type-Options"] = "nosniff"
        answer.headers["Referrer-Policy"] = "no-referrer"
        answer.headers["Cache-Control"] = "no-store"
        return answer

    return dispatch


def _same_token(given: str, token: str) -> bool:
    """Whether ``given`` is the token, compared in constant time as UTF-8 bytes (a token
    of any characters, a header's Latin-1 ones included, is compared, not refused with an
    error: :func:`hmac.compare_digest` takes text of ASCII only)."""
    return hmac.compare_digest(given.encode("utf-8", "surrogatepass"),
                               token.encode("utf-8", "surrogatepass"))


def _token_of(request: Request) -> str | None:
    header = request.headers.get("authorization", "")
    if header.lower().startswith("bearer "):
        return header[7:].strip()
    return request.query_params.get("token") or request.cookies.get(TOKEN_COOKIE)


def _failure(request: Request, status: int, title: str, reason: str) -> Response:
    """A failure as JSON (``{"error"}``) under ``/api``, else as a page; a 503 page retries
    (meta refresh)."""
    if request.url.path == "/api" or request.url.path.startswith("/api/"):
        return JSONResponse({"error": reason}, status_code=status)
    family = unit_family("deg")
    refresh = pages.RETRY_S if status == 503 else None
    body = pages.unavailable_body(reason) if status == 503 else f"<p>{text(reason)}</p>"
    return HTMLResponse(page(title, body, family=family, here=request.url.path,
                             refresh_s=refresh), status_code=status)
