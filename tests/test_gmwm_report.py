"""The spec sheet's GMWM page: ``station report --method gmwm`` and the profile's
``[test] gmwm_model``, on a short simulated record with a Gauss-Markov term."""

from __future__ import annotations

import json
from html.parser import HTMLParser
from pathlib import Path

import pytest
from pypdf import PdfReader

from station.cli import main
from station.errors import ProfileError
from station.model.profiles import parse_profile
from station.storage.csv_records import write_csv_record
from tests.test_gmwm import FS, TRUE_MODEL, rate_of
from tests.test_grading import profile_text, write_profile


@pytest.fixture(scope="module")
def gm_unit(tmp_path_factory) -> tuple[Path, Path]:
    """20 min at 10 Hz of white noise + GM (20 deg/h, 30 s) + RRW; a one-axis profile."""
    d = tmp_path_factory.mktemp("gmwm-report")
    record = write_csv_record(d / "gm.csv", rate_of(TRUE_MODEL, 9, 12_000, axes=1), FS,
                              axis_names=["x"])
    return record, write_profile(d, profile_text(warmup_s=10.0))


@pytest.fixture(scope="module")
def reports(gm_unit, tmp_path_factory) -> Path:
    record, profile = gm_unit
    out = tmp_path_factory.mktemp("sheets")
    args = ["report", str(record), "--profile", str(profile), "--out", str(out), "--no-store",
            "--method", "gmwm", "--model", "auto"]
    assert main([*args, "--format", "pdf", "--format", "html", "--format", "json"]) == 0
    return out


class _Gmwm(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, str]] = []
        self.alts: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        if tag == "tr" and "data-key" in a:
            self.rows.append(a)
        elif tag == "img":
            self.alts.append(a["alt"] + " " + a["src"][:22])


@pytest.mark.slow
def test_pdf_sheet_has_the_gmwm_terms_beside_the_allan_read_offs(reports: Path) -> None:
    doc = json.loads((reports / "gm_TEST.json").read_text())
    axis = doc["units"][0]["axes"]["x"]
    g = axis["gmwm"]
    assert g["ranking"][0]["model"] == g["model"] and len(g["ranking"]) > 2
    assert "gm_tau_s" in g["params"]  # the hidden Gauss-Markov term is selected
    pages = PdfReader(reports / "gm_TEST.pdf").pages
    assert len(pages) == 3  # the unit's sheet, its GMWM page, its test record
    text = pages[1].extract_text()
    assert "GMWM noise model" in text and f"model {g['model']}" in text
    assert "Gauss-Markov correlation time" in text and "deg/sqrt(h)" in text
    assert f"{g['params']['gm_tau_s']:.4g}" in text and f"{g['stderr']['gm_tau_s']:.4g}" in text
    assert f"{axis['figures']['arw']['value']:.4g} (ARW read-off)" in text
    assert "p-value" in text and "runner-up" in text and "selected by the WIC" in text
    assert "Haar wavelet variance" in text and "Allan fit (logwls) as AVAR/2" in text


def test_html_sheet_has_the_gmwm_table_and_the_wavelet_plot(reports: Path) -> None:
    parser = _Gmwm()
    parser.feed((reports / "gm_TEST.html").read_text(encoding="utf-8"))
    g = json.loads((reports / "gm_TEST.json").read_text())["units"][0]["axes"]["x"]["gmwm"]
    assert {r["data-key"] for r in parser.rows} == set(g["params"])
    tau = next(r for r in parser.rows if r["data-key"] == "gm_tau_s")
    assert float(tau["data-value"]) == pytest.approx(g["params"]["gm_tau_s"])
    wavelet = [a for a in parser.alts if a.startswith("Haar wavelet variance")]
    assert len(wavelet) == 1 and wavelet[0].endswith("data:image/png;base64,")


def test_profile_key_and_bad_options(gm_unit, tmp_path: Path, capsys) -> None:
    record, _ = gm_unit
    profile = write_profile(tmp_path, profile_text(warmup_s=10.0).replace(
        "[grading]", 'gmwm_model = "gm + wn"\n\n[grading]'), "keyed")
    base = ["report", str(record), "--profile", str(profile), "--no-store", "--format", "json"]
    assert main([*base, "--out", str(tmp_path / "a")]) == 0  # the profile's model, no option
    doc = json.loads((tmp_path / "a" / "gm_TEST.json").read_text())
    assert doc["units"][0]["axes"]["x"]["gmwm"]["model"] == "wn+gm"
    assert main([*base, "--out", str(tmp_path / "b"), "--method", "allan"]) == 0
    assert "gmwm" not in json.loads((tmp_path / "b" / "gm_TEST.json").read_text()
                                    )["units"][0]["axes"]["x"]
    capsys.readouterr()
    for bad, said in ((["--model", "wn+gm"], "--method gmwm"),
                      (["--method", "gmwm", "--model", "wn+pink"], "unknown GMWM term")):
        assert main([*base, "--out", str(tmp_path / "c"), *bad]) == 2
        err = capsys.readouterr().err
        assert said in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "c").exists()  # refused before anything was graded or written
    with pytest.raises(ProfileError, match="gmwm_model"):
        parse_profile(profile_text().replace("[grading]", 'gmwm_model = "wn+pink"\n[grading]'))
