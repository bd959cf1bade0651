"""Reconcile with the GMWM as judge: a faint Gauss-Markov process, named where the Allan curve
alone takes it for more bias instability, and both explanations reported with their scores.

The record is made here by textbook recursions (white noise, Kasdin flicker, a point-sampled
AR(1)), not by the station's simulator that reconcile's Monte Carlo uses: 1 h at 10 Hz,
ARW 0.5 deg/sqrt(h), bias instability 2 deg/h, a Gauss-Markov process of a tenth of the
white noise's standard deviation and 20 s correlation time. Seed 2 is one of the seeds
(2, 6, 8, 11 of 1-12) where the Allan curve's order names "bias instability increased"
and the GMWM names the Gauss-Markov process (``benchmarks/bench_reconcile_naming.py`` has
the rates over many seeds).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from analysis.models.noise import flicker_rate_noise
from analysis.models.terms import AngleRandomWalk, BiasInstability, NoiseModel
from analysis.reconcile import gmwm_naming
from analysis.reconcile.discrepancy import ComparisonCache
from analysis.reconcile.gmwm_naming import GmwmJudgement, judge, new_or_more
from analysis.reconcile.loop import ReconcileOptions, reconcile
from station.cli import main
from station.output.reconcile_report import format_reconcile
from station.storage.csv_records import write_csv_record

FS, N = 10.0, 36_000
SIGMA_W = 0.5 * 60.0 * math.sqrt(FS) / 3600.0  # white noise per sample, deg/s
BASE = NoiseModel(
    terms=(AngleRandomWalk(N_deg_rt_h=0.5), BiasInstability(B_deg_h=2.0)), name="base"
)


def faint_gauss_markov(seed: int, sigma: float = 0.1, tau_s: float = 20.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = SIGMA_W * rng.standard_normal(N) + flicker_rate_noise(2.0 / 3600.0, N, FS, rng)
    phi = math.exp(-1.0 / (FS * tau_s))
    e = sigma * SIGMA_W * math.sqrt(1 - phi**2) * rng.standard_normal(N)
    gm, _ = signal.lfilter(
        [1.0], [1.0, -phi], e, zi=[phi * sigma * SIGMA_W * rng.standard_normal()]
    )
    return x + gm


@pytest.fixture(scope="module")
def cache() -> ComparisonCache:
    return ComparisonCache()


def test_new_process_or_more_of_one_goes_by_the_gmwm_score():
    group = ["bias_instability", "gauss_markov", "rate_random_walk"]  # the curve's order
    added = {"gauss_markov", "rate_random_walk"}.__contains__
    scores = {"bias_instability": 0.0, "gauss_markov": 2.5, "rate_random_walk": 9.0}
    j = GmwmJudgement(scores, {k: k for k in scores}, "wn+bi")
    # the first added term (the curve's choice among added ones) against the best refit
    assert new_or_more(group, str, added, j) == [
        "gauss_markov",
        "bias_instability",
        "rate_random_walk",
    ]
    j = GmwmJudgement({**scores, "gauss_markov": -1.0}, {k: k for k in scores}, "wn+bi")
    assert new_or_more(group, str, added, j) == group
    assert new_or_more(["gauss_markov", "rate_random_walk"], str, added, j) == [
        "gauss_markov",
        "rate_random_walk",
    ]


def test_gmwm_scores_a_hidden_gauss_markov_above_more_bias_instability():
    rate = faint_gauss_markov(2)
    candidates = [("bias_instability", "refit"), ("gauss_markov", "add")]
    j = judge(rate, FS, BASE, candidates)  # N2: the rest of the model held
    assert (
        j is not None
        and j.base == "wn+bi"
        and j.models == {"bias_instability": "bi", "gauss_markov": "gm"}
    )
    assert j.scores["gauss_markov"] > j.scores["bias_instability"] > 0.0
    free = judge(rate, FS, BASE, candidates, held=False)  # N1: every term free
    assert free is not None and free.models["gauss_markov"] == "wn+gm+bi"
    assert free.scores["bias_instability"] == 0.0 and free.scores["gauss_markov"] > 0.0
    assert (
        judge(faint_gauss_markov(2), FS, BASE, [("sinusoid", "add"), ("gauss_markov", "add")])
        is None
    )


def test_reconcile_names_the_faint_gauss_markov_and_reports_the_rival(cache):
    rate = faint_gauss_markov(2)
    alone = reconcile(rate, FS, BASE, cache=cache, options=ReconcileOptions(gmwm=False))
    judged = reconcile(rate, FS, BASE, cache=cache)
    assert [e.name for e in alone.effects] == ["bias_instability"]
    assert alone.effects[0].criterion == "allan" and [
        a.name for a in alone.effects[0].alternatives
    ] == ["gauss_markov"]
    assert [e.name for e in judged.effects] == ["gauss_markov"]
    named = judged.effects[0]
    assert (
        named.criterion == "gmwm"
        and named.score > 0
        and named.params["tau_s"] == pytest.approx(20.0, rel=0.6)
    )
    rival = named.alternatives[0]
    assert (rival.name, rival.change, rival.criterion) == ("bias_instability", "increased", "gmwm")
    assert abs(named.score - rival.score) < 6.0
    doc = judged.as_json()
    assert doc["alternatives"] == [
        {
            "effect": "gauss_markov",
            "name": "bias_instability",
            "score": rival.score,
            "criterion": "gmwm",
            "change": "increased",
        }
    ]
    assert doc["effects"][0]["alternatives"][0]["name"] == "bias_instability"
    assert "about as good (GMWM score" in format_reconcile(judged)


def test_reconcile_json_keeps_its_keys_and_adds_alternatives(tmp_path: Path, capsys):
    csv = write_csv_record(
        tmp_path / "faint.csv", faint_gauss_markov(2)[:, None], FS, axis_names=["x"]
    )
    model = tmp_path / "base.toml"
    model.write_text(BASE.to_toml())
    assert main(["reconcile", str(csv), "--model", str(model), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in (
        "gap_before",
        "gap_after",
        "effects",
        "model_after",
        "excess_terms",
        "axes",
        "alternatives",
    ):
        assert key in out
    assert [e["name"] for e in out["effects"]] == ["gauss_markov"]
    assert {"name", "score"} <= set(out["alternatives"][0]) and out["alternatives"][0][
        "name"
    ] == "bias_instability"


def test_judge_reaches_the_longest_scale_where_a_slow_gauss_markov_turns_down(monkeypatch):
    # T = 150 s in 1 h: its Allan variance peaks at 1.89 T = 280 s and falls past the 410 s
    # where a plotted wavelet variance (m <= N/8) stops; a random walk's keeps rising
    rate = faint_gauss_markov(2, sigma=0.2, tau_s=150.0)
    candidates = [("gauss_markov", "add"), ("rate_random_walk", "add")]
    j = judge(rate, FS, BASE, candidates)
    assert j is not None
    assert j.scores["gauss_markov"] > j.scores["rate_random_walk"] + 6.0
    monkeypatch.setattr(gmwm_naming, "JUDGE_MIN_BLOCKS", 8)
    short = judge(rate, FS, BASE, candidates)
    assert short is not None
    assert abs(short.scores["gauss_markov"] - short.scores["rate_random_walk"]) < 6.0


def test_an_explanation_the_gmwm_scores_above_the_named_one_is_reported(cache):
    # between two added terms the curve's order (the simpler first) names the random walk;
    # the Gauss-Markov process, which the GMWM scores far above it, is reported beside it
    result = reconcile(faint_gauss_markov(2, sigma=0.2, tau_s=150.0), FS, BASE, cache=cache)
    (named,) = result.effects
    assert named.name == "rate_random_walk" and named.criterion == "gmwm"
    assert [(a.name, a.change) for a in named.alternatives] == [("gauss_markov", "added")]
    assert named.alternatives[0].score > named.score + 6.0
    assert "about as good or better (GMWM score" in format_reconcile(result)
