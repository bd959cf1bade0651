"""GMWM: the covariance of the wavelet variances, the estimator, its errors and model selection.

Simulated records come from :mod:`analysis.models.simulation` with parameters set here; the
estimator sees only the rate. Tolerances are stated per check (Monte Carlo spreads from
``benchmarks/bench_gmwm.py``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from analysis.errors import FitError, TooFewSamplesError
from analysis.gmwm.covariance import wv_covariance
from analysis.gmwm.estimator import gmwm, gmwm_with_covariance
from analysis.gmwm.models import GmwmModel, GmwmModelError
from analysis.gmwm.selection import gmwm_analysis, select_model
from analysis.gmwm.wavelet import haar_wavelet_variance
from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, GaussMarkov, NoiseModel, RateRandomWalk
from station.cli import main
from station.storage.csv_records import write_csv_record

FS = 10.0
TRUTH = {"wn_deg_rt_h": 1.0, "gm_sigma_deg_h": 20.0, "gm_tau_s": 30.0, "rw_deg_h_rt_h": 20.0}
TRUE_MODEL = NoiseModel(
    terms=(
        AngleRandomWalk(N_deg_rt_h=1.0),
        GaussMarkov(sigma_deg_h=20.0, tau_s=30.0),
        RateRandomWalk(K_deg_h_1_5=20.0),
    )
)
REAL_DATA = Path(__file__).resolve().parents[2] / "shared" / "real-data"


def rate_of(model: NoiseModel, seed: int, n: int, axes: int | None = None) -> np.ndarray:
    chunk = simulate(model, n / FS, FS, n_axes=axes or 1, seed=seed)
    return chunk.rate_deg_s if axes else chunk.rate_deg_s[:, 0]


def test_model_covariance_of_the_wavelet_variances_matches_monte_carlo():
    runs, n = 600, 2048
    wv = haar_wavelet_variance(rate_of(TRUE_MODEL, 2, n, axes=runs), FS, ci="eta3")
    model = GmwmModel.parse("wn+gm+rw")
    v = wv_covariance(model, model.internal(TRUTH, 1 / FS), wv.m, n, FS)
    empirical = np.cov(wv.wv)
    sd, sd_mc = np.sqrt(np.diag(v)), np.sqrt(np.diag(empirical))
    # the standard deviation of a sample standard deviation over 600 runs is ~3-6 % here
    np.testing.assert_allclose(sd_mc, sd, rtol=0.15)
    corr, corr_mc = v / np.outer(sd, sd), empirical / np.outer(sd_mc, sd_mc)
    assert np.max(np.abs(np.diag(corr, 1) - np.diag(corr_mc, 1))) < 0.1
    assert np.all(np.linalg.eigvalsh(v) > 0)


def test_gmwm_recovers_a_gauss_markov_under_white_noise_and_a_random_walk():
    n = 72_000  # 2 h at 10 Hz
    for seed in (1, 2, 3):
        wv = haar_wavelet_variance(rate_of(TRUE_MODEL, seed, n), FS)
        fit = gmwm(wv, "wn+gm+rw")
        assert fit.weights == "efficient" and fit.model.name == "wn+gm+rw"
        assert set(fit.values) == set(TRUTH) == set(fit.stderr) == set(fit.ci_low)
        for key, true in TRUTH.items():
            got, se = fit.values[key], fit.stderr[key]
            # honest errors: within 3.5 standard errors, and the error itself bounded
            assert abs(got - true) < 3.5 * se, (seed, key, got, se)
            assert fit.ci_low[key] <= got <= fit.ci_high[key]
        assert fit.values["wn_deg_rt_h"] == pytest.approx(1.0, rel=0.02)
        assert fit.values["gm_tau_s"] == pytest.approx(30.0, rel=0.6)
        assert fit.dof == len(wv.tau_s) - 4 and 0.0 < fit.p_value <= 1.0
        np.testing.assert_allclose(fit.model_wv, fit.model_wv_at(wv.tau_s))


def test_fit_statistic_follows_its_chi_square_when_the_model_holds():
    model = NoiseModel(
        terms=(AngleRandomWalk(N_deg_rt_h=1.0), GaussMarkov(sigma_deg_h=30.0, tau_s=5.0))
    )
    stats = [
        gmwm(haar_wavelet_variance(rate_of(model, seed, 16_384), FS), "wn+gm")
        for seed in range(10, 22)
    ]
    j = np.array([f.objective for f in stats])
    dof = stats[0].dof
    # mean of 12 chi-square(dof) values: dof +- sqrt(2 dof / 12) ~ 1.2 for dof = 9
    assert abs(j.mean() - dof) < 4.0 * math.sqrt(2 * dof / len(j)), (j, dof)


def test_diagonal_weights_and_short_records():
    wv = haar_wavelet_variance(rate_of(TRUE_MODEL, 4, 8192), FS)
    diag = gmwm(wv, "wn+gm", weights="diagonal")
    assert diag.weights == "diagonal" and diag.values["wn_deg_rt_h"] == pytest.approx(1.0, rel=0.05)
    with pytest.raises(TooFewSamplesError, match="can identify"):
        gmwm(haar_wavelet_variance(np.random.default_rng(0).standard_normal(64), FS), "wn+gm+gm+rw")
    with pytest.raises(FitError, match="weights"):
        gmwm(wv, "wn", weights="heavy")


def test_model_strings_and_parameter_keys():
    model = GmwmModel.parse("RW + 2gm + wn")
    assert model.name == "wn+gm+gm+rw" and model.n_params == 6
    p = model.internal(
        {
            "wn_deg_rt_h": 1.0,
            "gm1_sigma_deg_h": 1.0,
            "gm1_tau_s": 100.0,
            "gm2_sigma_deg_h": 2.0,
            "gm2_tau_s": 3.0,
            "rw_deg_h_rt_h": 4.0,
        },
        0.1,
    )
    values, _ = model.physical(p, np.zeros((6, 6)), 0.1)
    # repeated terms are numbered by increasing correlation time
    assert values["gm1_tau_s"] == pytest.approx(3.0) and values["gm2_sigma_deg_h"] == pytest.approx(
        1.0
    )
    assert model.term_labels(p) == ["wn", "gm2", "gm1", "rw"]
    assert GmwmModel.parse("wn+gm").keys()[1][0] == "gm_sigma_deg_h"
    for bad, match in (("wn+foo", "unknown"), ("wn+wn", "twice"), ("+", "empty")):
        with pytest.raises(GmwmModelError, match=match):
            GmwmModel.parse(bad)


def test_selection_ranks_every_candidate_and_finds_the_hidden_terms():
    white = haar_wavelet_variance(np.random.default_rng(5).standard_normal(32_768), FS)
    sel = select_model(white, ["wn", "wn+gm", "wn+rw", "wn+bi"])
    assert sel.ranking[0].effective == "wn" and sel.best.model.name == "wn"
    assert sorted(r.model for r in sel.ranking) == ["wn", "wn+bi", "wn+gm", "wn+rw"]
    assert np.all(
        np.diff([r.criterion for r in sel.ranking]) > -1e-6
    )  # ties go to the smaller model
    auto = gmwm_analysis(rate_of(TRUE_MODEL, 7, 72_000), FS)
    assert "gm" in auto.best.model.codes and auto.ranking[0].model == auto.best.model.name
    assert len(auto.ranking) >= 20 and auto.runner_up is not None
    assert auto.runner_up.effective != auto.ranking[0].effective


@pytest.fixture(scope="module")
def gm_record(tmp_path_factory) -> Path:
    rate = rate_of(TRUE_MODEL, 9, 36_000, axes=2)
    return write_csv_record(
        tmp_path_factory.mktemp("gmwm") / "gm.csv", rate, FS, axis_names=["x", "y"]
    )


@pytest.mark.slow
def test_analyze_gmwm_json_interface(gm_record: Path, tmp_path: Path, capsys):
    png = tmp_path / "wv.png"
    # in-process: the command as a process (its exit status, its stdout) is test_cli_startup's
    assert main(["analyze", str(gm_record), "--method", "gmwm", "--model", "auto", "--axis", "y",
                 "--json", "--png", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)  # the whole stdout is one object
    assert [a["name"] for a in out["axes"]] == ["y"]
    for axis in out["axes"]:
        assert axis["fit"]["method"] == "logwls"  # the Allan fit and read-offs stay beside it
        g = axis["gmwm"]
        assert (
            set(g["params"]) == set(g["stderr"]) and g["model"] == GmwmModel.parse(g["model"]).name
        )
        units = ("_deg_rt_h", "_deg_h", "_s", "_deg_h_rt_h", "_urad", "_deg_h2", "_phi")
        assert all(k.endswith(units) for k in g["params"])
        assert g["ranking"][0]["model"] == g["model"] and all(
            {"model", "criterion"} <= set(r) for r in g["ranking"]
        )
        assert len(g["wv_tau_s"]) == len(g["wv"]) == len(g["model_wv"]) >= 10
        assert g["wv_tau_s"][0] == pytest.approx(0.1)
    assert png.stat().st_size > 10_000
    assert (
        main(
            [
                "analyze",
                str(gm_record),
                "--method",
                "gmwm",
                "--model",
                "wn+gm",
                "--axis",
                "x",
                "--json",
            ]
        )
        == 0
    )
    g = json.loads(capsys.readouterr().out)["axes"][0]["gmwm"]
    assert g["model"] == "wn+gm" and [r["model"] for r in g["ranking"]] == ["wn+gm"]
    assert set(g["params"]) == {"wn_deg_rt_h", "gm_sigma_deg_h", "gm_tau_s"}


def test_analyze_gmwm_table_and_bad_options(gm_record: Path, capsys):
    assert (
        main(["analyze", str(gm_record), "--method", "gmwm", "--model", "wn+gm+rw", "--axis", "y"])
        == 0
    )
    out = capsys.readouterr().out
    assert "GMWM gm_tau_s" in out and "ARW read-off" in out and "J / dof" in out
    assert main(["analyze", str(gm_record), "--method", "gmwm", "--model", "wn+pink"]) == 2
    err = capsys.readouterr().err
    assert (
        "unknown GMWM term" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    )
    assert main(["analyze", str(gm_record), "--model", "wn+gm"]) == 2
    assert "--method gmwm" in capsys.readouterr().err


@pytest.mark.skipif(not (REAL_DATA / "mtig_cont_imu1_gyro_x_100hz.csv.gz").exists(),
                    reason="real records not available (../shared/real-data)")
@pytest.mark.slow
def test_real_mtig_record_selects_a_gauss_markov_of_a_few_seconds():
    from station.storage.runs import read_record

    record = read_record(
        REAL_DATA / "mtig_cont_imu1_gyro_x_100hz.csv.gz", sample_rate_hz=100.0, units="rad/s"
    )
    sel = gmwm_analysis(record.rate_deg_s[:, 0], 100.0)
    values = sel.best.values
    taus = [v for k, v in values.items() if k.endswith("_tau_s") and v > 0.5]
    # the Allan curve's shoulder at 3-40 s (docs/real-data.md): a Gauss-Markov of a few seconds
    assert "gm" in sel.best.model.codes and any(1.0 < t < 10.0 for t in taus), values
    # the white noise at every tau above a sample: wn and any Gauss-Markov far shorter than a
    # sample period (white beyond it, N^2 = 2 s^2 T; the output filter shapes the first scale)
    n2 = values["wn_deg_rt_h"] ** 2 + sum(
        2.0 * (values[k[: -len("tau_s")] + "sigma_deg_h"] / 3600.0) ** 2 * t * 3600.0
        for k, t in values.items() if k.endswith("_tau_s") and t < 0.1 / 100.0
    )
    assert math.sqrt(n2) == pytest.approx(1.94, rel=0.03), values


def test_a_model_the_record_rejects_gets_floored_weights_and_follows_the_data():
    from analysis.models.terms import BiasInstability

    flicker = NoiseModel(terms=(AngleRandomWalk(N_deg_rt_h=1.0), BiasInstability(B_deg_h=30.0)))
    wv = haar_wavelet_variance(rate_of(flicker, 12, 200_000), FS)
    exact = gmwm(wv, "wn+rw", model_error=0.0)
    floored = gmwm(wv, "wn+rw")
    assert exact.p_value < 1e-3 and exact.weights == "efficient"
    assert floored.weights == "nonparametric+floor" and floored.model_error == pytest.approx(0.02)
    # with the data's variances the wrong model still runs through the data, above it at some
    # scales only, and nowhere far off it: the model-based V of a rejected model grows with the
    # fitted curve and lets the random walk overshoot the plateau's top scales many times
    misfit = np.abs(np.log(floored.model_wv / wv.wv))
    assert 0.2 < np.mean(floored.model_wv > wv.wv) < 0.8, floored.model_wv / wv.wv
    assert np.max(misfit) < math.log(10.0), floored.model_wv / wv.wv
    assert np.mean(misfit) < np.mean(np.abs(np.log(exact.model_wv / wv.wv)))


@pytest.mark.skipif(not (REAL_DATA / "adis16405_imu1_gyro_deg_s_100hz.csv.gz").exists(),
                    reason="real records not available (../shared/real-data)")
def test_real_adis_record_rejects_wn_ar1_rw_and_the_fit_stays_near_its_plateau():
    from station.storage.runs import read_record

    record = read_record(REAL_DATA / "adis16405_imu1_gyro_deg_s_100hz.csv.gz",
                         sample_rate_hz=100.0, units="deg/s")
    wv = haar_wavelet_variance(record.rate_deg_s[:, 0], 100.0, min_blocks=2)
    fit = gmwm(wv, "wn+ar1+rw")
    # the WV is flat beyond 40 s (bias instability), which no random walk follows: the model is
    # rejected, and the random walk must not run far above the top scales' plateau
    assert fit.weights == "nonparametric+floor", fit.p_value
    assert np.max(fit.model_wv / wv.wv) < 5.0, fit.model_wv / wv.wv
    assert fit.ci_low["rw_deg_h_rt_h"] < fit.values["rw_deg_h_rt_h"] < fit.ci_high["rw_deg_h_rt_h"]


def test_a_stuck_axis_or_a_model_nil_at_some_scale_is_a_fit_error_not_nan():
    """A constant record has no noise to fit; weights from a model that is zero at some
    scale cannot whiten it (before, both divided by zero and fitted NaN)."""
    flat = haar_wavelet_variance(np.full(20_000, 0.25), FS)
    with pytest.raises(FitError, match="no noise to fit"):
        gmwm(flat, "wn+rw")
    wv = haar_wavelet_variance(np.random.default_rng(7).standard_normal(20_000), FS)
    v = np.diag(np.asarray(wv.variance))
    v[3, 3] = 0.0
    with pytest.raises(FitError, match="no positive variance"):
        gmwm_with_covariance(wv, "wn", v)


def test_an_analysis_keeps_no_quadrature_rules_for_the_next_record():
    """``gmwm_analysis`` drops the quadrature rules of its record's levels when done (those
    of a long record take 5-7 MB each, up to 8 kept while it is fitted); the same record
    analysed again gives the same fit."""
    from analysis.gmwm import covariance

    rate = rate_of(TRUE_MODEL, 3, 8_000)
    first = gmwm_analysis(rate, FS, model="wn+rw")
    assert covariance._rules.cache_info().currsize == 0
    again = gmwm_analysis(rate, FS, model="wn+rw")
    np.testing.assert_array_equal(again.best.params, first.best.params)
