"""A whole run through ``station tui``: two simulated units with time warp, recorded by a
real, detached recorder process; the TUI is closed and reopened (it reattaches and the run
went on), shows progress, stops the run, shows the spec sheet and exports a report."""

from __future__ import annotations

import asyncio
import json
import os
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from textual.widgets import DataTable, Input, ProgressBar

from station.services.recorder_process import RecorderProcess, pid_alive
from station.tui.app import StationApp, TuiSettings
from station.tui.live_screen import LiveScreen
from station.tui.setup_screen import SetupScreen, short_url
from station.tui.spec_screen import SpecSheetScreen
from tests.test_tui import SIZE, cell_texts, notifications, screen_text, until

#: Two simulated VG951 gyros at 10 Hz over STIM300 and Xbus serial links, 400x time warp:
#: the 4 h run would take 36 s of wall time; the test stops it after a tenth or more (at
#: least 24 simulated minutes: enough to grade after the profile's 5 min warm-up).
URLS = ("sim+serial://VG951?protocol=stim300&rate=10&warp=400&seed=1",
        "sim+serial://VG951?protocol=xbus&rate=10&warp=400&seed=2")


@pytest.fixture
def started() -> Iterator[list[RecorderProcess]]:
    """The recorders the test's apps start; any still running at the end is killed."""
    processes: list[RecorderProcess] = []
    yield processes
    for p in processes:
        if p.popen is not None and p.popen.poll() is None:
            os.killpg(p.popen.pid, signal.SIGKILL)
            p.popen.wait(10)


@pytest.mark.slow
def test_start_reattach_progress_stop_spec_sheet_export(tmp_path: Path,
                                                         started: list[RecorderProcess]) -> None:
    # the product's poll interval: polling every 0.25 s kept the app so busy (a file read,
    # an Allan deviation and a redraw each time) that every Pilot key press waited out
    # Textual's 1-s idle wait, and the run grew longer (more to grade) meanwhile
    settings = TuiSettings(runs_dir=tmp_path / "runs", reports_dir=tmp_path / "reports",
                           db_path=tmp_path / "results.sqlite", check_units=False, poll_s=1.0)
    path = asyncio.run(_start_and_quit(settings, started))
    assert pid_alive(started[0].pid)  # closing the TUI left the recorder recording
    asyncio.run(_reattach_stop_and_grade(settings, path))


async def _start_and_quit(settings: TuiSettings, started: list[RecorderProcess]) -> Path:
    app = StationApp(settings)
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        setup = app.screen
        assert isinstance(setup, SetupScreen)
        for url in URLS:
            await pilot.click("#url")
            setup.query_one("#url", Input).value = url
            await pilot.press("enter")
        duration = setup.query_one("#duration", Input)
        await pilot.click("#duration")
        duration.value = ""
        await pilot.press(*"4h")
        await pilot.click("#operator")
        await pilot.press(*"ann")
        assert [r[1] for r in cell_texts(setup.query_one("#units", DataTable))] == [
            short_url(u) for u in URLS
        ]
        await pilot.press("f5")
        await until(pilot, lambda: app.recorders.started, 10, "the recorder process")
        started.extend(app.recorders.started)
        await until(pilot, lambda: isinstance(app.screen, LiveScreen), 60, "the live screen")
        live = app.screen
        assert isinstance(live, LiveScreen)
        await until(
            pilot,
            lambda: (
                live.snapshot is not None
                and live.snapshot.units
                and all(u.samples for u in live.snapshot.units)
            ),
            30,
            "samples",
        )
        # where it records (the folder) and by which process is on the screen, not in a
        # toast over the Allan plot
        assert f"recorder pid {started[0].pid}" in live.where
        assert f" in {live.path.parent.resolve()}" in live.where
        assert "Run started" not in notifications(app)
        return live.path


async def _reattach_stop_and_grade(settings: TuiSettings, path: Path) -> None:
    app = StationApp(TuiSettings(**{**settings.__dict__, "attach": True}))
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        await until(pilot, lambda: isinstance(app.screen, LiveScreen), 30, "the reattach")
        live = app.screen
        assert isinstance(live, LiveScreen) and live.path == path and live.process is None
        assert "Reattached" in notifications(app)
        app.clear_notifications()  # its toast covers the footer's keys for 10 s
        await until(
            pilot,
            lambda: live.snapshot is not None and live.snapshot.fraction > 0.1,
            40,
            "a tenth of the run",
        )
        snap = live.snapshot
        assert snap is not None and snap.state == "recording" and snap.remaining_wall_s > 0
        assert [u.serial_number for u in snap.units] == ["SIM-1", "SIM-2"]
        bar = live.query_one("#progress", ProgressBar)
        assert 0.1 < (bar.progress or 0) < 1
        words = (
            "recording",
            "of 04:00:00,",
            "left",
            "SIM-1",
            "SIM-2",
            "rate, axis 1",
            "run time [s]",
            "ADEV [deg/h]",
            "tau [s]",
            "s Stop",
        )
        await until(
            pilot,
            lambda: all(w in screen_text(app) for w in words),
            10,
            "the live screen's rows, times and plots",
        )
        await pilot.press("g")  # not yet: the run is recording
        assert "still recording" in notifications(app)
        await pilot.press("s", "e")  # stray typing: any key but y answers no
        assert app.screen is live and live.snapshot.state == "recording"
        await pilot.press("s")
        await pilot.press("y")  # confirm
        await until(
            pilot, lambda: live.snapshot is not None and live.snapshot.stopped, 30, "the stop"
        )
        assert live.snapshot.stop_reason == "terminated (SIGTERM)"
        assert live.snapshot.fraction < 1
        await pilot.press("g")
        sheet = app.screen
        assert isinstance(sheet, SpecSheetScreen)
        await until(pilot, lambda: sheet.graded is not None, 60, "the grading")
        assert sheet.graded.profile.name == "VG951"  # the profile of the units' model
        rows = cell_texts(sheet.query_one("#figures", DataTable))
        assert any(
            r[0] == "N ARW (fit) [deg/sqrt(h)]" and r[3] in ("pass", "fail", "indeterminate")
            for r in rows
        )
        await pilot.press("j")
        reports = settings.reports_dir
        await until(pilot, lambda: list(reports.glob("*.json")), 30, "the report")
        doc = json.loads(next(reports.glob("*.json")).read_text())
        assert [u["serial_number"] for u in doc["units"]] == ["SIM-1", "SIM-2"]
