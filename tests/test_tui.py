"""``station tui`` driven by the Pilot: a stored run's spec sheet, the results browser, the
set-up screen's checks, and the screens' layout at 80x24 (text of ``export_screenshot``).

The start-to-end run with a real recorder process is in ``tests/test_tui_run.py``.
"""

from __future__ import annotations

import asyncio
import html
import json
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from textual.pilot import Pilot
from textual.widgets import DataTable, Input, Select, Static

from devices.protocols import DeviceDescription
from station.commands.demo import simulate_demo_record
from station.errors import Problem
from station.model.documents import (
    Descriptor,
    EventBatch,
    LogEntry,
    RunStart,
    RunStop,
    data_keys,
    utc_now,
)
from station.model.profiles import anchored_model
from station.model.runs import RunMetadata
from station.services.record import RecordRequest, recorder_arguments, simulated_unit_url
from station.storage.hdf5_writer import RunFileWriter
from station.tui.app import StationApp, TuiSettings
from station.tui.browse_screens import ResultsScreen, RunsScreen
from station.tui.live import RunPoller, decimate
from station.tui.messages import for_the_form
from station.tui.setup_screen import SetupScreen, duration_text
from station.tui.spec_screen import SpecSheetScreen
from station.tui.widgets import interval_text

SIZE = (80, 24)
RATE_HZ = 10.0


def write_run(path: Path, *, duration_s: float = 1800.0, close: bool = True) -> Path:
    """A two-unit VG951 run file written from run documents (no device, no recorder)."""
    writer = RunFileWriter(path, flush_interval_s=0.5)
    writer(RunStart("uid-tui", "2026-11-20T08:00:00Z", ("unit1", "unit2"), duration_s, str(path),
                    RunMetadata(profile="VG951", profile_version="1", operator="ann",
                                lot="LOT-9", station_host="bench", software_version="0.1.0")))
    for i, uid in enumerate(("unit1", "unit2")):
        d = DeviceDescription(model="VG951", serial_number=f"SN-{i + 1}", protocol="stim300",
                              transport="serial", axes=("x", "y", "z"), sample_rate_hz=RATE_HZ,
                              has_counter=True, counter_modulus=256, has_device_time=False,
                              has_temperature=True, settings=())
        writer(Descriptor(uid, f"sim+serial://VG951?seed={i + 1}", d, data_keys(d), utc_now(),
                          "simulated device clock, warp x1", 1.0))
        rate = simulate_demo_record(duration_s, RATE_HZ, seed=7 + i).rate_deg_s
        n = len(rate)
        counter = np.arange(n, dtype=np.int64)
        log = (LogEntry("gap", 600.0, 1, 5, 5999, "counter"),) if i else ()
        writer(EventBatch(uid, 0, rate, counter, counter / RATE_HZ, np.zeros(n, np.uint32),
                          temperature_c=np.full(n, 31.5), log=log))
    writer.flush()
    if close:
        writer(RunStop(utc_now(), "duration"))
    return path


@pytest.fixture(scope="module")
def stored_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_run(tmp_path_factory.mktemp("tui-run") / "runs" / "run-stored.h5")


def settings(tmp: Path, runs: Path | None = None, **kw: object) -> TuiSettings:
    return TuiSettings(runs_dir=runs or tmp / "runs", reports_dir=tmp / "reports",
                       db_path=tmp / "results.sqlite", attach=False, **kw)  # type: ignore[arg-type]


async def until(pilot: Pilot, condition: Callable[[], object], timeout_s: float = 30.0,
                what: str = "") -> None:
    """Let the app run until ``condition()`` is true (fails after ``timeout_s``, wall s)."""
    for _ in range(int(timeout_s / 0.05)):
        if condition():
            return
        await pilot.pause(0.05)
    raise AssertionError(f"timed out waiting for {what or condition}")


def screen_text(app: StationApp) -> str:
    """The visible text of the screen (the SVG screenshot without its markup)."""
    svg = app.export_screenshot()
    rows = re.findall(r'<text[^>]*>(.*?)</text>', svg, flags=re.S)
    return html.unescape("".join(rows)).replace("\xa0", " ")


def notifications(app: StationApp) -> str:
    """The notifications the operator sees now: the title and message of each toast shown."""
    return "\n".join(toast.render().plain for toast in app.screen.query("Toast"))


def cell_texts(table: DataTable) -> list[list[str]]:
    return [[str(c) for c in table.get_row_at(i)] for i in range(table.row_count)]


# -- helpers without the app ----------------------------------------------------------------

def test_recorder_arguments_and_messages() -> None:
    req = RecordRequest(("sim+serial://A?seed=1", "sim+can://B"), "2h", Path("runs/r.h5"),
                        "VG951", "ann", "L1")
    args = recorder_arguments(req)
    assert args[:2] == ["--out", "runs/r.h5"] and args[args.index("--duration") + 1] == "2h"
    assert args.count("--unit") == 2 and args[args.index("--profile") + 1] == "VG951"
    assert args[args.index("--lot") + 1] == "L1" and "--bench" not in args
    problem = Problem("not enough space: choose another --out, or shorten --duration")
    assert for_the_form(str(problem)) == ("not enough space: choose another runs folder, or "
                                          "shorten duration")
    assert str(Problem("bad device URL", "unit1", "sim+serial://X")) == (
        "unit1 (sim+serial://X): bad device URL")


def test_sim_url_and_duration_text(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    url = simulated_unit_url("sim+serial://VG951?model=profiles/models/VG951.toml&rate=10",
                             seed=3, warp=60)
    assert url == "sim+serial://VG951?model=profiles/models/VG951.toml&rate=10&seed=3&warp=60"
    assert simulated_unit_url("serial:///dev/ttyUSB0", seed=1, warp=60).startswith(
        "sim+serial://VG951?")
    url = "sim+serial://VG951?model=profiles/models/VG951.toml&rate=10"
    monkeypatch.chdir(tmp_path)  # a folder without profiles/
    anchored = anchored_model(url)
    assert anchored.startswith("sim+serial://VG951?model=/") and Path(
        anchored.split("model=")[1].split("&")[0]).is_file()  # works from any folder
    assert [duration_text(s) for s in (7200, 5400, 90, 0.5)] == ["2h", "90min", "90s", "0.5s"]
    assert interval_text(1.512, 1.538) == "1.51..1.54" and interval_text(38.2, 60.1) == "38..60"
    assert interval_text(None, 2.0) == "-..2"


def test_poller_reads_a_growing_file_incrementally(tmp_path: Path) -> None:
    path = write_run(tmp_path / "live.h5", duration_s=3600.0, close=False)
    poller = RunPoller(path, max_samples_per_poll=10_000)
    first = poller.poll()  # 36000 samples per unit: caught up over several polls
    assert first.state == "recording" and not first.caught_up
    assert [u.samples for u in first.units] == [36000, 36000]
    while not (snap := poller.poll()).caught_up:
        pass
    assert snap.elapsed_s == pytest.approx(3600, abs=0.2) and snap.fraction == pytest.approx(
        1, abs=1e-3
    )
    assert snap.units[1].gaps == 1 and snap.units[1].missing == 5
    assert snap.units[0].temperature_c == 31.5 and snap.units[0].model == "VG951"
    tau, adev = snap.adev[0].x, snap.adev[0].y
    assert tau[0] == pytest.approx(0.1) and len(tau) >= 10 and np.all(adev > 0)
    assert len(snap.rate[0].x) <= 400  # decimated for the terminal
    x, y = decimate(np.arange(1000.0), np.arange(1000.0), 100)
    assert len(x) == 100 and y[0] == pytest.approx(4.5)


# -- the app --------------------------------------------------------------------------------

@pytest.mark.slow
def test_spec_sheet_of_a_stored_run_and_its_export(stored_run: Path, tmp_path: Path) -> None:
    asyncio.run(_spec_sheet_of_a_stored_run(stored_run, tmp_path))


async def _spec_sheet_of_a_stored_run(stored_run: Path, tmp_path: Path) -> None:
    app = StationApp(settings(tmp_path, stored_run.parent, check_units=False))
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        await pilot.press("f4")  # Runs: the folder's run files
        runs = app.screen
        assert isinstance(runs, RunsScreen)
        await until(pilot, lambda: runs.listing, what="the run list")
        assert runs.listing[0].state == "stopped"
        await pilot.press("enter")
        sheet = app.screen
        assert isinstance(sheet, SpecSheetScreen)
        await until(pilot, lambda: sheet.graded is not None, 40, "the grading")
        rows = cell_texts(sheet.query_one("#figures", DataTable))
        labels = [r[0] for r in rows]
        assert "N ARW (fit) [deg/sqrt(h)]" in labels and "|bias| [deg/h]" in labels
        assert {r[3] for r in rows} <= {"pass", "fail", "indeterminate", "info"}
        text = screen_text(app)
        assert (
            "Spec sheet: run-stored.h5" in text and "SN-1: " in text and "axis x (1/1, n)" in text
        )
        assert "N ARW (fit) [deg/sqrt(h)]" in text and "PDF (p)" in text
        assert all(r[4] in text for r in rows)  # the CI column fits in 80 columns
        sheet.query_one("#profile", Select).value = "CRG20"  # re-grade with another profile
        await until(pilot, lambda: sheet.graded.profile.name == "CRG20", 40, "the re-grading")
        await pilot.press("u")  # the second unit, with its gap
        await until(pilot, lambda: "SN-2" in screen_text(app), what="unit 2")
        await pilot.press("r")
        assert "samples missing: 5" in screen_text(app)
        await pilot.press("a")
        assert "Allan deviation" in screen_text(app) and "tau [s]" in screen_text(app)
        await pilot.press("j")  # export JSON
        reports = tmp_path / "reports"
        await until(pilot, lambda: list(reports.glob("*.json")), what="the JSON report")
        doc = json.loads(next(reports.glob("*.json")).read_text())
        assert len(doc["units"]) == 2
        await until(pilot, lambda: "Wrote" in notifications(app), what="the notification")
        # the folder it went to, not only the file's name
        assert f"in {reports.resolve()}" in notifications(app)
        assert f"in {reports.resolve()}" in str(sheet.query_one("#exported", Static).render())
        await pilot.press("f3")  # results browser: the grading was stored
        results = app.screen
        assert isinstance(results, ResultsScreen)
        await until(pilot, lambda: results.rows, what="the results")
        assert {r.serial_number for r in results.rows} == {"SN-1", "SN-2"}
        assert "LOT-9" in screen_text(app) and "Yield: lot LOT-9" in screen_text(app)
        await pilot.press("enter")  # the newest grading's spec sheet: unit2 of the run
        again = app.screen
        assert isinstance(again, SpecSheetScreen) and again.first_unit == "unit2"
        await until(pilot, lambda: again.graded is not None, 40, "the grading")
        assert "SN-2" in screen_text(app)
        await pilot.press("escape")
        assert app.screen is results
        await pilot.click("#lot")
        await pilot.press(*"NOPE", "enter")  # filter by a lot that does not exist
        await until(pilot, lambda: not results.rows, what="the filter")
        assert "0 gradings" in screen_text(app)


@pytest.mark.slow
def test_setup_screen_checks_each_unit_and_refuses_a_bad_one(tmp_path: Path) -> None:
    asyncio.run(_setup_checks(tmp_path))


async def _setup_checks(tmp_path: Path) -> None:
    app = StationApp(settings(tmp_path))
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        setup = app.screen
        assert isinstance(setup, SetupScreen)
        text = screen_text(app)
        for word in ("Profile", "Unit URL", "Duration", "Operator", "Lot", "Runs folder",
                     "f5 Start", "f6 Sim unit", "f3 Results", "f4 Runs", "f7 Sequence"):
            assert word in text, word
        await pilot.press("f5")  # nothing to start yet
        assert "Add at least one unit" in notifications(app)
        await pilot.click("#url")
        await pilot.press(*"no-url", "enter")
        assert "not a device URL" in notifications(app)
        setup.query_one("#url", Input).value = "sim+serial://NOPE?protocol=stim300&rate=10"
        await pilot.press("enter")
        # said while its toast shows (15 s of wall time: not after the second unit's check)
        await until(pilot, lambda: "does not answer" in notifications(app), 60, "the refusal")
        await pilot.press("f6")  # a simulated unit that answers
        await until(pilot, lambda: all(setup.checks.values()), 60, "the unit checks")
        bad, good = (setup.checks[u] for u in setup.units)
        assert not bad.ok and bad.message.startswith("bad device URL")  # without unit1 (URL)
        assert good.ok and good.description is not None
        assert good.description.model == "VG951" and good.description.serial_number == "SIM-2"
        rows = cell_texts(setup.query_one("#units", DataTable))
        assert rows[1][3] == "ok: VG951 SIM-2, 10 Hz, 3 ax"
        # the four columns fit 80 columns: the answer is not cut on a small terminal
        assert setup.query_one("#units", DataTable).virtual_size.width <= 80
        await pilot.press("f5")
        assert "did not answer" in notifications(app)
        assert not list((tmp_path / "runs").glob("*.h5"))  # nothing was started


def test_setup_screen_says_what_f6_adds_and_ctrl_d_keeps_focus_off_profiles(tmp_path: Path) -> None:
    asyncio.run(_setup_keys(tmp_path))


async def _setup_keys(tmp_path: Path) -> None:
    app = StationApp(settings(tmp_path))
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        setup = app.screen
        assert isinstance(setup, SetupScreen)
        setup.check_units = False
        await pilot.press("f6", "f6")
        told = notifications(app)
        assert "no profile chosen" in told and "x60 (1h in 1min) of wall time" in told
        table = setup.query_one("#units", DataTable)
        rows = cell_texts(table)
        assert all("warp=60" in row[1] and row[2] == "x60 (1h in 1min)" for row in rows)
        setup.query_one("#duration", Input).value = "2h"
        await pilot.pause()
        assert cell_texts(table)[0][2] == "x60 (2h in 2min)"
        table.focus()
        await pilot.press("ctrl+d")
        assert len(setup.units) == 1 and app.focused is table
        await pilot.press("ctrl+d")
        url = setup.query_one("#url", Input)
        assert not setup.units and app.focused is url
        await pilot.press(*"sim")  # goes into the URL field, not the profile list
        assert url.value == "sim" and setup.profile is None


class _Buggy(StationApp):
    """The app with a key bound to a bug."""

    BINDINGS = [*StationApp.BINDINGS, ("f9", "bug", "Bug")]

    def action_bug(self) -> None:
        raise RuntimeError("a bug")


def test_an_unexpected_error_goes_to_a_log_not_the_screen(tmp_path: Path) -> None:
    (tmp_path / "runs").mkdir()
    app = _Buggy(settings(tmp_path))

    async def press_the_bug() -> None:
        async with app.run_test(size=SIZE, notifications=True) as pilot:
            await pilot.press("f9")
            await pilot.pause(0.1)

    with pytest.raises(RuntimeError, match="a bug"):  # the Pilot re-raises it for the test
        asyncio.run(press_the_bug())
    log = tmp_path / "runs" / "station-tui-crash.log"
    assert "RuntimeError: a bug" in log.read_text()
    assert str(log) in app.crash_message and "reattach" in app.crash_message


@pytest.mark.slow
def test_a_run_the_recorder_refuses_is_a_notification_with_the_fix(tmp_path: Path) -> None:
    async def start_a_bad_unit() -> None:
        app = StationApp(settings(tmp_path, check_units=False))
        async with app.run_test(size=SIZE, notifications=True) as pilot:
            app.screen.query_one("#url", Input).value = "sim+serial://NOPE?rate=10"
            await pilot.click("#url")
            await pilot.press("enter", "f5")
            await until(
                pilot, lambda: "did not start" in notifications(app), 60, "the recorder's refusal"
            )
            text = notifications(app)
            assert "bad device URL" in text and "station devices" in text
            assert isinstance(app.screen, SetupScreen)  # still there, to fix the URL
            assert all(p.exit_code() == 2 for p in app.recorders.started)

    asyncio.run(start_a_bad_unit())
