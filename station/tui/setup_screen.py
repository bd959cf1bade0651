"""The run set-up screen: profile, units (each checked), duration, operator, lot; start."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from urllib.parse import parse_qsl, urlsplit

from textual import on, work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal
from textual.message import Message
from textual.screen import Screen
from textual.widgets import Button, DataTable, Header, Input, Label, Select, Static

from station.model.profiles import anchored_model
from station.services.record import DEFAULT_SIM_URL, RecordRequest, simulated_unit_url
from station.services.recorder_process import UnitCheck, check_unit
from station.tui.keys import StationFooter
from station.tui.messages import explain

#: Time warp of the simulated units F6 adds (simulated seconds per wall second).
SIM_WARP = 60
_NO_PROFILE = "(none: simulated units only)"
#: Characters of a unit's URL the units table shows (the middle is elided, so that the
#: query keys at the end, seed and warp, stay in view): at 80 columns the table's four
#: columns (2 + 26 + a time of up to 16 + an answer of up to 28, a space either side of
#: each) fit, and the answer is not cut.
URL_WIDTH = 26
#: Characters of the "answers?" column.
ANSWER_WIDTH = 28


def short_url(url: str, width: int = URL_WIDTH) -> str:
    """``url`` in ``width`` characters: the start and the end, an ellipsis between."""
    if len(url) <= width:
        return url
    tail = width * 3 // 5
    return url[: width - tail - 1] + "\u2026" + url[-tail:]


def time_text(url: str, duration_s: float | None = None) -> str:
    """How a unit keeps time: ``"real time"``, or ``"x60 (1h in 1min)"`` for a warped simulation."""
    warp = dict(parse_qsl(urlsplit(url).query)).get("warp") if url.startswith("sim+") else None
    try:
        factor = float(warp) if warp is not None else 1.0
    except ValueError:
        return f"warp {warp}"
    if factor == 1.0:
        return "real time"
    if duration_s:
        return f"x{factor:g} ({duration_text(duration_s)} in {duration_text(duration_s / factor)})"
    return f"x{factor:g}"


def check_summary(check: UnitCheck) -> str:
    """One line of the units table for a unit's check."""
    if not check.ok or check.description is None:
        # cut to the column (the whole message is the refusal's notification)
        text = f"no: {check.message.splitlines()[0] if check.message else 'no answer'}"
        return text if len(text) <= ANSWER_WIDTH else text[: ANSWER_WIDTH - 1] + "\u2026"
    d = check.description
    model = Path(d.model).stem if "/" in d.model else d.model
    return f"ok: {model} {d.serial_number or '-'}, {d.sample_rate_hz:g} Hz, {d.n_axes} ax"


def duration_text(seconds: float) -> str:
    """A duration the recorder parses, short: ``2h``, ``90min``, ``45s``."""
    for unit, size in (("h", 3600), ("min", 60)):
        if seconds >= size and seconds % size == 0:
            return f"{seconds / size:g}{unit}"
    return f"{seconds:g}s"


@dataclass(frozen=True)
class ProfileChoice:
    """What the set-up screen takes from a profile."""

    name: str
    duration_s: float
    url: str
    description: str


class SetupScreen(Screen[None]):
    """Set up a run and ask the app to start it (:class:`SetupScreen.StartRequested`).

    Parameters
    ----------
    runs_dir : Path
        Default folder of the run file.
    check_units : bool
        Check that each unit answers when it is added (``station record --check`` in a
        process of its own: the unit is opened, checked and released; nothing is written).
    """

    BINDINGS = [
        Binding("f5", "start", "Start", tooltip="start the run (each unit answers first)"),
        Binding("f6", "add_sim", "Sim unit",
                tooltip=f"add a simulated unit (the profile's, x{SIM_WARP} time warp)"),
        Binding("ctrl+d", "remove_unit", "Remove", tooltip="remove the unit under the cursor"),
    ]

    class StartRequested(Message):
        """The operator asked for this run."""

        def __init__(self, request: RecordRequest) -> None:
            super().__init__()
            self.request = request

    def __init__(self, runs_dir: Path, *, check_units: bool = True) -> None:
        super().__init__()
        self.runs_dir = runs_dir
        self.check_units = check_units
        self.units: list[str] = []
        self.checks: dict[str, UnitCheck | None] = {}
        self.profile: ProfileChoice | None = None

    def compose(self) -> ComposeResult:
        from station.model.profiles import available_profiles

        yield Header()
        with Horizontal(classes="row"):
            yield Label("Profile", classes="label")
            yield Select([(name, name) for name in available_profiles()], prompt=_NO_PROFILE,
                         id="profile")
        with Horizontal(classes="row"):
            yield Label("Unit URL", classes="label")
            yield Input(placeholder="serial:///dev/ttyUSB0?protocol=stim300 or sim+serial://...",
                        id="url")
            yield Button("Add", id="add", classes="small")
        yield DataTable(id="units", cursor_type="row", zebra_stripes=True)
        with Horizontal(classes="row"):
            yield Label("Duration", classes="label")
            yield Input("1h", placeholder="12h, 90min, 30s", id="duration", classes="short")
            yield Label("Operator", classes="label2")
            yield Input(placeholder="name", id="operator", classes="short")
            yield Label("Lot", classes="label2")
            yield Input(placeholder="lot", id="lot", classes="short")
        with Horizontal(classes="row"):
            yield Label("Runs folder", classes="label")
            yield Input(str(self.runs_dir), id="runs_dir")
            yield Button("Start", id="start", variant="success", classes="small")
        yield Static("Enter a device URL and press Enter, or F6 for a simulated unit; "
                     "F5 starts the run.", id="hint")
        yield StationFooter()

    def on_mount(self) -> None:
        """Set up the units table."""
        self.sub_title = "New run"
        table = self.query_one("#units", DataTable)
        table.add_column("#", key="n", width=2)
        table.add_column("device URL", key="url", width=URL_WIDTH)
        table.add_column("time", key="time")
        table.add_column("answers?", key="check")
        self.query_one("#profile", Select).focus()

    # -- profile -----------------------------------------------------------------------
    @on(Select.Changed, "#profile")
    def _profile_changed(self, event: Select.Changed) -> None:
        self.profile = None
        if isinstance(event.value, str):
            self._load_profile(event.value)

    @work(thread=True, exclusive=True, group="profile", exit_on_error=False)
    def _load_profile(self, name: str) -> None:
        from station.model.profiles import load_profile

        try:
            p = load_profile(name)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            self.app.call_from_thread(self.notify, explain(exc, f"reading profile {name}"),
                                      severity="error", timeout=10)
            return
        choice = ProfileChoice(p.name, p.duration_s,
                               anchored_model(str(p.transport.get("url", ""))), p.description)
        self.app.call_from_thread(self._apply_profile, choice)

    def _apply_profile(self, choice: ProfileChoice) -> None:
        self.profile = choice
        self.query_one("#duration", Input).value = duration_text(choice.duration_s)
        url = self.query_one("#url", Input)
        if choice.url and not url.value:
            url.value = choice.url
        self.query_one("#hint", Static).update(
            f"{choice.name}: {choice.description}. Enter adds the URL above; F6 adds a "
            f"simulated unit (x{SIM_WARP} time warp).")

    @on(Input.Changed, "#duration")
    def _duration_changed(self) -> None:
        table = self.query_one("#units", DataTable)
        for url in self.units:
            table.update_cell(url, "time", time_text(url, self._duration_s()), update_width=True)

    # -- units -------------------------------------------------------------------------
    @on(Input.Submitted, "#url")
    @on(Button.Pressed, "#add")
    def _add_from_input(self) -> None:
        url_input = self.query_one("#url", Input)
        if self.add_unit(url_input.value.strip()):
            url_input.value = ""

    def action_add_sim(self) -> None:
        """Add a simulated unit (the profile's simulation if it has one) and say what it is."""
        base = self.profile.url if self.profile else DEFAULT_SIM_URL
        url = simulated_unit_url(base, seed=len(self.units) + 1, warp=SIM_WARP)
        if not self.add_unit(url):
            return
        what = (
            f"the {self.profile.name} profile's simulation"
            if self.profile and base.startswith("sim+")
            else "the default simulated VG951 (STIM300 framing): no profile chosen"
            if not self.profile
            else f"the default simulated VG951: {self.profile.name}'s URL is not a simulation"
        )
        self.notify(
            f"Unit {len(self.units)}: {what}, at {time_text(url, self._duration_s())} of "
            f"wall time.",
            title="Simulated unit added",
            timeout=8,
        )

    def _duration_s(self) -> float | None:
        from station.model.durations import parse_duration

        try:
            return parse_duration(self.query_one("#duration", Input).value.strip())
        except Exception:  # noqa: BLE001 - no duration typed yet: the time column says less
            return None

    def add_unit(self, url: str) -> bool:
        """Add a unit by URL and start its check; False (and a notification) if refused."""
        if not url:
            self.notify(
                "Type a device URL first (see `station devices` for examples), or "
                "press F6 for a simulated unit.",
                severity="warning",
            )
            return False
        if "://" not in url:
            self.notify(
                f"{url!r} is not a device URL: it looks like scheme://device?key=value, "
                f"e.g. serial:///dev/ttyUSB0?protocol=stim300",
                severity="error",
            )
            return False
        if url in self.units:
            self.notify(
                "That unit is in the list already; a second simulated unit needs "
                "another seed= (its serial number).",
                severity="warning",
            )
            return False
        self.units.append(url)
        self.checks[url] = None
        table = self.query_one("#units", DataTable)
        table.add_row(
            str(len(self.units)),
            short_url(url),
            time_text(url, self._duration_s()),
            "checking..." if self.check_units else "not checked",
            key=url,
        )
        if self.check_units:
            self._check(url, self.profile.name if self.profile else None)
        return True

    @work(thread=True, group="check", exit_on_error=False)
    def _check(self, url: str, profile: str | None) -> None:
        try:
            result = check_unit(url, profile)
        except Exception as exc:  # noqa: BLE001 - shown to the operator
            result = UnitCheck(url, False, message=explain(exc, "checking the unit"))
        self.app.call_from_thread(self._checked, result)

    def _checked(self, result: UnitCheck) -> None:
        if result.url not in self.checks:
            return  # removed meanwhile
        self.checks[result.url] = result
        self.query_one("#units", DataTable).update_cell(
            result.url, "check", check_summary(result), update_width=True
        )
        if not result.ok:
            self.notify(
                f"Unit {self.units.index(result.url) + 1} does not answer: {result.message}",
                title="Unit check",
                severity="error",
                timeout=15,
            )

    def action_remove_unit(self) -> None:
        """Remove the unit under the cursor."""
        table = self.query_one("#units", DataTable)
        if not self.units:
            return
        row = min(table.cursor_row, len(self.units) - 1)
        url = self.units[row]
        self.units.remove(url)
        self.checks.pop(url, None)
        table.clear()
        for i, u in enumerate(self.units):
            check = self.checks.get(u)
            table.add_row(
                str(i + 1),
                short_url(u),
                time_text(u, self._duration_s()),
                check_summary(check) if check else "checking...",
                key=u,
            )
        # focus stays with the units (or the URL field when none is left): never the profile
        # list, where the next typed characters would pick a profile
        if self.units:
            table.move_cursor(row=min(row, len(self.units) - 1))
            table.focus()
        else:
            self.query_one("#url", Input).focus()
        self.notify(f"Removed {short_url(url)}.", timeout=4)

    # -- start -------------------------------------------------------------------------
    @on(Button.Pressed, "#start")
    def action_start(self) -> None:
        """Check the form and ask the app to start the recorder."""
        request = self.request()
        if request is not None:
            self.post_message(self.StartRequested(request))

    def request(self) -> RecordRequest | None:
        """The run the form describes, or None (with a notification saying what to fix)."""
        if not self.units:
            self.notify(
                "Add at least one unit: type its URL and press Enter, or F6 for a simulated unit.",
                severity="error",
            )
            return None
        bad = [
            i + 1
            for i, u in enumerate(self.units)
            if (c := self.checks.get(u)) is not None and not c.ok
        ]
        if bad:
            self.notify(
                f"Unit(s) {', '.join(map(str, bad))} did not answer: fix the URL or "
                f"the connection, or remove them (ctrl+d).",
                severity="error",
            )
            return None
        duration = self.query_one("#duration", Input).value.strip()
        if not duration:
            self.notify("Give a duration: 12h, 90min, 30s.", severity="error")
            return None
        profile = self.query_one("#profile", Select).value
        return RecordRequest(
            tuple(self.units),
            duration,
            Path(self.query_one("#runs_dir", Input).value.strip() or str(self.runs_dir)),
            profile if isinstance(profile, str) else None,
            self.query_one("#operator", Input).value.strip(),
            self.query_one("#lot", Input).value.strip(),
        )
