"""``station serve`` in a real headless Chromium: the overview shows the line's numbers, a
unit link leads to its spec sheet, and a run being recorded gains samples on the runs page
without the page reloading (tests/browser.py; chromium missing fails, never skips)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

from station.evaluation.grading import RunGrade
from tests.browser import chromium, served
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


@pytest.mark.slow
def test_overview_unit_sheet_and_a_live_run(graded: RunGrade, tmp_path: Path,  # noqa: F811
                                            recording: tuple[Path, subprocess.Popen]) -> None:
    runs, recorder = recording
    db = _fill(str(tmp_path / "line.sqlite"), graded)
    with served(db, (runs,)) as server, chromium() as driver:
        base = server.wait()
        wait = WebDriverWait(driver, 15)
        driver.get(base + "/")
        lots = driver.find_elements(By.CSS_SELECTOR, "table.lots tr[data-lot]")
        assert [r.get_attribute("data-lot") for r in lots] == ["L1", "L2"]
        assert [td.text for td in lots[1].find_elements(By.TAG_NAME, "td")][:6] == [
            "TG-1", "L2", "6", "5", "0", "1"]
        driver.find_element(By.CSS_SELECTOR, "a[data-serial='S05']").click()
        wait.until(lambda d: "Unit S05" in d.title)
        driver.find_element(By.ID, "sheet-link").click()
        wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "table.figures"))
        assert "GRADE" in driver.find_element(By.TAG_NAME, "h1").text  # rendered afresh
        _wait_for_run_file(runs, recorder)
        driver.get(base + "/runs")
        cell = driver.find_element(By.CSS_SELECTOR, "td[data-field='samples_recorded']")
        first = int(cell.text)
        driver.execute_script("window.stationMarker = 1;")  # gone if the page reloads
        wait.until(lambda d: int(d.find_element(
            By.CSS_SELECTOR, "td[data-field='samples_recorded']").text) > first)
        assert driver.execute_script("return window.stationMarker;") == 1
        assert driver.find_elements(By.CSS_SELECTOR, "svg.allan polyline")
