"""A slow Gauss-Markov process beside a printed bias instability or walk (issue 28, item 1).

Records of 1 h at 10 Hz from the station's simulator: white noise plus a Gauss-Markov
process of 3 deg/h with a 300 s correlation time (read ``N+K``), and white noise plus a
bias instability whose floor spans two decades (read ``N+B``, the GMWM tells it from a
Gauss-Markov process). The statistics over seeds are ``benchmarks/bench_bias_or_markov.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from analysis.allan.curves import FLICKER_AVAR_FACTOR, gauss_markov_avar
from analysis.figures.ambiguity import AMBIGUITY_MARGIN
from analysis.fit.result import GM_B_EQUIVALENT
from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, BiasInstability, GaussMarkov, NoiseModel
from station.evaluation.analyze import analyze_record
from station.evaluation.figure_intervals import Interval
from station.evaluation.grading import grade_figure
from station.evaluation.readings import alternative_readings
from station.model.profiles import parse_profile
from station.model.records import RateRecord

PROFILE = Path(__file__).resolve().parents[1] / "profiles" / "ADIS16405.toml"


def _axis(model: NoiseModel, seed: int):
    rate = simulate(model, 3600.0, 10.0, seed=seed).rate_deg_s
    return analyze_record(RateRecord(rate, 10.0, ("x",)))[0]


@pytest.fixture(scope="module")
def markov_axis():
    model = NoiseModel((AngleRandomWalk(N_deg_rt_h=0.05),
                        GaussMarkov(sigma_deg_h=3.0, tau_s=300.0)))
    return _axis(model, 2863)


def _markov(fit):
    found = [a for a in fit.alternatives if a.gauss_markov is not None]
    assert len(found) == 1, [a.terms for a in fit.alternatives]
    return found[0]


def test_a_slow_gauss_markov_record_lists_the_process_beside_its_walk(markov_axis):
    fit = markov_axis.fit
    assert "K" in fit.terms and (fit.values["K"] or 0.0) > 0
    alt = _markov(fit)
    gm = alt.gauss_markov
    assert gm is not None
    # the printed reading's other terms, the walk replaced by the process
    assert alt.terms == fit.terms.replace("K", "") + "+GM"
    assert alt.fit.values["K"] is None and alt.fit.values["N"] == fit.values["N"]
    assert alt.criterion_delta is None
    assert alt.wavelet_criterion_delta is not None
    assert alt.wavelet_criterion_delta <= AMBIGUITY_MARGIN
    # the process the record holds: 3 deg/h, 300 s, within a factor of two
    assert 1.5 < gm.sigma_deg_h < 6.0 and 150.0 < gm.tau_s < 600.0
    doc = json.loads(json.dumps(markov_axis.as_json()["fit"], allow_nan=False))
    (entry,) = [a for a in doc["alternatives"] if a["terms"].endswith("+GM")]
    assert entry["values"]["GM_sigma_deg_h"] == gm.sigma_deg_h
    assert entry["values"]["GM_tau_s"] == gm.tau_s
    assert entry["stderr"]["GM_sigma_deg_h"] == gm.sigma_stderr_deg_h
    assert entry["stderr"]["GM_tau_s"] == gm.tau_stderr_s
    assert entry["values"]["K_deg_h_1_5"] is None and entry["criterion_delta"] is None
    assert "GM sigma" in alt.describe()


def test_a_bias_instability_the_gmwm_tells_apart_has_no_markov_reading():
    model = NoiseModel((AngleRandomWalk(N_deg_rt_h=0.02), BiasInstability(B_deg_h=1.0)))
    fit = _axis(model, 2850).fit
    assert fit.terms == "NB" and fit.values["B"] == pytest.approx(1.0, rel=0.1)
    assert not [a for a in fit.alternatives if a.gauss_markov is not None]


def test_the_markov_b_is_the_bias_instability_of_the_same_allan_height():
    # the process' Allan deviation peaks at 0.617 sigma near 1.89 T (IEEE Std 952, Annex C)
    x = np.logspace(-1.0, 2.0, 3001)
    adev = np.sqrt(gauss_markov_avar(x, 1.0, 1.0))
    assert x[adev.argmax()] == pytest.approx(1.89, abs=0.01)
    assert GM_B_EQUIVALENT * np.sqrt(FLICKER_AVAR_FACTOR) == pytest.approx(adev.max(), rel=1e-4)
    assert GM_B_EQUIVALENT == pytest.approx(0.929, abs=0.001)


def _bias_profile(limit: float):
    text = PROFILE.read_text() + (
        f'\n[figures.bias_instability_fit]\nunit = "deg/h"\n'
        f"limits = {{ datasheet = {limit}, industrial = {limit} }}\n")
    profile = parse_profile(text)
    return profile, next(f for f in profile.figures if f.name == "bias_instability_fit")


def test_a_b_verdict_near_the_limit_is_safe_for_the_markov_reading(markov_axis):
    fit = markov_axis.fit
    z = 1.96
    others = alternative_readings(fit, "B", z)
    gm = _markov(fit).gauss_markov
    assert gm is not None
    (reading,) = [r for r in others if r.terms.endswith("+GM")]
    assert reading.value == pytest.approx(gm.sigma_deg_h * GM_B_EQUIVALENT)
    # printed: no bias instability, B 0 with its bound; a limit between that bound and the
    # process' B passes the printed reading alone and is not passed with the process
    b_err = fit.stderr["B"] or 0.0
    printed = Interval(0.0, 0.0, z * b_err)
    assert reading.value is not None and printed.high is not None
    assert reading.value > printed.high
    limit = (printed.high + reading.value) / 2
    profile, spec = _bias_profile(limit)
    assert set(grade_figure(spec, printed, profile).verdicts.values()) == {"pass"}
    both = grade_figure(spec, printed, profile, others)
    assert set(both.verdicts.values()) == {"indeterminate"}
    assert "+GM" in both.note
    # above every reading: the process does not change a clear pass
    assert reading.high is not None
    profile, spec = _bias_profile(reading.high * 1.1)
    assert set(grade_figure(spec, printed, profile, others).verdicts.values()) == {"pass"}
