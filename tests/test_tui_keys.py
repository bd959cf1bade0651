"""``station tui`` at 80x24, driven by the Pilot: every key within reach (in the footer, or
listed by F1), the F4 Run file field with the focus, and F7's units filled in from the
profile as the set-up screen fills in its unit.

Each wait is on a condition (the app's state), never on a length of wall time.
"""

from __future__ import annotations

import asyncio
import os
from pathlib import Path
from typing import Any

import pytest
from textual.binding import Binding
from textual.pilot import Pilot
from textual.widgets import Input, Select

from station.tui.app import StationApp
from station.tui.browse_screens import ResultsScreen, RunsScreen
from station.tui.keys import KeysScreen, StationFooter, footer_rows, screen_keys
from station.tui.live_screen import LiveScreen
from station.tui.sequence_screen import SequenceScreen
from station.tui.setup_screen import SetupScreen
from station.tui.spec_screen import SpecSheetScreen
from tests.test_tui import SIZE, screen_text, settings, until, write_run


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two stored runs; the second is the newer, first in the F4 list."""
    runs = tmp_path_factory.mktemp("tui-keys") / "runs"
    older = write_run(runs / "run-older.h5", duration_s=600.0)
    newer = write_run(runs / "run-newer.h5", duration_s=600.0)
    os.utime(older, (1_000_000_000, 1_000_000_000))
    os.utime(newer, (1_000_000_100, 1_000_000_100))
    return older, newer


def test_footer_lines_hold_what_fits() -> None:
    assert footer_rows([10, 10, 10], 80) == [[0, 1, 2]]
    assert footer_rows([41, 40], 80) == [[0, 1]]  # the last key may lose its margin
    assert footer_rows([41, 41], 80) == [[0], [1]]
    assert footer_rows([100], 80) == [[0]]


@pytest.mark.slow
def test_f4_focuses_the_run_file_field_and_a_typed_path_opens_that_run(
        two_runs: tuple[Path, Path], tmp_path: Path) -> None:
    asyncio.run(_typed_path(two_runs, tmp_path))


async def _typed_path(two_runs: tuple[Path, Path], tmp_path: Path) -> None:
    older, newer = two_runs
    app = StationApp(settings(tmp_path, older.parent, check_units=False))
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        await pilot.press("f4")
        runs = app.screen
        assert isinstance(runs, RunsScreen)
        await until(pilot, lambda: len(runs.listing) == 2, what="the run list")
        assert runs.listing[0].path == newer  # the list's cursor is on the newer run
        field = runs.query_one("#path", Input)
        assert app.focused is field
        await pilot.press(*str(older), "enter")  # typed into the field, not lost
        assert field.value == str(older)
        first = app.screen
        assert isinstance(first, SpecSheetScreen) and first.path == older
        await pilot.press("escape")
        assert app.screen is runs
        field.value = ""
        await pilot.press("down", "up", "down", "enter")  # nothing typed: the list's run
        sheet: object = app.screen
        assert isinstance(sheet, SpecSheetScreen) and sheet.path == older
        await pilot.press("escape")
        field.value = newer.name  # a file name of the runs folder
        await pilot.press("enter")
        sheet = app.screen
        assert isinstance(sheet, SpecSheetScreen) and sheet.path == newer
        await pilot.press("escape")
        field.value = "no-such.h5"
        await pilot.press("enter")
        assert app.screen is runs


def _footer_keys(app: StationApp) -> list[tuple[str, str]]:
    """(key, description) of each key the footer shows inside the 80x24 screen."""
    width, height = SIZE
    shown = []
    for widget in app.screen.query_one(StationFooter).query("FooterKey"):
        key: Any = widget  # textual.widgets._footer.FooterKey: key, description
        region = key.region
        if region.width and region.right <= width and region.bottom <= height:
            shown.append((str(key.key), str(key.description)))
    return shown


async def _keys_within_reach(app: StationApp, pilot: Pilot[None], name: str) -> None:
    """Every key of the screen shown: in its footer (inside the screen) when the binding
    is shown, and listed by F1 in any case; F1 closes again on any key."""
    screen = app.screen
    declared = {b.key for b in [*type(screen).BINDINGS, *StationApp.BINDINGS]
                if isinstance(b, Binding)}  # the station's keys, not Textual's own
    bindings = [(b.key, b) for node, b, enabled, _ in screen.active_bindings.values()
                if enabled and node in (screen, app) and b.key in declared]
    assert len(bindings) >= 6, name
    await until(pilot, lambda: _footer_keys(app), 10, f"the footer of the {name} screen")
    footer = _footer_keys(app)
    hidden = [key for key, b in bindings if b.show and (key, b.description) not in footer]
    assert not hidden, f"{name}: keys not in the footer at 80x24: {hidden}"
    assert ("f1", "Help") in footer, name
    app.clear_notifications()  # a toast covers the footer's right end for a while
    await pilot.pause()
    text = screen_text(app)
    for key, b in bindings:
        if b.show:
            assert f"{app.get_key_display(b)} {b.description}" in text, (name, key)
    await pilot.press("f1")
    keys = app.screen
    assert isinstance(keys, KeysScreen), name
    listed = {k.key for k in keys.keys}
    missing = [app.get_key_display(b) for _, b in bindings
               if app.get_key_display(b) not in listed]
    assert not missing, f"{name}: F1 does not list {missing}"
    shown = screen_text(app)
    assert all(k.text in shown for k in keys.keys), name  # the list fits the screen
    await pilot.press("f5")  # closes the list, and does nothing else
    assert app.screen is screen, name


@pytest.mark.slow
def test_every_key_is_within_reach_at_80x24(two_runs: tuple[Path, Path],
                                            tmp_path: Path) -> None:
    asyncio.run(_every_key(two_runs, tmp_path))


async def _every_key(two_runs: tuple[Path, Path], tmp_path: Path) -> None:
    older, _ = two_runs
    app = StationApp(settings(tmp_path, older.parent, check_units=False))
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        assert isinstance(app.screen, SetupScreen)
        for key in ("f4 Runs", "f7 Sequence", "f3 Results", "^q Quit"):
            assert key in screen_text(app), key  # the ones the footer used to cut off
        assert "f2 New run" not in screen_text(app)  # the screen shown: no key to it
        await _keys_within_reach(app, pilot, "set-up")
        assert not app.recorders.started  # the f5 that closed F1 started nothing
        await pilot.press("f4")
        assert isinstance(app.screen, RunsScreen)
        await _keys_within_reach(app, pilot, "runs")
        await pilot.press("f3")
        assert isinstance(app.screen, ResultsScreen)
        await _keys_within_reach(app, pilot, "results")
        await pilot.press("f7")
        assert isinstance(app.screen, SequenceScreen)
        await _keys_within_reach(app, pilot, "sequence")
        app.push_screen(SpecSheetScreen(older, tmp_path / "reports", None))
        await pilot.pause()
        await _keys_within_reach(app, pilot, "spec sheet")
        keys = {k.key: k.text for k in screen_keys(app, app.screen)}
        assert keys["p"] == "write the PDF report" and keys["d"].endswith("variance tab")
        app.push_screen(LiveScreen(older, poll_s=60.0))
        await pilot.pause()
        await _keys_within_reach(app, pilot, "live")


def test_f7_units_are_filled_in_from_the_profile_as_new_run_does(tmp_path: Path) -> None:
    asyncio.run(_f7_units(tmp_path))


async def _f7_units(tmp_path: Path) -> None:
    app = StationApp(settings(tmp_path, check_units=False))
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        setup = app.screen
        assert isinstance(setup, SetupScreen)
        setup.query_one("#profile", Select).value = "VG951"
        url = setup.query_one("#url", Input)
        await until(pilot, lambda: url.value, 20, "the set-up's unit")
        await pilot.press("f7")
        screen = app.screen
        assert isinstance(screen, SequenceScreen)
        units = screen.query_one("#seq-units", Input)
        assert units.value == ""
        screen.query_one("#seq-profile", Select).value = "VG951"
        await until(pilot, lambda: units.value, 20, "the sequence's units")
        assert units.value == url.value and "model=/" in units.value  # the model found
        assert screen.query_one("#sequence", Select).value == "turn_on"
        screen.query_one("#seq-profile", Select).value = "CRG20"  # not typed: replaced
        await until(pilot, lambda: "CRG20" in units.value, 20, "the other profile's unit")
        units.value = "sim+serial://MINE?seed=4"  # typed by hand: kept
        screen.query_one("#seq-profile", Select).value = "VG951"
        await until(pilot, lambda: screen.query_one("#sequence", Select).value == "turn_on",
                    20, "the profile's sequences")
        assert units.value == "sim+serial://MINE?seed=4"
        # the units field spans the screen, inside it
        assert units.region.right <= SIZE[0]
