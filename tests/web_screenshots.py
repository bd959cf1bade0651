"""The screenshots of docs/web.md: ``station serve`` on the demo's database, in headless
Chromium.

``python -m tests.web_screenshots [OUT_DIR] [--runs N]`` records ``station demo``'s run
(two simulated VG951 gyros), grades it into a fresh results database as lot ``DEMO-1``
with its HTML spec sheet recorded (``station report --format html --db``), grades ``N``
(default 16) simulated VG951 runs beside it in lots ``DEMO-2`` and ``DEMO-3``, serves the
database and saves ``web-overview.png``, ``web-figure.png`` (a figure's control chart),
``web-unit.png`` (a unit's sheet) and ``web-runs.png`` (the runs page: a simulated VG951
being recorded at 20 times real time beside the demo's finished run) into OUT_DIR (default
docs/figures), each of the whole page. About three minutes.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from urllib.parse import quote
from urllib.request import urlopen

from tests.browser import chromium, screenshot, served


def station(*args: str) -> None:
    """Run ``station ARGS`` (quiet), failing loudly."""
    subprocess.run([sys.executable, "-m", "station", *args], check=True,
                   stdout=subprocess.DEVNULL)


def demo_database(folder: Path, runs: int) -> Path:
    """The demo's run and ``runs`` simulated ones, graded into ``folder/demo.sqlite``."""
    db = folder / "demo.sqlite"
    station("demo", "--out", str(folder))
    demo_run = str(folder / "demo-run.h5")
    station("report", demo_run, "--profile", "VG951", "--format", "html", "--out",
            str(folder / "sheets"), "--db", str(db), "--lot", "DEMO-1")
    for i in range(runs):
        run = folder / f"sim-{i}.h5"
        station("simulate", "--model", "VG951", "--duration", "2h", "--axes", "3", "--seed",
                str(100 + i), "--quiet", "--out", str(run))
        station("grade", str(run), "--profile", "VG951", "--db", str(db), "--lot",
                "DEMO-2" if i < runs // 2 else "DEMO-3", "--operator", "line 1")
    return db


def main(argv: list[str] | None = None) -> int:
    """Build the database, serve it, take the four screenshots."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=Path("docs/figures"))
    parser.add_argument("--runs", type=int, default=16)
    args = parser.parse_args(argv)
    from selenium.webdriver.common.by import By

    with tempfile.TemporaryDirectory(prefix="station-web-") as tmp:
        db = demo_database(Path(tmp), args.runs)
        runs = Path(tmp) / "runs"
        runs.mkdir()
        shutil.copy(Path(tmp) / "demo-run.h5", runs / "demo-run.h5")
        recorder = subprocess.Popen(
            [sys.executable, "-m", "station", "record", "--profile", "VG951", "--unit",
             "sim+serial://VG951?protocol=xbus&rate=10&warp=20&seed=4", "--duration", "20m",
             "--lot", "DEMO-4", "--operator", "line 1", "--quiet", "--out", str(runs)],
            stdout=subprocess.DEVNULL)
        try:
            with served(db, (runs,)) as server, chromium(1280, 900) as driver:
                base = server.wait()
                driver.get(base + "/")
                screenshot(driver, args.out / "web-overview.png")
                figure = driver.find_element(By.CSS_SELECTOR, "table.capability a")
                figure.click()
                screenshot(driver, args.out / "web-figure.png")
                with urlopen(base + "/api/overview?lot=DEMO-1") as answer:
                    serial = json.load(answer)["gradings"][0]["serial_number"]
                driver.get(f"{base}/units/{quote(serial, safe='')}")  # waits for the sheet
                screenshot(driver, args.out / "web-unit.png", most_px=1400)
                time.sleep(20)  # a minute of the 20 recorded at 20 times real time
                driver.get(base + "/runs")
                screenshot(driver, args.out / "web-runs.png")
        finally:
            recorder.kill()
            recorder.wait(timeout=20)
    for name in ("web-overview", "web-figure", "web-unit", "web-runs"):
        print(args.out / f"{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
