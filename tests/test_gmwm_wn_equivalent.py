"""The white noise a fast Gauss-Markov / AR(1) GMWM term amounts to (issue 38 part 6).

The references are the processes' own statistics, not our fit: the point-sampled AR(1)
``x_t = phi x_(t-1) + e_t`` of stationary variance ``s^2`` has autocovariances
``s^2 phi^|k|``, whose sum times ``dt``, ``s^2 dt (1 + phi) / (1 - phi)``, is the ``N^2``
of the white noise it looks like at ``tau >> T``; white noise of per-sample deviation
``w`` adds ``w^2 dt``. The Allan deviation of the simulated record at 1 s is the third
witness.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from analysis.allan.variance import allan_variance
from analysis.gmwm.equivalent import WN_EQUIVALENT_KEY, white_equivalent
from analysis.gmwm.estimator import gmwm
from analysis.gmwm.models import GmwmModel
from analysis.gmwm.wavelet import haar_wavelet_variance
from analysis.units.conversions import S_PER_H
from station.cli import main

FS = 100.0
PHI, SIGMA, WHITE = 0.3, 0.05, 0.01  # AR(1) coefficient and deviation, white deviation (deg/s)


def _truth() -> float:
    """The angle random walk (deg/sqrt(h)) of the AR(1) and the white noise together."""
    return math.sqrt(WHITE**2 / FS + SIGMA**2 / FS * (1 + PHI) / (1 - PHI)) * math.sqrt(S_PER_H)


@pytest.fixture(scope="module")
def fast_ar1() -> np.ndarray:
    rng = np.random.default_rng(38)
    n = 200_000
    ar1 = signal.lfilter([SIGMA * math.sqrt(1 - PHI**2)], [1.0, -PHI], rng.normal(size=n))
    return np.asarray(ar1 + rng.normal(0.0, WHITE, n))


def test_ar1_equivalent_is_the_limit_of_its_own_wavelet_variance() -> None:
    """The closed form equals tau avar(tau) of the model's exact AR(1) wavelet variance at
    tau >> T, and 2 s^2 T for a Gauss-Markov term."""
    dt = 1.0 / FS
    t = -dt / math.log(PHI)
    for name in ("ar1", "gm"):
        model = GmwmModel.parse(name)
        params = np.array([(SIGMA) ** 2, math.log(t)])
        eq = white_equivalent(model, params, None, dt, 0.01)
        assert eq is not None
        tau = np.array([1e4 * dt])
        n2_limit = float(2.0 * model.wv(params, tau, dt)[0] * tau[0])  # avar = 2 WV
        assert (eq.value_deg_rt_h / math.sqrt(S_PER_H)) ** 2 == pytest.approx(n2_limit, rel=1e-3)
    # a term slower than the shortest tau is no white noise: no equivalent
    slow = white_equivalent(GmwmModel.parse("wn+gm"), np.array([1e-4, SIGMA**2, 0.0]), None,
                            dt, 0.01)
    assert slow is None


def test_fit_reads_the_white_noise_the_ar1_amounts_to(fast_ar1: np.ndarray) -> None:
    fit = gmwm(haar_wavelet_variance(fast_ar1, FS), "wn+ar1")
    truth = _truth()
    value = fit.values[WN_EQUIVALENT_KEY]
    assert value == pytest.approx(truth, rel=0.03)
    # the white term alone misses most of it; the Allan -1/2 line at 1 s agrees
    assert fit.values["wn_deg_rt_h"] < 0.8 * truth
    r = allan_variance(fast_ar1, FS, taus=np.array([1.0]))
    assert value == pytest.approx(float(np.sqrt(r.avar[0] * 1.0 * S_PER_H)), rel=0.05)
    assert 0 < fit.stderr[WN_EQUIVALENT_KEY] < 0.05 * value
    assert fit.ci_low[WN_EQUIVALENT_KEY] < value < fit.ci_high[WN_EQUIVALENT_KEY]
    readings = fit.white_equivalent().readings()  # type: ignore[union-attr]
    assert readings[0].startswith("white noise term alone") and "together" in readings[-1]


@pytest.mark.slow
def test_analyze_json_gives_wn_equivalent_and_export_takes_it(
        fast_ar1: np.ndarray, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "gyro.csv"
    np.savetxt(path, fast_ar1[:20_000, None], delimiter=",", header="x", comments="",
               fmt="%.6f")
    assert main(["analyze", str(path), "--rate", "100", "--method", "gmwm", "--model",
                 "wn+ar1", "--json"]) == 0
    gm = json.loads(capsys.readouterr().out)["axes"][0]["gmwm"]
    value = gm["params"]["wn_equivalent_deg_rt_h"]
    assert value == pytest.approx(_truth(), rel=0.08)
    assert any(r.startswith("ar1 (T ") for r in gm["wn_equivalent_readings"])
    assert main(["export", str(path), "--rate", "100", "--method", "gmwm", "--model",
                 "wn+ar1", "--format", "json", "--out", "-"]) == 0
    axis = json.loads(capsys.readouterr().out)["axes"][0]
    assert axis["arw_deg_rt_h"] == pytest.approx(value, rel=1e-9)
    assert "white-noise equivalent" in axis["sources"]["arw"]


@pytest.mark.slow
def test_sheet_rows_lead_with_the_equivalent(fast_ar1: np.ndarray, tmp_path: Path) -> None:
    """The sheet's GMWM rows: the white-noise equivalent first (never the 0 of a white
    term whose noise went into the AR(1)), the white term marked as alone, the readings
    in the summary line."""
    from station.evaluation.gmwm_run import run_with_gmwm
    from station.output.report.gmwm_terms import gmwm_rows, gmwm_summary
    from station.services.grade import GradeRequest, RunSource, grade
    from tests.test_grading import profile_text, write_profile

    path = tmp_path / "gyro.csv"
    np.savetxt(path, fast_ar1[:20_000, None], delimiter=",", header="x", comments="",
               fmt="%.6f")
    figures = '[figures.arw]\nunit = "deg/sqrt(h)"\nlimits = { A = 1.0, B = 2.0 }\n'
    profile = write_profile(tmp_path, profile_text(warmup_s=0.0, figures=figures))
    graded = grade(GradeRequest(RunSource(path, rate_hz=FS), profile=str(profile),
                                store=False)).graded
    [axis] = run_with_gmwm(graded, "wn+ar1").units[0].axes
    rows = gmwm_rows(axis)
    assert rows[0].key == WN_EQUIVALENT_KEY and rows[0].unit == "deg/sqrt(h)"
    assert rows[0].value == pytest.approx(_truth(), rel=0.08)
    assert "ARW read-off" in rows[0].allan
    assert next(r for r in rows if r.key == "wn_deg_rt_h").term.endswith("(term alone)")
    assert "white-noise equivalent readings" in gmwm_summary(axis)
