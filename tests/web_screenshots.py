"""The screenshots of docs/web.md: ``station serve`` on the demo's database, in headless
Chromium.

``python -m tests.web_screenshots [OUT_DIR] [--runs N]`` records ``station demo``'s run
(two simulated VG951 gyros), grades it into a fresh results database as lot ``DEMO-1``
with its HTML spec sheet recorded (``station report --format html --db``), grades ``N``
(default 16) simulated VG951 runs beside it in lots ``DEMO-2`` and ``DEMO-3``, serves the
database and saves ``web-overview.png``, ``web-figure.png`` (a figure's control chart) and
``web-unit.png`` (a unit's sheet) into OUT_DIR (default docs/figures). About two minutes.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from urllib.parse import quote
from urllib.request import urlopen

from tests.browser import chromium, served


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
    """Build the database, serve it, take the three screenshots."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=Path("docs/figures"))
    parser.add_argument("--runs", type=int, default=16)
    args = parser.parse_args(argv)
    from selenium.webdriver.common.by import By

    with tempfile.TemporaryDirectory(prefix="station-web-") as tmp:
        db = demo_database(Path(tmp), args.runs)
        with served(db) as server, chromium(1280, 1400) as driver:
            base = server.wait()
            driver.get(base + "/")
            driver.save_screenshot(str(args.out / "web-overview.png"))
            figure = driver.find_element(By.CSS_SELECTOR, "table.capability a")
            figure.click()
            driver.save_screenshot(str(args.out / "web-figure.png"))
            with urlopen(base + "/api/overview?lot=DEMO-1") as answer:
                serial = json.load(answer)["gradings"][0]["serial_number"]
            driver.get(f"{base}/units/{quote(serial, safe='')}")
            driver.save_screenshot(str(args.out / "web-unit.png"))
    for name in ("web-overview", "web-figure", "web-unit"):
        print(args.out / f"{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
