"""``station reconcile``: the JSON interface, the text report, the figure, and errors."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, BiasInstability, NoiseModel, Sinusoid
from devices.model_files import save_noise_model
from station import cli
from station.storage.csv_records import write_csv_record

FS_HZ = 10.0
BASE = NoiseModel(
    terms=(AngleRandomWalk(N_deg_rt_h=0.5), BiasInstability(B_deg_h=2.0)), name="base"
)
#: A sinusoid of 0.28 sigma_w amplitude (variance 0.04 sigma_w^2): invisible in the rate plot.
HIDDEN = Sinusoid(amplitude_deg_h=0.28 * 0.5 * 60.0 * np.sqrt(FS_HZ), period_s=83.0, phase_deg=30.0)


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    # 12 Monte Carlo runs: enough for the interface, cheaper than the default 20
    rc = cli.main([*argv] if "--runs" in argv else [*argv, "--runs", "12"])
    out = capsys.readouterr()
    return rc, out.out, out.err


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reconcile")
    chunk = simulate(BASE.with_term(HIDDEN), 1800.0, FS_HZ, n_axes=2, seed=77)
    record = write_csv_record(folder / "run.csv", chunk.rate_deg_s, FS_HZ)
    model = save_noise_model(BASE, folder / "base.toml", comment="the model without the sinusoid")
    return folder, record, model


def test_json_names_the_hidden_sinusoid_with_units_in_the_keys(files, capsys):
    folder, record, model = files
    png = folder / "out.png"
    rc, out, err = _run(capsys, "reconcile", str(record), "--model", str(model), "--axis", "gyro_x",
                        "--png", str(png), "--json")
    assert rc == 0, err
    doc = json.loads(out)
    assert {"gap_before", "gap_after", "effects", "model_after"} <= set(doc)
    assert doc["gap_before"] >= 5 * doc["gap_after"]
    [effect] = doc["effects"]
    assert effect["name"] == "sinusoid"
    assert effect["params"]["period_s"] == pytest.approx(83.0, rel=0.02)
    assert set(effect["params"]) == {"amplitude_deg_h", "period_s", "phase_deg"}
    lo, hi = effect["tau_range_s"]
    assert 0 < lo < 83.0 < hi
    assert doc["model_after"]["sinusoid"]["period_s"] == effect["params"]["period_s"]
    assert doc["model_after"]["arw"] == {"N_deg_rt_h": 0.5}
    assert [a["axis"] for a in doc["axes"]] == ["gyro_x"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_model_after_loads_back_as_a_model(files, capsys, tmp_path):
    _, record, model = files
    rc, out, _ = _run(
        capsys, "reconcile", str(record), "--model", str(model), "--axis", "gyro_y", "--json"
    )
    assert rc == 0
    after = NoiseModel.from_tables(json.loads(out)["model_after"])
    assert "sinusoid" in after and "arw" in after


def test_text_report_tells_each_step(files, capsys):
    _, record, model = files
    rc, out, _ = _run(capsys, "reconcile", str(record), "--model", str(model), "--axis", "gyro_x")
    assert rc == 0
    for words in ("model before", "gap G", "round 1", "sinusoid", "accepted", "periodogram peak",
                  "model after", "[sinusoid]"):
        assert words in out, words


def test_a_model_that_fits_reports_no_effect(files, capsys, tmp_path):
    _, record, _ = files
    full = save_noise_model(BASE.with_term(HIDDEN), tmp_path / "full.toml")
    rc, out, _ = _run(
        capsys, "reconcile", str(record), "--model", str(full), "--axis", "gyro_x", "--json"
    )
    assert rc == 0
    doc = json.loads(out)
    assert doc["effects"] == [] and doc["excess_terms"] == []
    assert doc["gap_after"] == doc["gap_before"]


def test_errors_are_reported_not_raised(files, capsys, tmp_path):
    _, record, model = files
    rc, _, err = _run(capsys, "reconcile", str(record), "--model", str(tmp_path / "missing.toml"))
    assert rc == 2 and "no model file" in err
    rc, _, err = _run(capsys, "reconcile", str(record), "--model", str(model), "--axis", "nope")
    assert rc == 2 and "no axis" in err
    rc, _, err = _run(capsys, "reconcile", str(record), "--model", str(model), "--runs", "2")
    assert rc == 2 and "at least 4" in err
    with pytest.raises(SystemExit):
        cli.main(["reconcile", str(record)])  # --model is required


def test_text_report_and_figure_in_rad(files, capsys, monkeypatch):
    """``--output-units rad``: the effect's parameters are the deg report's (of the same
    result) times the family's factors, under rad-named keys; the figure, read as it is saved,
    draws the Allan deviation in rad/s; the model's TOML stays in a model file's units."""
    from analysis.units.conversions import RAD_FAMILY, S_PER_H
    from station.output import plots, reconcile_report

    figures, kept = [], []
    save, fmt = plots._save, reconcile_report.format_reconcile

    def saved(fig, path, dpi=None):  # the figure as it is saved
        figures.append(fig)
        return save(fig, path, dpi)

    def formatted(res, **kw):
        kept.append((res, kw["label"]))
        return fmt(res, **kw)

    monkeypatch.setattr(plots, "_save", saved)
    monkeypatch.setattr(reconcile_report, "format_reconcile", formatted)
    folder, record, model = files
    png = folder / "rad.png"
    rc, rad, err = _run(capsys, "reconcile", str(record), "--model", str(model), "--axis",
                        "gyro_x", "--png", str(png), "--output-units", "rad")
    assert rc == 0, err
    [(res, label)] = kept
    deg = fmt(res, label=label)  # the deg default, of the same result

    def number(text: str, key: str) -> float:
        return float(re.search(rf"\b{key} = ([-+0-9.e]+)", text).group(1))

    for deg_key, rad_key, unit in (("amplitude_deg_h", "amplitude_rad_s", "deg/h"),
                                   ("phase_deg", "phase_rad", "deg")):
        assert number(rad, rad_key) == pytest.approx(
            number(deg, deg_key) * RAD_FAMILY.factor(unit), rel=1e-3)
    assert "amplitude_deg_h" not in rad.split("model after")[0]
    assert "model after (TOML, in the deg units a model file is read in):" in rad
    assert "N_deg_rt_h = 0.5" in rad  # the TOML, loadable as a model file
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    [ax] = figures[0].axes
    assert ax.get_ylabel() == "Allan deviation [rad/s]"
    measured = next(x for x in ax.get_lines() if x.get_label().startswith("measured"))
    np.testing.assert_allclose(measured.get_ydata(), np.sqrt(res.curve.avar) * S_PER_H
                               * RAD_FAMILY.factor("deg/h"), rtol=1e-12)


def test_evidence_numbers_in_rad():
    from analysis.units.conversions import RAD_FAMILY
    from station.output.reconcile_report import _in_family_text

    text = "change-point test: 2 step(s) ({3} blocks of 60 s): +0.52 deg/h at 300 s, -1e+02 deg/h"
    rad = _in_family_text(text, RAD_FAMILY)
    k = RAD_FAMILY.factor("deg/h")
    assert rad == (f"change-point test: 2 step(s) ({{3}} blocks of 60 s): {0.52 * k:+.3g} rad/s "
                   f"at 300 s, {-100 * k:.3g} rad/s")
