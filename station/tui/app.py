"""The station's terminal user interface: set up a run, watch it live, read its spec sheet.

Screens, one concept each: :class:`~station.tui.setup_screen.SetupScreen` (the base),
:class:`~station.tui.live_screen.LiveScreen`, :class:`~station.tui.spec_screen.SpecSheetScreen`,
:class:`~station.tui.sequence_screen.SequenceScreen`,
:class:`~station.tui.browse_screens.RunsScreen` and
:class:`~station.tui.browse_screens.ResultsScreen`. Screens post messages up; the app
starts recorders (detached processes, :mod:`station.services.recorder_process`) and
pushes screens;
each screen's state flows down from reactive attributes that its workers set.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, cast

from rich.console import Console
from textual import on, work
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.screen import ModalScreen, Screen
from textual.worker import get_current_worker

from station.output.results_backends import STORE_RETRY_S, DatabaseLocation
from station.services.record import RecordRequest
from station.services.recorder_process import (
    RecorderProcess,
    RecorderStartError,
    find_active_runs,
    start_recording,
    wait_for_run_file,
)
from station.tui.browse_screens import ResultsScreen, RunChosen, RunsScreen
from station.tui.keys import KeysScreen, screen_keys
from station.tui.live_screen import LiveScreen
from station.tui.messages import explain, for_the_form
from station.tui.sequence_screen import SequenceScreen
from station.tui.setup_screen import SetupScreen
from station.tui.spec_screen import SpecSheetScreen

CSS = """
.row { height: 3; }
.label { width: 12; padding: 1 1 0 0; }
.label2 { width: auto; padding: 1 1 0 1; }
.short { width: 1fr; }
.small { min-width: 8; width: auto; }
#url, #runs_dir, #path, #seq-units { width: 1fr; }
#profile { width: 1fr; }
SetupScreen #units { height: 1fr; min-height: 4; }
#hint { height: auto; color: $text-muted; padding: 0 1; }
#run-title { height: auto; max-height: 2; padding: 0 1; }
#progress-row { height: 1; padding: 0 1; }
#progress { width: auto; }
#times { width: 1fr; padding: 0 0 0 1; }
LiveScreen #units { height: 2; overflow-x: hidden; }
#plots { height: 1fr; }
#grade { width: 1fr; padding: 1 1 0 1; }
SpecSheetScreen #profile { width: 24; }
#tabs { height: 1fr; }
#exports { height: 3; }
#exports Button { min-width: 10; width: auto; margin: 0 1 0 0; }
#exported { width: 1fr; padding: 0 1; }  /* 3 lines: a folder's path */
#verdict { width: 22; }
#yield { height: auto; padding: 0 1; }
#seq-status { height: auto; padding: 0 1; }
SequenceScreen #unfinished { height: auto; max-height: 5; }
SequenceScreen #steps { height: 1fr; }
SequenceScreen #figures { height: auto; max-height: 10; }
ConfirmScreen { align: center middle; }
#dialog { width: 70; height: 8; border: thick $error; background: $surface; padding: 0 1; }
#question { width: 1fr; padding: 1 0; }
#answers { height: 3; align-horizontal: center; }
#answers Button { margin: 0 2; }
"""


#: The screen each of the app's keys shows.
_SCREEN_OF_ACTION: dict[str, type[Screen[None]]] = {
    "new_run": SetupScreen, "results": ResultsScreen, "runs": RunsScreen,
    "sequence": SequenceScreen}


@dataclass(frozen=True)
class TuiSettings:
    """Where the TUI keeps things and how it behaves.

    Attributes
    ----------
    runs_dir : Path
        Folder of the run files (new runs go here; reattaching looks here).
    reports_dir : Path
        Folder the exported reports go to.
    db_path : str, Path or None
        Results database (None: gradings are not stored).
    db_retry_s : float
        How long a results database that is away is waited for before the spec sheet says
        its grading was not stored, s.
    check_units : bool
        Check that each unit answers when it is added.
    poll_s : float
        Time between reads of a live run file, s.
    attach : bool
        At start, attach to a run in progress found in ``runs_dir``.
    profiles_dir : Path or None
        Folder of the profiles the sequence screen offers (None: the shipped ones).
    """

    runs_dir: Path = Path("runs")
    reports_dir: Path = Path("reports")
    db_path: DatabaseLocation | None = None
    db_retry_s: float = STORE_RETRY_S
    check_units: bool = True
    poll_s: float = 1.0
    attach: bool = True
    profiles_dir: Path | None = None


def crash_log_path(runs_dir: Path) -> Path:
    """Where an unexpected error's traceback is written: the runs folder, else /tmp."""
    import tempfile

    folder = runs_dir if runs_dir.is_dir() else Path(tempfile.gettempdir())
    return folder / "station-tui-crash.log"


class CrashLog(io.TextIOBase):
    """A text file opened on the first write: the app's error console writes an unexpected
    error's traceback here instead of over the operator's terminal.

    ``written`` says whether anything was written, ``failed`` whether the file could not
    be (the disk, permissions).
    """

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = path
        self.written = False
        self.failed = False

    def writable(self) -> bool:
        """A log is written to."""
        return True

    def write(self, text: str) -> int:
        """Append ``text`` to the log (an OSError is remembered, not raised)."""
        self.written = True
        try:
            with self.path.open("a", encoding="utf-8") as f:
                f.write(text)
        except OSError:
            self.failed = True
        return len(text)


@dataclass
class _Recorders:
    """Recorders this TUI started (they outlive it; kept to reap them and for tests)."""

    started: list[RecorderProcess] = field(default_factory=list)


class StationApp(App[None]):
    """``station tui``."""

    TITLE = "Gyro station"
    CSS = CSS
    ENABLE_COMMAND_PALETTE = False  # the footer shows every binding; it needs the room
    #: The footer shows the description, F1 the tooltip; a key to the screen shown is hidden.
    BINDINGS = [
        Binding("f1", "keys", "Help", tooltip="this list: every key of the screen"),
        Binding("f2", "new_run", "New run", tooltip="set up a new run (the first screen)"),
        Binding("f3", "results", "Results",
                tooltip="the results database: gradings by model, lot, verdict; yields"),
        Binding("f4", "runs", "Runs",
                tooltip="the run files of the runs folder, or the path of any run file"),
        Binding("f7", "sequence", "Sequence",
                tooltip="start, follow or resume a test sequence"),
        Binding("ctrl+q", "quit", "Quit", priority=True,
                tooltip="quit (a run or sequence being recorded goes on)"),
    ]

    def __init__(self, settings: TuiSettings | None = None) -> None:
        super().__init__()
        self.settings = settings or TuiSettings()
        self.recorders = _Recorders()
        #: An unexpected error (a bug) ends the app with its traceback in this log, not on
        #: the screen: Textual prints it on the app's error console. The recorder is
        #: another process: a run in progress goes on.
        self.crash_log = CrashLog(crash_log_path(self.settings.runs_dir))
        self.error_console = Console(
            file=cast(IO[str], self.crash_log),
            markup=False,
            highlight=False,
            color_system=None,
            width=120,
        )

    @property
    def crash_message(self) -> str:
        """What to tell the operator when the app ended on an unexpected error ("" if not)."""
        if not self.crash_log.written:
            return ""
        where = ("no log could be written" if self.crash_log.failed
                 else f"the details are in {self.crash_log.path}")
        return (f"station tui stopped on an unexpected error (a bug: please report it; "
                f"{where}). A run in progress goes on recording: reopen `station tui` to "
                f"reattach.")

    def compose(self) -> ComposeResult:
        """Nothing on the default screen: the set-up screen is pushed at once."""
        return iter(())

    def on_mount(self) -> None:
        """Show the set-up screen and look for a run in progress."""
        self.push_screen(SetupScreen(self.settings.runs_dir,
                                     check_units=self.settings.check_units))
        if self.settings.attach:
            self._find_active()

    @work(thread=True, exit_on_error=False)
    def _find_active(self) -> None:
        try:
            active = find_active_runs(self.settings.runs_dir)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.call_from_thread(self.notify, explain(exc, "looking for runs in progress"),
                                  severity="warning")
            return
        if active:
            self.call_from_thread(self._reattach, active)

    def _reattach(self, active: list[Path]) -> None:
        self.push_screen(LiveScreen(active[0], poll_s=self.settings.poll_s))
        more = f" ({len(active) - 1} more: F4)" if len(active) > 1 else ""
        self.notify(f"Reattached to the run in progress {active[0].name}{more}. Quitting the "
                    f"TUI does not stop it.", title="Run in progress", timeout=10)

    # -- screens -----------------------------------------------------------------------
    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """The key to the screen shown is off (and out of the footer, which needs the room)."""
        screen = _SCREEN_OF_ACTION.get(action)
        if screen is None:
            return True
        shown = next((s for s in reversed(self.screen_stack) if not isinstance(s, ModalScreen)),
                     None)  # the screen under a question or the keys list
        return not isinstance(shown, screen)

    def action_keys(self) -> None:
        """F1: every key of the screen shown, with what it does."""
        screen = self.screen
        if not isinstance(screen, KeysScreen):
            # the screen's own title where it has one, else what the header says of it
            name = screen.title if screen.title != self.title else screen.sub_title
            self.push_screen(KeysScreen(name or self.title, screen_keys(self, screen)))

    def action_new_run(self) -> None:
        """Back to the set-up screen."""
        while len(self.screen_stack) > 2:
            self.pop_screen()

    def action_results(self) -> None:
        """The results database browser."""
        from station.output.results import default_database_path

        self.push_screen(ResultsScreen(self.settings.db_path or default_database_path()))

    def action_runs(self) -> None:
        """The run files of the runs folder."""
        self.push_screen(RunsScreen(self.settings.runs_dir))

    def action_sequence(self) -> None:
        """The test sequence screen: start, follow or resume a profile's sequence."""
        self.push_screen(SequenceScreen(self.settings.runs_dir,
                                        profiles_dir=self.settings.profiles_dir,
                                        poll_s=self.settings.poll_s))

    def open_spec_sheet(self, path: Path, *, profile: str | None = None,
                        unit: str | None = None) -> None:
        """Push the spec sheet of a stored run."""
        self.push_screen(SpecSheetScreen(path, self.settings.reports_dir, self.settings.db_path,
                                         profile=profile, unit=unit,
                                         db_retry_s=self.settings.db_retry_s))

    @on(RunChosen)
    def _run_chosen(self, message: RunChosen) -> None:
        if message.recording:
            self.push_screen(LiveScreen(message.path, poll_s=self.settings.poll_s))
        else:
            self.open_spec_sheet(message.path, profile=message.profile, unit=message.unit)

    @on(LiveScreen.SpecSheetRequested)
    def _spec_requested(self, message: LiveScreen.SpecSheetRequested) -> None:
        self.open_spec_sheet(message.path)

    # -- starting a run ----------------------------------------------------------------
    @on(SetupScreen.StartRequested)
    def _start_requested(self, message: SetupScreen.StartRequested) -> None:
        self.notify(f"Starting the recorder for {len(message.request.units)} unit(s): it "
                    f"opens and checks each unit first...", title="New run")
        self._start(message.request)

    @work(thread=True, exclusive=True, group="start", exit_on_error=False)
    def _start(self, request: RecordRequest) -> None:
        try:
            from station.model.durations import parse_duration

            parse_duration(request.duration or "")
            process = start_recording(request)
            self.recorders.started.append(process)
            worker = get_current_worker()
            wait_for_run_file(process, cancelled=lambda: worker.is_cancelled)
        except RecorderStartError as exc:
            problems = "\n".join(for_the_form(str(p)) for p in exc.problems)
            self.call_from_thread(self.notify, f"The run did not start: {problems}",
                                  severity="error", timeout=30)
            return
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.call_from_thread(self.notify, explain(exc, "The run did not start"),
                                  severity="error", timeout=30)
            return
        self.call_from_thread(self._started, process)

    def _started(self, process: RecorderProcess) -> None:
        # the live screen's header says where it records and that it outlives the TUI: a
        # toast here would cover the Allan plot for its first seconds
        self.push_screen(LiveScreen(process.path, process, poll_s=self.settings.poll_s))
