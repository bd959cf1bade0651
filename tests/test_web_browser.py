"""``station serve`` in a real headless Chromium: the overview shows the line's numbers and
its charts, a unit link leads to its spec sheet (a note says it is being rendered until it
is there), a figure's control chart is drawn, and a run being recorded gains samples on
the runs page without the page reloading, every time on it to at most three decimals
(tests/browser.py; chromium missing fails, never skips).

Each page's screenshot is saved, into ``$STATION_SCREENSHOTS`` when set (to look at), else
into the test's folder."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

from station.evaluation.grading import RunGrade
from tests.browser import chromium, screenshot, served
from tests.test_production_stats import _fill, graded  # noqa: F401  (a fixture)

#: A simulated VG951 recorded at 20 times real time: samples arrive every poll.
RECORDING_UNIT = "sim+serial://VG951?protocol=xbus&rate=10&warp=20&seed=4"


@pytest.fixture()
def recording(tmp_path: Path):
    """``station record`` starting a run in ``runs/`` (killed at the end: a killed
    recorder leaves a readable file, and the folder goes with the test)."""
    runs = tmp_path / "runs"
    runs.mkdir()
    process = subprocess.Popen(
        [sys.executable, "-m", "station", "record", "--profile", "VG951", "--unit",
         RECORDING_UNIT, "--duration", "20m", "--out", str(runs)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    yield runs, process
    process.kill()
    process.wait(timeout=20)


def _wait_for_run_file(runs: Path, process: subprocess.Popen) -> None:
    deadline = time.monotonic() + 20
    while not list(runs.glob("*.h5")):
        assert process.poll() is None and time.monotonic() < deadline, (
            process.stderr.read().decode() if process.stderr else "no run file")
        time.sleep(0.1)


#: A number written with more than three decimals (on the runs page: a raw float).
FOUR_DECIMALS = re.compile(r"\d\.\d{4,}")


def _raw_floats(seen: str) -> list[str]:
    """The numbers of ``seen`` with more than six significant digits (a float as Python
    prints it, ``0.30000000000000004``; the pages show four)."""
    return [n for n in re.findall(r"\d+\.\d+", seen)
            if len(n.replace(".", "").lstrip("0")) > 6]


def _seen(driver, folder: Path, name: str) -> str:
    """The page's visible text, once its screenshot (the whole page, up to 3000 pixels
    high) is saved as ``folder/name.png``."""
    screenshot(driver, folder / f"{name}.png")
    return str(driver.find_element(By.TAG_NAME, "body").text)


def _drawn(element) -> bool:
    """Whether an element takes room on the page (a chart drawn, not an empty box)."""
    size = element.size
    return bool(element.is_displayed() and size["width"] > 100 and size["height"] > 50)


@pytest.mark.slow
def test_overview_unit_sheet_and_a_live_run(graded: RunGrade, tmp_path: Path,  # noqa: F811
                                            recording: tuple[Path, subprocess.Popen]) -> None:
    runs, recorder = recording
    shots = Path(os.environ.get("STATION_SCREENSHOTS") or tmp_path)
    shots.mkdir(parents=True, exist_ok=True)
    db = _fill(str(tmp_path / "line.sqlite"), graded)
    with served(db, (runs,)) as server, chromium() as driver:
        base = server.wait()
        wait = WebDriverWait(driver, 30)
        driver.get(base + "/")
        seen = _seen(driver, shots, "overview")
        assert _drawn(driver.find_element(By.CSS_SELECTOR, "svg.yield-chart"))
        assert len(driver.find_elements(By.CSS_SELECTOR, "svg.yield-chart g.lot circle")) == 2
        charts = driver.find_elements(By.CSS_SELECTOR, "section.model svg.capability-chart")
        assert charts and all(_drawn(c) for c in charts)
        assert "yield % per lot" in seen and not _raw_floats(seen)
        active = driver.find_element(By.CSS_SELECTOR, "nav span.units b.active")
        assert active.text == "deg" and active.value_of_css_property("color") == (
            "rgba(255, 255, 255, 1)")
        lots = driver.find_elements(By.CSS_SELECTOR, "table.lots tr[data-lot]")
        assert [r.get_attribute("data-lot") for r in lots] == ["L1", "L2"]
        assert [td.text for td in lots[1].find_elements(By.TAG_NAME, "td")][:6] == [
            "TG-1", "L2", "6", "5", "0", "1"]
        driver.find_element(By.CSS_SELECTOR, "section.model table.capability a").click()
        wait.until(lambda d: d.execute_script(
            "const i = document.querySelector('img.control-chart');"
            "return i && i.complete && i.naturalWidth > 0;"))
        assert not _raw_floats(_seen(driver, shots, "figure"))
        assert _drawn(driver.find_element(By.CSS_SELECTOR, "img.control-chart"))
        driver.get(base + "/")
        driver.find_element(By.CSS_SELECTOR, "a[data-serial='S05']").click()
        wait.until(lambda d: "Unit S05" in d.title)
        # the page's load waits for its frame: the note (tests/test_web.py) gone by then
        wait.until(lambda d: d.find_element(By.TAG_NAME, "body").get_attribute(
            "data-sheet-loaded") == "1")
        assert not driver.find_elements(By.ID, "sheet-rendering")  # gone once it is there
        _seen(driver, shots, "unit")
        driver.refresh()  # the sheet now kept: no note
        assert not driver.find_elements(By.ID, "sheet-rendering")
        driver.find_element(By.ID, "sheet-link").click()
        wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "table.figures"))
        assert "GRADE" in driver.find_element(By.TAG_NAME, "h1").text
        _wait_for_run_file(runs, recorder)
        driver.get(base + "/runs")
        cell = driver.find_element(By.CSS_SELECTOR, "[data-field='samples_recorded']")
        first = int(cell.text)
        driver.execute_script("window.stationMarker = 1;")  # gone if the page reloads
        wait.until(lambda d: int(d.find_element(
            By.CSS_SELECTOR, "[data-field='samples_recorded']").text) > first)
        assert driver.execute_script("return window.stationMarker;") == 1
        assert driver.find_elements(By.CSS_SELECTOR, "svg.allan polyline")
        words = driver.execute_script(  # what the page says, less the plots' corner labels
            "const b = document.body.cloneNode(true);"
            "b.querySelectorAll('svg').forEach((s) => s.remove()); return b.innerText;")
        assert not FOUR_DECIMALS.search(words), FOUR_DECIMALS.search(words)
        assert not _raw_floats(_seen(driver, shots, "runs"))
        row = driver.find_element(By.CSS_SELECTOR, "section.run.live tr[data-unit]")
        shown = {c.get_attribute("data-field"): c.text
                 for c in row.find_elements(By.CSS_SELECTOR, "[data-field]")}
        assert shown["model"] == "VG951" and shown["serial_number"] not in ("", "-")
        assert re.fullmatch(r"\d+ %", shown["progress"]), shown
        assert re.fullmatch(r"\d+:\d\d(:\d\d)?", shown["time_left_s"]), shown
        assert re.fullmatch(r"\d+:\d\d(:\d\d)?(\.\d)?", shown["t_s"]), shown
        assert driver.find_element(By.CSS_SELECTOR, "section.run.live .state").text == (
            "recording")
        recorder.kill()  # the recorder gone: the run leaves "Recording now", said so
        recorder.wait(timeout=20)
        wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "section.run.gone"))
        seen = _seen(driver, shots, "runs-recorder-gone")
        state = driver.find_element(By.CSS_SELECTOR, "section.run.gone .state").text
        assert state.startswith("recorder gone") and "No run is being recorded" in seen
        assert driver.find_element(By.CSS_SELECTOR, "section.run.gone [data-field="
                                   "'time_left_s']").text == "-"  # nothing more to wait for
        assert not driver.find_elements(By.CSS_SELECTOR, "section.run.live")
