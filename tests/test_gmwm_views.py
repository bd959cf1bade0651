"""The GMWM beside the Allan read-offs in the views that did not carry it: the CSV report and
the TUI's spec screen (``station fleet report``: tests/test_fleet.py), on the short
simulated record with a Gauss-Markov term of tests/test_gmwm_report.py and a profile whose
``[test] gmwm_model`` asks for the GMWM."""

from __future__ import annotations

import asyncio
import csv
import json
from pathlib import Path

import pytest
from textual.widgets import DataTable

from station.cli import main
from station.tui.app import StationApp, TuiSettings
from station.tui.spec_screen import SpecSheetScreen
from tests.test_gmwm_report import gm_unit  # noqa: F401 - the record, a module fixture
from tests.test_grading import profile_text, write_profile
from tests.test_tui import cell_texts, until


@pytest.fixture(scope="module")
def keyed(gm_unit: tuple[Path, Path], tmp_path_factory: pytest.TempPathFactory  # noqa: F811
          ) -> tuple[Path, Path, dict]:
    """The record, a profile with ``gmwm_model = "gm + wn"``, and the JSON sheet of
    ``station report`` (the reference the other views must agree with)."""
    record, _ = gm_unit
    d = tmp_path_factory.mktemp("gmwm-views")
    profile = write_profile(d, profile_text(warmup_s=10.0).replace(
        "[grading]", 'gmwm_model = "gm + wn"\n\n[grading]'), "keyed")
    assert main(["report", str(record), "--profile", str(profile), "--no-store",
                 "--format", "json", "--format", "csv", "--out", str(d)]) == 0
    return record, profile, json.loads((d / "gm_TEST.json").read_text())


def test_csv_report_has_the_gmwm_terms_beside_the_allan_figures(keyed) -> None:
    record, profile, doc = keyed
    axis = doc["units"][0]["axes"]["x"]
    g = axis["gmwm"]
    with (profile.parent / "gm_TEST.csv").open(encoding="utf-8") as fh:
        [row] = list(csv.DictReader(fh))
    assert row["gmwm_model"] == g["model"] == "wn+gm"
    assert float(row["gmwm_p_value"]) == pytest.approx(g["p_value"])
    for key, value in g["params"].items():
        assert float(row[f"gmwm_{key}"]) == pytest.approx(value)
        assert float(row[f"gmwm_{key}_ci_low"]) == pytest.approx(g["ci_low"][key])
        assert float(row[f"gmwm_{key}_ci_high"]) == pytest.approx(g["ci_high"][key])
    assert row["gmwm_gm_tau_s_unit"] == "s" and row["gmwm_wn_deg_rt_h_unit"] == "deg/sqrt(h)"
    assert float(row["arw_value"]) == pytest.approx(axis["figures"]["arw"]["value"])


def test_tui_spec_screen_shows_the_gmwm_rows(keyed, tmp_path: Path) -> None:
    record, profile, doc = keyed
    g = doc["units"][0]["axes"]["x"]["gmwm"]

    async def run() -> None:
        app = StationApp(TuiSettings(runs_dir=tmp_path, reports_dir=tmp_path, attach=False,
                                     check_units=False))
        async with app.run_test(size=(120, 40)) as pilot:
            app.open_spec_sheet(record, profile=str(profile))
            await until(pilot, lambda: isinstance(app.screen, SpecSheetScreen)
                        and app.screen.graded is not None, 60, "the graded sheet")
            screen = app.screen
            await pilot.pause(0.2)
            rows = cell_texts(screen.query_one("#figures", DataTable))
            gm = [r for r in rows if r[0].startswith("GMWM ")]
            assert len(gm) == len(g["params"])
            tau = next(r for r in gm if "Gauss-Markov correlation time" in r[0])
            assert tau[0].endswith("[s]") and float(tau[1]) == pytest.approx(
                g["params"]["gm_tau_s"], rel=1e-2)
            assert any(r[0].startswith("ARW") or "arw" in r[0].lower() for r in rows)
            head = str(screen.query_one("#grade").render())
            assert f"GMWM x: model {g['model']}" in head and "p-value" in head

    asyncio.run(run())
