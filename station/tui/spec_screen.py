"""The spec-sheet screen of a stored run: grade, figures table, Allan plot, DAVAR, exports."""

from __future__ import annotations

from pathlib import Path

from rich.text import Text
from textual import on, work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, VerticalScroll
from textual.reactive import reactive
from textual.screen import Screen
from textual.widgets import (
    Button,
    DataTable,
    Header,
    Select,
    Static,
    TabbedContent,
    TabPane,
)
from textual.widgets.select import InvalidSelectValueError
from textual.worker import get_current_worker

from station.evaluation.grading import RunGrade, UnitGrade
from station.output.report import FORMATS, ReportFormat
from station.output.results_backends import STORE_RETRY_S, DatabaseLocation
from station.tui.heatmap import DavarHeatMap
from station.tui.keys import BACK, StationFooter
from station.tui.messages import explain
from station.tui.widgets import (
    SeriesPlot,
    grade_text,
    interval_text,
    model_name,
    number,
    verdict_text,
)

_COLUMNS = (("figure [unit]", "figure"), ("value", "value"), ("limit", "limit"),
            ("verdict", "verdict"), ("CI", "ci"))


class SpecSheetScreen(Screen[None]):
    """Grades a run (in a worker) and shows its spec sheet, unit by unit.

    Parameters
    ----------
    path : Path
        The run file.
    reports_dir : Path
        Where exported reports go.
    db_path : str, Path or None
        Results database the grading and the reports are recorded in (None: not stored).
    profile : str, optional
        Profile name or path (default: the run's, else one whose model matches).
    unit : str, optional
        The unit shown first (unit id or serial number).
    """

    BINDINGS = [
        # the export buttons and the tabs say their keys: the footer has no room for them
        Binding("p", "export('pdf')", "PDF", show=False, tooltip="write the PDF report"),
        Binding("h", "export('html')", "HTML", show=False, tooltip="write the HTML report"),
        Binding("j", "export('json')", "JSON", show=False, tooltip="write the JSON report"),
        Binding("u", "next_unit", "Unit", tooltip="the next unit of the run"),
        Binding("n", "next_axis", "Axis", tooltip="the next axis of the unit"),
        Binding("f", "tab('tab-figures')", "Figures", show=False, tooltip="the figures tab"),
        Binding("a", "tab('tab-allan')", "Allan", show=False,
                tooltip="the Allan deviation tab"),
        Binding("d", "tab('tab-davar')", "DAVAR", show=False,
                tooltip="the dynamic Allan variance tab"),
        Binding("r", "tab('tab-run')", "Run", show=False, tooltip="the run tab: events, notes"),
        Binding("escape", "app.pop_screen", "Back", tooltip=BACK),
    ]

    # always_update: a RunGrade holds arrays, which == cannot compare
    graded: reactive[RunGrade | None] = reactive(None, always_update=True)
    unit_index: reactive[int] = reactive(0)
    axis_index: reactive[int] = reactive(0)

    def __init__(self, path: Path, reports_dir: Path, db_path: DatabaseLocation | None, *,
                 profile: str | None = None, unit: str | None = None,
                 db_retry_s: float = STORE_RETRY_S) -> None:
        super().__init__()
        self.path = Path(path)
        self.reports_dir = reports_dir
        self.db_path = db_path
        self.db_retry_s = db_retry_s
        self.profile_ref = profile
        self.first_unit = unit
        self._davar_key: tuple[UnitGrade, int] | None = None  # what the DAVAR tab is of

    def compose(self) -> ComposeResult:
        from station.model.profiles import available_profiles

        yield Header()
        with Horizontal(classes="row"):
            yield Static("grading...", id="grade")
            yield Select([(n, n) for n in available_profiles()], prompt="profile",
                         id="profile", allow_blank=True)
        with TabbedContent(id="tabs"):
            with TabPane("Figures (f)", id="tab-figures"):
                yield DataTable(id="figures", cursor_type="row", zebra_stripes=True)
            with TabPane("Allan (a)", id="tab-allan"):
                yield SeriesPlot("Allan deviation", "tau [s]", "ADEV [deg/h]", log=True,
                                 empty_text="grading...", id="allan-plot")
            with TabPane("DAVAR (d)", id="tab-davar"):
                yield DavarHeatMap(empty_text="grading...", id="davar-map")
            with TabPane("Run (r)", id="tab-run"), VerticalScroll():
                yield Static("", id="header")
        with Horizontal(id="exports"):
            yield Button("PDF (p)", id="export-pdf")
            yield Button("HTML (h)", id="export-html")
            yield Button("JSON (j)", id="export-json")
            yield Static("", id="exported")
        yield StationFooter()

    def on_mount(self) -> None:
        """Set up the table and grade the run."""
        self.sub_title = f"Spec sheet: {self.path.name}"
        self._grade(self.profile_ref)

    # -- grading (worker) --------------------------------------------------------------
    @work(thread=True, exclusive=True, group="grade", exit_on_error=False)
    def _grade(self, profile_ref: str | None) -> None:
        from station.evaluation.gmwm_run import run_with_profile_gmwm
        from station.services.grade import GradeRequest, NoProfileError, RunSource, grade

        request = GradeRequest(RunSource(self.path), profile=profile_ref,
                               profile_from_model=True, db=self.db_path)
        try:
            result = grade(request)
        except NoProfileError:
            self.app.call_from_thread(
                self.notify, f"{self.path.name} names no profile and none matches its "
                             f"units' model: choose one in the profile list.",
                severity="warning", timeout=15)
            self.app.call_from_thread(self._show_status, "choose a profile")
            return
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self.notify, explain(exc, f"grading {self.path.name}"),
                                      severity="error", timeout=20)
            self.app.call_from_thread(self._show_status, "not graded")
            return
        for note in result.warnings:
            self.app.call_from_thread(self.notify, note, title="Profile changed",
                                      severity="warning", timeout=20)
        try:  # the GMWM the profile asks for, as its report would carry it
            graded = run_with_profile_gmwm(result.graded)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self.notify, explain(exc, "fitting the GMWM"),
                                      severity="warning", timeout=20)
            graded = result.graded
        self.app.call_from_thread(setattr, self, "graded", graded)
        if self.db_path is not None:
            self._store(result.graded, self.db_path)

    def _store(self, graded: RunGrade, db: DatabaseLocation) -> None:
        """Store the grading shown (in the grading worker); say so when it is not stored."""
        from station.errors import ResultsDatabaseError
        from station.services.grade import store_grading

        try:
            store_grading(graded, db, retry_s=self.db_retry_s)
        except ResultsDatabaseError as exc:
            self.app.call_from_thread(
                self.notify, f"The grading shown here was NOT stored: {exc}. Open this spec "
                f"sheet again once the database answers: the grading is then stored (once).",
                title="Not stored", severity="error", timeout=60)

    def _show_status(self, text: str) -> None:
        self.query_one("#grade", Static).update(text)

    @on(Select.Changed, "#profile")
    def _profile_changed(self, event: Select.Changed) -> None:
        if isinstance(event.value, str) and (self.graded is None
                                             or event.value != self.graded.profile.name):
            self._show_status(f"grading with {event.value}...")
            self._grade(event.value)

    # -- showing (state flows down) ----------------------------------------------------
    def watch_graded(self, graded: RunGrade | None) -> None:
        """A new grading: pick the first unit and show it."""
        if graded is None:
            return
        select = self.query_one("#profile", Select)
        if select.value != graded.profile.name:
            with select.prevent(Select.Changed):
                try:
                    select.value = graded.profile.name
                except InvalidSelectValueError:  # a profile file outside profiles/
                    select.clear()
        index = 0
        for i, u in enumerate(graded.units):
            if self.first_unit in (u.unit.unit_id, u.unit.serial_number):
                index = i
        self.unit_index, self.axis_index = index, 0
        self.show()

    def watch_unit_index(self) -> None:
        """Show another unit."""
        self.show()

    def watch_axis_index(self) -> None:
        """Show another axis."""
        self.show()

    def action_tab(self, tab: str) -> None:
        """Show a tab (f, a, d, r)."""
        self.query_one("#tabs", TabbedContent).active = tab

    def action_next_unit(self) -> None:
        """Show the next unit of the run (its first axis)."""
        if self.graded is not None:
            self.axis_index = 0
            self.unit_index = (self.unit_index + 1) % len(self.graded.units)

    def action_next_axis(self) -> None:
        """Show the next axis of the unit."""
        if self.graded is not None:
            n = len(self.graded.units[self.unit_index].axes)
            self.axis_index = (self.axis_index + 1) % max(1, n)

    def show(self) -> None:
        """Fill the header line, figures table, plots and run tab for the unit and axis."""
        from station.output.report.common import (
            ambiguity_lines,
            event_summary,
            figure_rows,
            header_fields,
        )
        from station.output.report.gmwm_terms import gmwm_rows, gmwm_summary
        from station.tui.spec_data import adev_unit, allan_series

        graded = self.graded
        if graded is None or not self.is_mounted:
            return
        p = graded.profile
        unit = graded.units[min(self.unit_index, len(graded.units) - 1)]
        u = unit.unit
        head = Text.assemble(
            f"{u.unit_id} ({self.unit_index + 1}/{len(graded.units)}, u) "
            f"{model_name(u.model or p.model)} {u.serial_number or '-'}: ",
            grade_text(unit.grade, p.reject))
        table = self.query_one("#figures", DataTable)
        table.clear(columns=True)
        for label, key in _COLUMNS:
            table.add_column(f"{p.confidence:.0%} {label}" if key == "ci" else label, key=key)
        if unit.axes:
            axis = unit.axes[min(self.axis_index, len(unit.axes) - 1)]
            head.append_text(Text.assemble(
                f"\naxis {axis.axis} ({self.axis_index + 1}/{len(unit.axes)}, n): ",
                grade_text(axis.grade, p.reject), f", limits of {axis.deciding_grade}"))
            for r in figure_rows(axis):
                table.add_row(Text(f"{r.label} [{r.unit}]"), number(r.value, 3),
                              number(r.limit, 3), verdict_text(r.verdict),
                              interval_text(r.ci_low, r.ci_high))
            for g in gmwm_rows(axis):  # beside the Allan read-offs, where analysed with it
                table.add_row(Text(f"GMWM {g.term} [{g.unit}]"), number(g.value, 3), "-",
                              Text("info"), interval_text(g.ci_low, g.ci_high))
            if axis.analysis.gmwm is not None:
                head.append_text(Text(f"\nGMWM {gmwm_summary(axis)}"))
            plot = self.query_one("#allan-plot", SeriesPlot)
            plot.y_label = f"ADEV [{adev_unit(axis)}]"
            plot.series = allan_series((axis,))
            self._davar_of(unit, unit.axes.index(axis))
        self.query_one("#grade", Static).update(head)
        header = "\n".join(f"{k}: {v}" for k, v in header_fields(graded, unit))
        events = "\n".join(event_summary(u, graded).lines(brief=True))
        notes = "\n".join([*ambiguity_lines(unit), *(f"note: {t}" for t in unit.notes)])
        self.query_one("#header", Static).update("\n".join(t for t in (events, notes, header)
                                                           if t))

    def _davar_of(self, unit: UnitGrade, axis_index: int) -> None:
        """Compute the DAVAR heat map of a unit's axis, unless it is the one drawn or
        being computed (:meth:`show` runs again for the same unit and axis)."""
        key = self._davar_key
        if key is not None and key[0] is unit and key[1] == axis_index:
            return
        self._davar_key = (unit, axis_index)
        self.query_one("#davar-map", DavarHeatMap).show(None, "computing the DAVAR...")
        self._davar(unit, axis_index)

    @work(thread=True, exclusive=True, group="davar", exit_on_error=False)
    def _davar(self, unit: UnitGrade, axis_index: int) -> None:
        from station.evaluation.davar_map import davar_grid
        from station.evaluation.settings import settings_of
        from station.tui.heatmap import viridis

        heat_map = self.query_one("#davar-map", DavarHeatMap)
        try:
            profile = self.graded.profile if self.graded is not None else None
            grid = davar_grid(unit, axis_index, settings=settings_of(profile))
            viridis()  # matplotlib loads here, not on the UI thread when the map is drawn
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self.notify, explain(exc, "computing the DAVAR"),
                                      severity="warning")
            self.app.call_from_thread(heat_map.show, None, "not computed")
            return
        if not get_current_worker().is_cancelled:  # another axis or unit was asked for
            self.app.call_from_thread(heat_map.show, grid, "record too short")

    # -- exports -----------------------------------------------------------------------
    @on(Button.Pressed, "#exports Button")
    def _export_button(self, event: Button.Pressed) -> None:
        fmt = str(event.button.id).removeprefix("export-")
        if fmt in FORMATS:
            self.action_export(fmt)

    def action_export(self, fmt: ReportFormat) -> None:
        """Write the report in ``fmt`` (pdf, html, json) to the reports folder."""
        if self.graded is None:
            self.notify("The run is not graded yet: wait for the grade, or choose a profile.",
                        severity="warning")
            return
        self.query_one("#exported", Static).update(f"writing {fmt.upper()}...")
        self._export(self.graded, fmt)

    @work(thread=True, group="export", exit_on_error=False)
    def _export(self, graded: RunGrade, fmt: ReportFormat) -> None:
        from station.services.report import write_reports

        try:
            ((_, path),) = write_reports(graded, (fmt,), self.reports_dir, self.db_path,
                                         retry_s=self.db_retry_s)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self.notify, explain(exc, f"writing the {fmt} report"),
                                      severity="error", timeout=20)
            self.app.call_from_thread(self.query_one("#exported", Static).update, "")
            return
        where = f"{path.name} in {path.parent.resolve()}"  # the folder, not just a name
        self.app.call_from_thread(self.query_one("#exported", Static).update, f"wrote {where}")
        self.app.call_from_thread(self.notify, f"Wrote {where}", title="Report")
