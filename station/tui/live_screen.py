"""The live screen: a run being recorded, read from its file (SWMR), never from devices."""

from __future__ import annotations

from pathlib import Path

from rich.text import Text
from textual import events, work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.message import Message
from textual.reactive import reactive
from textual.screen import ModalScreen, Screen
from textual.widgets import Button, DataTable, Header, Label, ProgressBar, Static

from station.services.recorder_process import RecorderProcess, run_file_state, stop_run
from station.tui.keys import StationFooter
from station.tui.live import LiveSnapshot, RunPoller
from station.tui.messages import explain
from station.tui.widgets import SeriesPlot, count, hms, model_name, number

_COLUMNS = (("unit", "unit"), ("model s/n", "who"), ("samples", "samples"),
            ("rate Hz", "rate"), ("CRC", "crc"), ("gaps (miss)", "gaps"), ("reconn", "reconn"),
            ("temp °C", "temp"))
#: Unit rows shown without scrolling (a bench has 4 to 16 units; the plots need the room).
MAX_TABLE_ROWS = 6


class ConfirmScreen(ModalScreen[bool]):
    """A yes/no question: y (or the Yes button) answers yes, any other key no, so that
    stray typing (text meant for another screen) never confirms by chance."""

    def __init__(self, question: str) -> None:
        super().__init__()
        self.question = question

    def compose(self) -> ComposeResult:
        with Vertical(id="dialog"):
            yield Label(self.question, id="question")
            with Horizontal(id="answers"):
                yield Button("Yes (y)", id="yes", variant="error")
                yield Button("No (any other key)", id="no")

    def on_button_pressed(self, event: Button.Pressed) -> None:
        """Answer with the button."""
        self.dismiss(event.button.id == "yes")

    def on_key(self, event: events.Key) -> None:
        """y answers yes; every other key answers no."""
        event.stop()
        event.prevent_default()
        self.dismiss(event.key == "y")


class LiveScreen(Screen[None]):
    """Follows one run file: status rows, progress, live rate and Allan deviation plots.

    Parameters
    ----------
    path : Path
        The run file.
    process : RecorderProcess, optional
        The recorder when this TUI started it (None when reattached).
    poll_s : float
        Time between reads of the file, s (wall).
    """

    BINDINGS = [
        Binding("s", "stop", "Stop", tooltip="stop the run now (asks first)"),
        Binding("g", "spec_sheet", "Sheet", tooltip="the spec sheet, once the run has stopped"),
        Binding("escape", "detach", "Detach",
                tooltip="leave this screen; the run goes on recording (F4 shows it again)"),
    ]

    # always_update: a snapshot holds arrays, which == cannot compare
    snapshot: reactive[LiveSnapshot | None] = reactive(None, always_update=True)

    class SpecSheetRequested(Message):
        """Show the spec sheet of this run."""

        def __init__(self, path: Path) -> None:
            super().__init__()
            self.path = path

    def __init__(self, path: Path, process: RecorderProcess | None = None, *,
                 poll_s: float = 1.0) -> None:
        super().__init__()
        self.path = Path(path)
        self.process = process
        self.poll_s = poll_s
        self.poller = RunPoller(self.path)
        self._polling = False
        self._told_stopped = False
        self._told_abandoned = False
        #: What the operator reads while the run's recorder is gone ("" while it records).
        self.recorder_gone = ""

    def compose(self) -> ComposeResult:
        yield Header()
        yield Static(f"reading the run file...{self.where}", id="run-title")
        with Horizontal(id="progress-row"):
            yield ProgressBar(total=1.0, show_eta=False, show_percentage=True, id="progress")
            yield Static("", id="times")
        yield DataTable(id="units", cursor_type="none", zebra_stripes=True)
        with Horizontal(id="plots"):
            yield SeriesPlot("rate, axis 1, 0.1 s means", "run time [s]", "deg/h",
                             id="rate-plot")
            yield SeriesPlot("Allan deviation, axis 1", "tau [s]", "ADEV [deg/h]", log=True,
                             id="adev-plot")
        yield StationFooter()

    def on_mount(self) -> None:
        """Set up the table and start polling the file."""
        self.sub_title = f"Live: {self.path.name}"
        table = self.query_one("#units", DataTable)
        for label, key in _COLUMNS:
            table.add_column(label, key=key)
        self.poll()
        self.set_interval(self.poll_s, self.poll)

    # -- polling (a worker thread reads the file; the snapshot flows down) -------------
    def poll(self) -> None:
        """Start a read of the file unless one is under way."""
        if not self._polling:
            self._polling = True
            self._read()

    @work(thread=True, group="poll", exit_on_error=False)
    def _read(self) -> None:
        try:
            snap = self.poller.poll()
            writer = run_file_state(self.path)
            gone = writer.gone_advice() if writer.recorder_gone() else ""
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self._failed, exc)
            return
        self.app.call_from_thread(self._arrived, snap, gone)

    @property
    def where(self) -> str:
        """Where the run is written and, when this TUI started it, by which process (said
        on the screen, not in a toast over the plots)."""
        text = f" in {self.path.parent.resolve()}"
        if self.process is not None:
            text += (f"; recorder pid {self.process.pid} (log {self.process.log_path.name}) "
                     f"goes on if the TUI is closed")
        return text

    def _failed(self, exc: BaseException) -> None:
        self._polling = False
        self.notify(explain(exc, f"reading {self.path.name}"), severity="error", timeout=10)

    def _arrived(self, snap: LiveSnapshot, gone: str) -> None:
        self._polling = False
        self.recorder_gone = gone
        self.snapshot = snap
        if self.process is not None:
            self.process.exit_code()  # reap our recorder once it ends
        if gone and not self._told_abandoned:
            self._told_abandoned = True
            self.notify(gone[0].upper() + gone[1:] + ".",
                        title="Recorder gone", severity="error", timeout=30)
        if snap.stopped and not self._told_stopped:
            self._told_stopped = True
            if snap.stop_reason.startswith("disk full"):
                self.notify(
                    f"The disk filled up: the run stopped with everything recorded so "
                    f"far intact ({snap.stop_reason}). Free some space or choose "
                    f"another runs folder before the next run; g grades what was "
                    f"recorded.",
                    title="Disk full",
                    severity="error",
                    timeout=60,
                )
            else:
                self.notify(
                    f"Run stopped ({snap.stop_reason}). Press g for the spec sheet.",
                    title="Run stopped",
                    timeout=15,
                )

    def watch_snapshot(self, snap: LiveSnapshot | None) -> None:
        """Show a new snapshot: title, progress, status rows, plots."""
        if snap is None:
            return
        state = (
            "[b]stopped[/b]: " + snap.stop_reason
            if snap.stopped
            else "[b red]recorder gone[/b red]: run `station recover`"
            if self.recorder_gone
            else "[b green]recording[/b green]"
        )
        catching = "" if snap.caught_up else " (catching up with the file...)"
        self.query_one("#run-title", Static).update(f"{state}{catching}{self.where}")
        self.query_one("#progress", ProgressBar).update(progress=snap.fraction)
        self.query_one("#times", Static).update(
            f"{hms(snap.elapsed_s)} of {hms(snap.duration_s)}"
            + (" recorded" if snap.stopped else f", {hms(snap.remaining_wall_s)} left")
        )
        self._fill_table(snap)
        self.query_one("#rate-plot", SeriesPlot).series = snap.rate
        self.query_one("#adev-plot", SeriesPlot).series = snap.adev

    def _fill_table(self, snap: LiveSnapshot) -> None:
        table = self.query_one("#units", DataTable)
        table.styles.height = min(len(snap.units), MAX_TABLE_ROWS) + 1
        for u in snap.units:
            achieved = number(u.achieved_rate_hz, 3)
            gaps = Text(f"{u.gaps} ({u.missing})", style="yellow" if u.gaps else "")
            crc = Text(str(u.crc_errors), style="yellow" if u.crc_errors else "")
            unit = (
                Text(u.unit_id) if u.connected else Text(f"{u.unit_id} DISC", style="bold red")
            )  # reconnecting
            cells = {
                "unit": unit,
                "who": f"{model_name(u.model)} {u.serial_number}",
                "samples": count(u.samples),
                "rate": f"{achieved}/{u.sample_rate_hz:g}",
                "crc": crc,
                "gaps": gaps,
                "reconn": str(u.reconnects),
                "temp": number(u.temperature_c, 3),
            }
            if u.unit_id not in table.rows:
                table.add_row(*cells.values(), key=u.unit_id)
            else:
                for key, value in cells.items():
                    table.update_cell(u.unit_id, key, value, update_width=True)

    # -- actions -----------------------------------------------------------------------
    def action_stop(self) -> None:
        """Ask, then stop the recorder cleanly (SIGTERM; the file is closed properly)."""
        if self.snapshot is not None and self.snapshot.stopped:
            self.notify("The run has stopped already: g opens the spec sheet.")
            return

        def answered(yes: bool | None) -> None:
            if yes:
                self._stop()

        self.app.push_screen(ConfirmScreen(f"Stop {self.path.name} now?"), answered)

    @work(thread=True, group="stop", exit_on_error=False)
    def _stop(self) -> None:
        try:
            pid = stop_run(self.path)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(
                self.notify, explain(exc, "stopping the run"), severity="error", timeout=15
            )
            return
        self.app.call_from_thread(
            self.notify,
            f"Stopping the recorder (pid {pid}): it writes what it has and closes the file.",
        )

    def action_spec_sheet(self) -> None:
        """Open the spec sheet once the run has stopped."""
        if self.snapshot is None or not self.snapshot.stopped:
            self.notify(
                "The run is still recording: stop it (s) or wait for its end; the "
                "spec sheet grades the whole run.",
                severity="warning",
            )
            return
        self.post_message(self.SpecSheetRequested(self.path))

    def action_detach(self) -> None:
        """Leave this screen; the recorder goes on (reopen it from Runs, F4)."""
        if self.snapshot is not None and not self.snapshot.stopped:
            self.notify("Detached: the run goes on recording. F4 (Runs) shows it again.")
        self.dismiss()
