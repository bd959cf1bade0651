"""Browsers: the stored runs of the runs folder, and the results database."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from rich.text import Text
from textual import on, work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal
from textual.message import Message
from textual.screen import Screen
from textual.widgets import DataTable, Header, Input, Label, Select, Static

from station.model.kinds import VERDICTS, Verdict
from station.output.results_backends import DatabaseLocation
from station.tui.keys import BACK, StationFooter
from station.tui.messages import explain

if TYPE_CHECKING:
    from station.output.results import GradingRow, LotYield
from station.tui.widgets import VERDICT_STYLES, model_name


class RunChosen(Message):
    """Open a run: live when it is recording, else its spec sheet."""

    def __init__(self, path: Path, *, recording: bool, profile: str | None = None,
                 unit: str | None = None) -> None:
        super().__init__()
        self.path = path
        self.recording = recording
        self.profile = profile
        self.unit = unit


@dataclass(frozen=True)
class RunListing:
    """One run file of the runs folder."""

    path: Path
    state: str
    detail: str


def list_runs(runs_dir: Path, limit: int = 200) -> list[RunListing]:
    """Run files of ``runs_dir``, newest first, with their state."""
    from station.services.recorder_process import run_file_state

    if not runs_dir.is_dir():
        return []
    out = []
    files = sorted(runs_dir.glob("*.h5"), key=lambda p: p.stat().st_mtime, reverse=True)
    for path in files[:limit]:
        try:
            st = run_file_state(path)
        except Exception as exc:  # noqa: BLE001 - an unreadable file is listed as such
            out.append(RunListing(path, "unreadable", str(exc)[:60]))
            continue
        state = ("recording" if st.recording else "interrupted" if st.abandoned
                 else st.state)
        out.append(RunListing(path, state, st.stop_reason))
    return out


class RunsScreen(Screen[None]):
    """The run files of the runs folder; Enter opens one (live, or its spec sheet).

    The *Run file* field has the focus: a typed path (or a file name of the runs folder)
    and Enter opens that file; with the field empty, up and down move in the list and
    Enter opens the run under the cursor.
    """

    BINDINGS = [
        Binding("escape", "app.pop_screen", "Back", tooltip=BACK),
        Binding("f5", "refresh", "Refresh", tooltip="read the runs folder again"),
        Binding("down", "move(1)", "Next run", show=False,
                tooltip="(down, up) the next or previous run of the list"),
        Binding("up", "move(-1)", "Previous run", show=False),
    ]

    def __init__(self, runs_dir: Path) -> None:
        super().__init__()
        self.runs_dir = runs_dir
        self.listing: list[RunListing] = []

    def compose(self) -> ComposeResult:
        yield Header()
        with Horizontal(classes="row"):
            yield Label("Run file", classes="label")
            yield Input(placeholder="a run file's path + Enter; or up/down, Enter below",
                        id="path")
        yield DataTable(id="runs", cursor_type="row", zebra_stripes=True)
        yield StationFooter()

    def on_mount(self) -> None:
        """List the runs."""
        self.sub_title = f"Runs in {self.runs_dir.resolve()}"
        table = self.query_one("#runs", DataTable)
        table.add_column("run file", key="file")
        table.add_column("state", key="state")
        table.add_column("stop reason", key="reason")
        self.query_one("#path", Input).focus()  # typing goes where the placeholder says
        self.action_refresh()

    def action_refresh(self) -> None:
        """Read the folder again."""
        self._list()

    def action_move(self, step: int) -> None:
        """Move the list's cursor while the Run file field has the focus."""
        table = self.query_one("#runs", DataTable)
        if table.row_count:
            table.move_cursor(row=max(0, min(table.row_count - 1, table.cursor_row + step)))

    @work(thread=True, exclusive=True, exit_on_error=False)
    def _list(self) -> None:
        listing = list_runs(self.runs_dir)
        self.app.call_from_thread(self._show, listing)

    def _show(self, listing: list[RunListing]) -> None:
        self.listing = listing
        table = self.query_one("#runs", DataTable)
        table.clear()
        styles = {"recording": "bold green", "interrupted": "bold red", "unreadable": "red"}
        for r in listing:
            table.add_row(r.path.name, Text(r.state, style=styles.get(r.state, "")), r.detail,
                          key=str(r.path))
        if not listing:
            self.notify(f"No run files in {self.runs_dir.resolve()} yet: start one with F2 "
                        f"(New run), or type the path of a run file above.")

    @on(DataTable.RowSelected, "#runs")
    def _chosen(self, event: DataTable.RowSelected) -> None:
        self.open_listed(event.cursor_row)

    def open_listed(self, row: int) -> None:
        """Open the run of the list's ``row`` (live when recording, else its spec sheet)."""
        if not 0 <= row < len(self.listing):
            self.notify(f"No run files in {self.runs_dir.resolve()}: type a run file's path.",
                        severity="warning")
            return
        r = self.listing[row]
        if r.state == "interrupted":
            self.notify(f"{r.path.name} was not closed (recorder killed): run `station recover "
                        f"{r.path}` first; its spec sheet opens with the data up to the last "
                        f"flush.", severity="warning", timeout=15)
        self.post_message(RunChosen(r.path, recording=r.state == "recording"))

    @on(Input.Submitted, "#path")
    def _typed(self, event: Input.Submitted) -> None:
        typed = event.value.strip()
        if not typed:  # nothing typed: the run under the list's cursor
            self.open_listed(self.query_one("#runs", DataTable).cursor_row)
            return
        path = Path(typed).expanduser()
        if not path.is_file() and (self.runs_dir / path).is_file():
            path = self.runs_dir / path  # a file name of the runs folder
        if not path.is_file():
            self.notify(f"No file {path.resolve()}: check the path.", severity="error")
            return
        from station.services.recorder_process import run_file_state

        try:
            recording = path.suffix.lower() in (".h5", ".hdf5") and run_file_state(path).recording
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.notify(explain(exc, f"opening {path.name}"), severity="error")
            return
        self.post_message(RunChosen(path, recording=recording))


_VERDICTS = [(v, v) for v in VERDICTS]


class ResultsScreen(Screen[None]):
    """The results database: gradings filtered by model, lot and verdict; yield per lot."""

    BINDINGS = [Binding("escape", "app.pop_screen", "Back", tooltip=BACK),
                Binding("f5", "refresh", "Refresh", tooltip="query the database again")]

    def __init__(self, db_path: DatabaseLocation) -> None:
        super().__init__()
        self.db_path = db_path
        self.rows: list[GradingRow] = []

    def compose(self) -> ComposeResult:
        yield Header()
        with Horizontal(classes="row"):
            yield Label("Model", classes="label2")
            yield Input(placeholder="any", id="model", classes="short")
            yield Label("Lot", classes="label2")
            yield Input(placeholder="any", id="lot", classes="short")
            yield Select(_VERDICTS, prompt="any verdict", id="verdict")
        yield DataTable(id="results", cursor_type="row", zebra_stripes=True)
        yield Static("", id="yield")
        yield StationFooter()

    def on_mount(self) -> None:
        """Read the database."""
        self.sub_title = f"Results: {self.db_path}"
        table = self.query_one("#results", DataTable)
        for label in ("test date", "model", "serial", "lot", "grade", "verdict", "profile"):
            table.add_column(label, key=label)
        table.focus()
        self.action_refresh()

    @on(Input.Submitted)
    @on(Select.Changed, "#verdict")
    def action_refresh(self) -> None:
        """Query with the current filters."""
        verdict = self.query_one("#verdict", Select).value
        self._query(self.query_one("#model", Input).value.strip() or None,
                    self.query_one("#lot", Input).value.strip() or None,
                    verdict if verdict in VERDICTS else None)

    @work(thread=True, exclusive=True, exit_on_error=False)
    def _query(self, model: str | None, lot: str | None, verdict: Verdict | None) -> None:
        from station.services.results import ResultsRequest, query_results

        try:
            request = ResultsRequest(self.db_path, model=model, lot=lot, verdict=verdict)
            rows = list(query_results(request).gradings)
            yields = list(query_results(replace(request, show="yield")).yields)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self.notify, explain(exc, "reading the results database"),
                                      severity="error", timeout=15)
            return
        self.app.call_from_thread(self._show, rows, yields)

    def _show(self, rows: list[GradingRow], yields: list[LotYield]) -> None:
        self.rows = list(reversed(rows))  # newest first
        table = self.query_one("#results", DataTable)
        table.clear()
        for r in self.rows:
            table.add_row(r.test_date[:16], model_name(r.model), r.serial_number, r.lot or "-",
                          Text(r.grade, style=VERDICT_STYLES.get(r.verdict, "")),
                          Text(r.verdict + (" (review)" if r.needs_review else ""),
                               style=VERDICT_STYLES.get(r.verdict, "")), r.profile)
        text = "  ".join(f"lot {y.lot or '-'} ({model_name(y.model)}): {y.passed}/{y.total} pass "
                         f"({y.yield_fraction:.0%})" for y in yields)
        self.query_one("#yield", Static).update(
            f"{len(rows)} gradings. Yield: {text or 'no lots yet'}. Enter opens a spec sheet.")

    @on(DataTable.RowSelected, "#results")
    def _chosen(self, event: DataTable.RowSelected) -> None:
        r = self.rows[event.cursor_row]
        path = Path(r.run_path)
        if not path.is_file():
            self.notify(f"The run file {path} is gone (moved or deleted): its stored figures "
                        f"are in `station results`.", severity="error", timeout=15)
            return
        self.post_message(RunChosen(path, recording=False, profile=r.profile.split("@")[0],
                                    unit=r.run_unit))
