"""The sequence screen: start (or resume) a profile's test sequence and follow it step by step.

A thin view over :mod:`station.services.sequence_process` (``station record --sequence``
started detached: quitting the TUI does not stop it; ``s`` stops it and it stays
resumable) and :mod:`station.services.sequence_progress` (the steps' states from the
sequence file's journal, the unfinished sequences of the runs folder, resumed as the
command resumes them, and the figures at the end).
"""

from __future__ import annotations

import time
from pathlib import Path

from textual import on, work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal
from textual.reactive import reactive
from textual.screen import Screen
from textual.widgets import DataTable, Header, Input, Label, Select, Static

from station.errors import StationError
from station.model.sequence_runs import SequenceRun
from station.output.report.common import FigureRow
from station.services.sequence import SIM, SequenceRequest
from station.services.sequence_process import (
    SequenceProcess,
    running_sequence,
    start_sequence,
)
from station.services.sequence_progress import (
    SequenceProgress,
    StepProgress,
    resume_request,
    sequence_figures,
    sequence_progress,
    unfinished_sequences,
)
from station.storage.sequence_files import read_sequence
from station.tui.keys import BACK, StationFooter
from station.tui.messages import explain
from station.tui.widgets import hms

_STEP_COLUMNS = ("#", "cycle", "step", "state", "progress", "temperature")
_FIGURE_COLUMNS = ("unit", "figure", "value", "interval", "limit", "verdict")
_NO_CHOICE = "(choose)"


def progress_text(step: StepProgress) -> str:
    """``"45% 00:13:30/00:30:00"``, ``"done"``, ``"-"``: how far a step has run."""
    share = step.fraction
    if step.state == "pending":
        return "-"
    if step.duration_s:
        return f"{100 * (share or 0.0):3.0f}% {hms(step.done_s)}/{hms(step.duration_s)}"
    return "done" if step.state == "done" else hms(step.done_s)


def temperature_text(step: StepProgress) -> str:
    """``"plateau 40 degC, air 39.8"``, ``"set 25 degC"`` or ``""``."""
    if step.setpoint_c is None:
        return ""
    head = f"{'plateau' if step.plateau else 'set'} {step.setpoint_c:g} °C"
    return head if step.chamber_c is None else f"{head}, air {step.chamber_c:.1f}"


def _number(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"


def figure_cells(unit_id: str, row: FigureRow) -> tuple[str, ...]:
    """One unit's figure as the figures table shows it."""
    interval = ("-" if row.ci_low is None or row.ci_high is None
                else f"[{row.ci_low:.3g}, {row.ci_high:.3g}]")
    return (unit_id, row.label, f"{_number(row.value)} {row.unit}", interval,
            _number(row.limit), row.verdict or "-")


class SequenceScreen(Screen[None]):
    """Pick a profile's sequence and its units, start it (F5) or resume an unfinished one
    (Enter on it), and follow each step until it ends; the figures follow.

    Parameters
    ----------
    runs_dir : Path
        Folder of the sequence files (new ones go here; unfinished ones are found here).
    profiles_dir : Path, optional
        Folder of the profiles offered (default the shipped ``profiles/``).
    poll_s : float
        Time between refreshes of the steps, s (wall).
    """

    BINDINGS = [
        Binding("f5", "start", "Start", tooltip="start the sequence of the form (or resume it)"),
        Binding("s", "stop", "Stop", tooltip="stop the running sequence (it stays resumable)"),
        Binding("escape", "app.pop_screen", "Back", tooltip=BACK),
    ]

    progress: reactive[SequenceProgress | None] = reactive(None, always_update=True)
    figures: reactive[tuple[tuple[str, FigureRow], ...]] = reactive((), always_update=True)

    def __init__(self, runs_dir: Path, *, profiles_dir: Path | None = None,
                 poll_s: float = 0.5) -> None:
        super().__init__()
        self.runs_dir = runs_dir
        self.profiles_dir = profiles_dir
        self.poll_s = poll_s
        #: The sequence this screen started last (None: none yet).
        self.process: SequenceProcess | None = None
        #: The sequence file whose end was shown (graded when it finished).
        self.graded_path: Path | None = None
        self.unfinished: list[SequenceRun] = []
        #: The units the last profile chosen filled in ("" none): replaced by the next one.
        self.prefilled_units = ""

    def compose(self) -> ComposeResult:
        from station.model.profiles import available_profiles

        yield Header()
        with Horizontal(classes="row"):
            yield Label("Profile", classes="label")
            yield Select([(n, n) for n in available_profiles(self.profiles_dir)],
                         prompt=_NO_CHOICE, id="seq-profile")
            yield Label("Sequence", classes="label2")
            yield Select([], prompt=_NO_CHOICE, id="sequence")
        with Horizontal(classes="row"):
            yield Label("Units", classes="label")
            yield Input(placeholder="device URLs, separated by spaces", id="seq-units")
        with Horizontal(classes="row"):
            yield Label("Power", classes="label")
            yield Input(SIM, placeholder="sim, or a switch URL per unit", id="power",
                        classes="short")
            yield Label("Chamber", classes="label2")
            yield Input(SIM, placeholder="sim, a URL, or empty", id="chamber", classes="short")
        yield Static("", id="seq-status")
        yield DataTable(id="unfinished", cursor_type="row")
        yield DataTable(id="steps", cursor_type="row")
        yield DataTable(id="figures", cursor_type="row")
        yield StationFooter()

    def on_mount(self) -> None:
        """Set up the tables and list the unfinished sequences."""
        self.title = "Test sequence"
        self.sub_title = f"files in {self.runs_dir.resolve()}"
        self.query_one("#unfinished", DataTable).add_columns("unfinished sequence", "profile",
                                                             "units", "where")
        self.query_one("#steps", DataTable).add_columns(*_STEP_COLUMNS)
        self.query_one("#figures", DataTable).add_columns(*_FIGURE_COLUMNS)
        self._list_unfinished()
        self.set_interval(self.poll_s, self._refresh, name="sequence-progress")

    # -- choosing ----------------------------------------------------------------------
    def _profile_ref(self, name: str) -> str:
        return str(self.profiles_dir / f"{name}.toml") if self.profiles_dir else name

    @on(Select.Changed, "#seq-profile")
    def _profile_changed(self, event: Select.Changed) -> None:
        if isinstance(event.value, str):
            self._load_sequences(event.value)

    @work(thread=True, exclusive=True, group="profile", exit_on_error=False)
    def _load_sequences(self, name: str) -> None:
        from station.model.profiles import anchored_model, load_profile

        try:
            profile = load_profile(self._profile_ref(name))
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self.notify, explain(exc, f"reading profile {name}"),
                                      severity="error")
            return
        # the profile's unit, as the set-up screen offers it (a model file made absolute)
        url = anchored_model(str(profile.transport.get("url", "")), self.profiles_dir)
        self.app.call_from_thread(self._show_sequences, name, list(profile.sequences), url)

    def _show_sequences(self, name: str, names: list[str], url: str = "") -> None:
        units = self.query_one("#seq-units", Input)
        if url and units.value.strip() in ("", self.prefilled_units):
            units.value = self.prefilled_units = url  # never over units typed by hand
        select = self.query_one("#sequence", Select)
        select.set_options([(n, n) for n in names])
        if names:
            select.value = names[0]
        else:
            self.notify(f"profile {name} has no [sequence.NAME] table: choose another",
                        severity="warning")

    def _list_unfinished(self) -> None:
        self.unfinished = unfinished_sequences(self.runs_dir)
        table = self.query_one("#unfinished", DataTable)
        table.clear()
        for run in self.unfinished:
            at = sequence_progress(run).current
            where = "-" if at is None else f"step {at.index + 1}: {at.text}"
            live = running_sequence(Path(run.path))
            table.add_row(Path(run.path).name, f"{run.profile} {run.name}",
                          str(len(run.unit_urls)),
                          where if live is None else f"running (pid {live.pid}), {where}")
        table.display = bool(self.unfinished)

    def request(self) -> SequenceRequest | None:
        """The request the form describes (None, with a notification, when incomplete)."""
        profile = self.query_one("#seq-profile", Select).value
        sequence = self.query_one("#sequence", Select).value
        units = tuple(self.query_one("#seq-units", Input).value.split())
        if not isinstance(profile, str) or not isinstance(sequence, str):
            self.notify("choose a profile with a sequence, and the sequence", severity="error")
            return None
        power = tuple(self.query_one("#power", Input).value.split())
        chamber = self.query_one("#chamber", Input).value.strip() or None
        return SequenceRequest(sequence, self._profile_ref(profile), units, power, chamber,
                               self.runs_dir)

    # -- running -----------------------------------------------------------------------
    def action_start(self) -> None:
        """Start the sequence of the form (resumed when the same one is unfinished)."""
        request = self.request()
        if request is not None:
            self.begin(request)

    @on(DataTable.RowSelected, "#unfinished")
    def _resume_chosen(self, event: DataTable.RowSelected) -> None:
        run = self.unfinished[event.cursor_row]
        live = running_sequence(Path(run.path))
        if live is None:
            self.begin(resume_request(run, self.runs_dir))
        elif self.process is None or not self.process.running:
            self.process, self.graded_path, self.figures = live, None, ()
            self.notify(f"Following {Path(run.path).name}, still running (pid {live.pid}).",
                        title="Sequence")

    def begin(self, request: SequenceRequest) -> None:
        """Run ``request`` (refused while a sequence this screen started runs)."""
        if self.process is not None and self.process.running:
            self.notify("a sequence is running: stop it (s) first", severity="warning")
            return
        self.figures = ()
        self.graded_path = None
        self.query_one("#seq-status", Static).update(
            f"starting the sequence on {len(request.units)} unit(s)...")
        try:
            self.process = start_sequence(request)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self._failed(explain(exc, "The sequence did not start"))
            return
        verb = "Resuming" if self.process.resumed else "Running"
        path = self.process.path
        self.notify(f"{verb} {request.sequence} into {path.name} in {path.parent.resolve()} "
                    f"(its log {self.process.log_path.name} beside it): quitting the TUI does "
                    f"not stop it.", title="Sequence", timeout=10)

    def _refresh(self) -> None:
        process = self.process
        if process is None or self.graded_path == process.path:
            return
        running = process.running
        try:
            run = read_sequence(process.path)
        except (OSError, StationError):
            if not running:  # it ended before writing its file: the log says why
                self.graded_path = process.path
                self._failed(f"The sequence did not start: {process.log_tail(400).strip()}")
            return
        self.progress = sequence_progress(run, now_s=time.time() if running else None)
        if not running:
            self.graded_path = process.path
            self._list_unfinished()
            if run.done:
                self._grade(process.path)
            elif process.exit_code() == 2:  # refused before it ran: the log says why
                self._failed(f"The sequence did not start: {process.log_tail(400).strip()}")

    @work(thread=True, exclusive=True, group="grade", exit_on_error=False)
    def _grade(self, path: Path) -> None:
        try:
            rows = sequence_figures(path)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self._failed, explain(exc, "grading the sequence"))
            return
        self.app.call_from_thread(setattr, self, "figures", rows)

    def _failed(self, text: str) -> None:
        self.notify(text, severity="error", timeout=30)
        self.query_one("#seq-status", Static).update(text)

    def action_stop(self) -> None:
        """Stop the running sequence at once (SIGTERM to its process); it stays resumable."""
        if self.process is not None:
            self.process.stop()

    # -- showing -----------------------------------------------------------------------
    def watch_progress(self, progress: SequenceProgress | None) -> None:
        """Redraw the steps and the status line."""
        if progress is None:
            return
        table = self.query_one("#steps", DataTable)
        table.clear()
        for step in progress.steps:
            table.add_row(str(step.index + 1), str(step.cycle), step.text, step.state,
                          progress_text(step), temperature_text(step))
        current = progress.current
        if current is not None:
            table.move_cursor(row=current.index)
        status = (f"{progress.name} ({progress.profile}): {progress.state}, "
                  f"{progress.steps_done} of {len(progress.steps)} steps done, "
                  f"{Path(progress.path).name}")
        if progress.message:
            status += f"\n{progress.message}"
        elif progress.state == "done":
            status += "\ngrading the sequence..." if not self.figures else ""
        self.query_one("#seq-status", Static).update(status)

    def watch_figures(self, rows: tuple[tuple[str, FigureRow], ...]) -> None:
        """Show the sequence's figures, per unit."""
        table = self.query_one("#figures", DataTable)
        table.clear()
        for unit_id, row in rows:
            table.add_row(*figure_cells(unit_id, row))
        if rows:
            grades = ", ".join(sorted({f"{u} {r.grade or '-'}" for u, r in rows}))
            self.query_one("#seq-status", Static).update(
                f"{self.progress.name if self.progress else ''}: done; grades {grades}")
