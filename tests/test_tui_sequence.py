"""A profile's test sequence started from ``station tui`` (a detached ``station record
--sequence`` process), followed step by step, killed (SIGKILL) mid-record, resumed from the
list of unfinished sequences as the command resumes it, and graded: two simulated gyros on a
simulated fixture (relays and chamber over real Modbus on 127.0.0.1), warp x200."""

from __future__ import annotations

import asyncio
import math
import os
import signal
from pathlib import Path

import pytest
from textual.widgets import DataTable, Input, Select

from station.errors import UsageError
from station.services.sequence_process import running_sequence, start_sequence
from station.services.sequence_progress import (
    resume_request,
    sequence_progress,
    unfinished_sequences,
)
from station.storage.sequence_files import read_sequence
from station.tui.app import StationApp, TuiSettings
from station.tui.sequence_screen import SequenceScreen
from tests.test_sequences import PROFILE as SEQUENCE_PROFILE, unit_url as sequence_unit_url
from tests.test_tui import cell_texts, notifications, until

#: The test profile of tests/test_sequences.py with a quick sequence of its own.
PROFILE = SEQUENCE_PROFILE.split("[sequence.")[0] + """[sequence.quick]
steps = ["set_chamber 25", "wait_stable", "repeat 1",
         "power_on", "record 40s", "power_off", "cool_down 5s", "repeat 2"]
bias_after_s = 20
warmup_band_deg_h = 1.0
warmup_average_s = 10
stable_band_c = 0.5
stable_hold_s = 5
[sequence.quick.figures.turn_on_time]
unit = "s"
limits = { A = 15, B = 30 }
[sequence.quick.figures.warmup_time]
unit = "s"
"""


def unit_url(seed: int) -> str:
    """A simulated VG951 at 5 Hz, warp x200, with a turn-on time, bias and warm-up.

    The switch-ons' jitter is wide enough that the two the test grades differ by about 2 s:
    a turn-on time is timed to a few tenths of a second on a loaded machine at x200 (1 ms of
    wall time is 0.2 s), and with 0.5 s of jitter the two once came out 0.07 s apart, an
    interval narrow enough to pass class B."""
    return sequence_unit_url(seed, 200.0, turn_on_s=6, turn_on_jitter_s=2.5,
                             turn_on_bias_deg_h=10, warmup_deg_h=5, warmup_tau_s=10)


@pytest.mark.slow
def test_start_follow_kill_resume_and_figures(tmp_path: Path) -> None:
    profiles = tmp_path / "profiles"
    profiles.mkdir()
    (profiles / "SEQ.toml").write_text(PROFILE, encoding="utf-8")
    settings = TuiSettings(runs_dir=tmp_path / "runs", reports_dir=tmp_path / "reports",
                           check_units=False, poll_s=0.1, attach=False, profiles_dir=profiles)
    asyncio.run(_start_kill_resume(settings))


async def _start_kill_resume(settings: TuiSettings) -> None:
    app = StationApp(settings)
    async with app.run_test(size=(100, 40), notifications=True) as pilot:
        await pilot.press("f7")
        screen = app.screen
        assert isinstance(screen, SequenceScreen)
        screen.query_one("#seq-profile", Select).value = "SEQ"
        await until(pilot, lambda: screen.query_one("#sequence", Select).value == "quick", 10,
                    "the profile's sequences")
        await pilot.press("f5")  # no unit yet: refused with what to do, nothing started
        await until(pilot, lambda: "no unit" in notifications(app), 5, "the refusal")
        assert screen.process is None
        screen.query_one("#seq-units", Input).value = f"{unit_url(1)} {unit_url(2)}"
        await pilot.press("f5")
        # where its files go: the folder is named
        await until(pilot, lambda: "Running quick into" in notifications(app), 10, "the start")
        assert f"in {settings.runs_dir.resolve()} (its log" in notifications(app)
        steps = screen.query_one("#steps", DataTable)
        # followed step by step: the chamber's set point and air, a record's progress
        await until(pilot, lambda: screen.progress is not None
                    and screen.progress.steps[3].state == "running", 60, "the first record")
        rows = cell_texts(steps)
        assert [r[3] for r in rows[:3]] == ["done"] * 3 and rows[3][3] == "running"
        assert rows[0][5].startswith("set 25 °C, air 25") and rows[3][2] == "record 40s"
        assert rows[3][4].endswith("/00:00:40") and rows[6][3] == "pending"
        process = screen.process
        assert process is not None
        # a second start of the running sequence is refused; a later TUI would follow it
        found = running_sequence(process.path)
        assert found is not None and found.pid == process.pid
        request = screen.request()
        assert request is not None
        with pytest.raises(UsageError, match="is running"):
            start_sequence(request)
        os.killpg(process.popen.pid, signal.SIGKILL)  # killed mid-record, fixture and all
        await until(pilot, lambda: screen.graded_path == process.path, 20, "the kill seen")
        assert screen.progress is not None and screen.progress.state == "interrupted"
        assert "killed" in screen.progress.message and running_sequence(process.path) is None
        assert not process.path.with_suffix(".pid").exists()  # an ended process' pid: gone
        # the stopped sequence is offered for resuming, with the request that started it
        unfinished = screen.query_one("#unfinished", DataTable)
        assert unfinished.row_count == 1
        path = screen.progress.path
        [run] = unfinished_sequences(settings.runs_dir)
        request = resume_request(run, settings.runs_dir)
        assert request.power == ("sim",) and request.chamber == "sim"
        assert request.units == (unit_url(1), unit_url(2))
        unfinished.focus()
        await pilot.press("enter")
        await until(pilot, lambda: screen.figures, 40, "the sequence's figures")
        shown = cell_texts(screen.query_one("#figures", DataTable))
    run = read_sequence(Path(path))
    assert run.done and [e.kind for e in run.journal].count("resume") == 1
    progress = sequence_progress(run)
    assert progress.state == "done" and progress.steps_done == len(run.steps)
    figures = {(u, r.label): r for u, r in screen.figures}
    assert {u for u, _ in figures} == {"unit1", "unit2"}
    assert len(shown) == len(figures) and all(r[0] in ("unit1", "unit2") for r in shown)
    turn_on = figures[("unit1", "turn-on time")]
    assert turn_on.ci_low is not None and turn_on.value and turn_on.limit == 15.0
    # two switch-ons at the profile's 99.9 %: an interval too wide to decide, whose upper
    # bound may lie beyond the float range (none: the two values do not bound the mean)
    assert turn_on.ci_low < turn_on.value < (turn_on.ci_high or math.inf)
    assert (turn_on.ci_high or math.inf) > 15.0 and turn_on.verdict == "indeterminate"
    row = next(r for r in shown if r[:2] == ["unit1", "turn-on time"])
    assert row[4] == "15" and row[5] == "indeterminate" and row[2].endswith(" s")
