"""Readings a record cannot tell apart (issues 28, 38): reported, graded safely, exported.

The record: N 0.1 deg/sqrt(h) + K 1 deg/h^1.5, 6 h at 10 Hz (the issue's case), on a
seed whose realised walk the term selection reads as a ramp (``N+R``, with ``N+K`` within
its margin). The statistics over seeds are ``benchmarks/bench_ambiguity.py``.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from analysis.figures.ambiguity import AMBIGUITY_MARGIN, RAMP_MARGIN
from analysis.models.simulation import simulate
from analysis.models.terms import AngleRandomWalk, BiasInstability, NoiseModel, RateRandomWalk
from station.evaluation.analyze import analyze_record
from station.evaluation.figure_intervals import Interval
from station.evaluation.grading import grade_figure, grade_run
from station.evaluation.noise_parameters import axis_noise
from station.evaluation.readings import (
    Reading,
    alternative_readings,
    best_supported,
    covering_interval,
    safe_verdict,
)
from station.model.profiles import parse_profile
from station.model.records import RateRecord
from station.output.export_formats import ExportContext, render
from station.output.report.common import ambiguity_lines
from station.storage.csv_records import write_csv_record
from station.storage.runs import open_run

PROFILE = Path(__file__).resolve().parents[1] / "profiles" / "ADIS16405.toml"


@pytest.fixture(scope="module")
def ambiguous_axis():
    model = NoiseModel((AngleRandomWalk(N_deg_rt_h=0.1), RateRandomWalk(K_deg_h_1_5=1.0)))
    rate = simulate(model, 6 * 3600.0, 10.0, seed=508).rate_deg_s
    return analyze_record(RateRecord(rate, 10.0, ("x",)))[0]


def test_the_reading_with_k_is_printed_and_the_ramp_reading_named(ambiguous_axis):
    fit = ambiguous_axis.fit
    assert "K" in fit.terms and fit.values["K"] > 0
    ramp = [a for a in fit.alternatives if "R" in a.fit.terms and "K" not in a.fit.terms]
    assert ramp, "the ramp reading the selection preferred is not listed"
    alt = ramp[0]
    assert alt.fit.values["R"] > 0 and alt.fit.values["K"] == 0.0
    # the selection preferred it, by less than the margin on one of the two criteria
    assert alt.criterion_delta <= 0
    assert (-alt.criterion_delta <= AMBIGUITY_MARGIN
            or (alt.wavelet_criterion_delta is not None
                and -alt.wavelet_criterion_delta >= -AMBIGUITY_MARGIN))
    doc = ambiguous_axis.as_json()["fit"]
    assert doc["alternatives"][0]["terms"] == alt.fit.terms
    assert doc["alternatives"][0]["values"]["R_deg_h2"] == alt.fit.values["R"]
    assert any("not told apart" in n for n in fit.notes)


def test_the_sheet_reads_the_record_one_way_the_one_it_supports_best(ambiguous_axis):
    # the analysis printed the walk, the selection preferred the ramp: the sheet prints
    # the ramp reading whole (its N, its R, its K of 0), the walk reading its alternative
    fit = ambiguous_axis.fit
    ramp = next(a for a in fit.alternatives if "R" in a.fit.terms and "K" not in a.fit.terms)
    sheet = best_supported(fit)
    assert sheet.terms == ramp.fit.terms and sheet.values == ramp.fit.values
    walk = sheet.alternatives[0]
    assert walk.fit.terms == fit.terms and walk.criterion_delta == -ramp.criterion_delta >= 0
    assert any("supports best" in n for n in sheet.notes)
    assert not any("Printed: the reading with K" in n for n in sheet.notes)
    # a reading the selection itself prefers is returned as it is
    assert best_supported(sheet) is sheet


def test_export_writes_the_printed_reading_and_marks_a_bound(ambiguous_axis):
    noise = axis_noise(ambiguous_axis)
    sheet = best_supported(ambiguous_axis.fit)
    assert sheet.values["K"] == 0.0
    # the printed reading drops K: a bound covering the walk reading's K + 1 sigma
    walk = ambiguous_axis.fit
    assert noise.rrw_deg_h_1_5 == pytest.approx(max(
        walk.values["K"] + walk.stderr["K"], sheet.stderr["K"] or 0.0))
    source = (noise.sources or {})["rrw"]
    assert "upper bound" in source and "ambiguous" in source
    assert f"terms {sheet.terms}" in source and f"terms {walk.terms}" in source
    assert noise.arw_deg_rt_h == pytest.approx(sheet.values["N"])


def test_an_interval_covers_every_reading():
    printed = Reading("NB", 0.30, 0.25, 0.35)
    walk = Reading("NK", 0.0, 0.0, 0.12)  # drops B: the interval reaches 0
    markov = Reading("N+GM", 0.45, 0.30, 0.60, equivalent=True)  # a Gauss-Markov B
    assert covering_interval(printed, (walk, markov)) == (0.0, 0.60)
    assert covering_interval(printed, ()) == (0.25, 0.35)
    # a reading without an interval widens by its value; an unknown bound stays unknown
    assert covering_interval(printed, (Reading("NBK", 0.5, None, None),)) == (0.25, 0.5)
    assert covering_interval(Reading("NB", 0.3, None, None), (walk,)) == (None, None)


def _rrw_profile(limit: float):
    text = PROFILE.read_text().replace(
        '[figures.rrw]\nunit = "deg/h^1.5"',
        f'[figures.rrw]\nunit = "deg/h^1.5"\nlimits = {{ datasheet = {limit}, '
        f'industrial = {limit} }}')
    profile = parse_profile(text)
    return profile, next(f for f in profile.figures if f.name == "rrw")


def test_a_verdict_holds_for_every_reading(ambiguous_axis):
    fit = ambiguous_axis.fit
    z = 1.0  # one sigma: the printed K's error carries the other reading's chance, and its
    # 95 % interval reaches 0 on this record
    others = alternative_readings(fit, "K", z)
    assert others and all(r.value == 0.0 for r in others)
    k, err = fit.values["K"], fit.stderr["K"]
    printed = Interval(k, max(k - z * err, 0.0), k + z * err)
    # a limit just below the walk's lower bound: the printed reading fails it, the ramp
    # reading (K 0, its bound above the limit) does not; together: indeterminate
    assert printed.low is not None and printed.low > 0
    limit = printed.low * 0.99
    profile, spec = _rrw_profile(limit)
    alone = grade_figure(spec, printed, profile)
    both = grade_figure(spec, printed, profile, others)
    assert set(alone.verdicts.values()) == {"fail"}
    assert set(both.verdicts.values()) == {"indeterminate"}
    assert "ambiguous" in both.note and both.as_json("datasheet")["alternatives"]
    # the value stays the printed reading's; its interval reaches the ramp reading's 0
    assert both.value == pytest.approx(k) and both.ci_low == 0.0
    assert both.ci_high == pytest.approx(max(printed.high, *(r.high for r in others)))
    # above every reading: pass; the readings do not change a clear verdict
    high = max(printed.high, others[0].high) * 1.1
    profile, spec = _rrw_profile(high)
    assert set(grade_figure(spec, printed, profile, others).verdicts.values()) == {"pass"}


def test_safe_verdict_passes_or_fails_only_on_agreement():
    assert safe_verdict(["pass", "pass"]) == "pass"
    assert safe_verdict(["fail", "fail"]) == "fail"
    assert safe_verdict(["pass", "fail"]) == "indeterminate"
    assert safe_verdict(["pass", "indeterminate"]) == "indeterminate"
    r = Reading("NR", 0.0, 0.0, 1.5)
    assert r.as_json(0.5) == {"terms": "NR", "value": 0.0, "ci_low": 0.0, "ci_high": 3.0}
    assert np.isfinite(r.high or np.nan)


def test_a_bias_instability_reading_stands_where_the_gmwm_prefers_it_and_k_is_named():
    # N 0.1 + B 0.3: the selection reads N+B with N+K within its margin (+0.8), the GMWM's
    # wavelet criterion prefers N+B (+2.7): N+B is printed, N+K listed with its K
    model = NoiseModel((AngleRandomWalk(N_deg_rt_h=0.1), BiasInstability(B_deg_h=0.3)))
    rate = simulate(model, 6 * 3600.0, 10.0, seed=903).rate_deg_s
    fit = analyze_record(RateRecord(rate, 10.0, ("x",)))[0].fit
    assert fit.terms == "NB" and (fit.values["B"] or 0.0) > 0
    # (a slow Gauss-Markov reading may be listed too: tests/test_bias_or_markov.py)
    assert [a.terms for a in fit.alternatives if a.gauss_markov is None] == ["NK"]
    walk = fit.alternatives[0]
    assert 0 < walk.criterion_delta <= AMBIGUITY_MARGIN
    assert walk.wavelet_criterion_delta is not None and walk.wavelet_criterion_delta > 0
    assert (walk.fit.values["K"] or 0.0) > 0 and walk.fit.values["B"] == 0.0
    # a K limit below the walk reading's K cannot pass on the N+B reading's K of 0
    others = alternative_readings(fit, "K", 1.0)
    assert others and others[0].value == walk.fit.values["K"]
    # the sheet prints the N+B reading whole: its K of 0, the interval reaching the walk
    # reading's K + 1 sigma; the verdict holds for both
    k0, k_err = fit.values["K"] or 0.0, fit.stderr["K"] or 0.0
    assert best_supported(fit) is fit
    profile, spec = _rrw_profile(10.0)
    sheet = grade_figure(spec, Interval(k0, 0.0, k0 + k_err), profile, others, fit.terms)
    assert sheet.value == 0.0 and sheet.terms == "NB" and sheet.ci_low == 0.0
    assert sheet.ci_high == pytest.approx(max(k0 + k_err, others[0].high))
    assert "NK" in [r.terms for r in sheet.alternatives]
    assert "covers every reading" in sheet.note


def test_a_ramp_the_selection_prefers_by_less_than_the_ramp_margin_keeps_the_walk():
    # a walk read as a ramp: the selection's criterion prefers N+R by 4.9, the GMWM's by
    # 12 (its drift term claims a precision one record cannot check); N+R is printed, N+K
    # listed; the sheet prints the ramp reading, its K interval reaching the walk's K
    model = NoiseModel((AngleRandomWalk(N_deg_rt_h=0.1), RateRandomWalk(K_deg_h_1_5=1.0)))
    rate = simulate(model, 6 * 3600.0, 10.0, seed=718).rate_deg_s
    fit = analyze_record(RateRecord(rate, 10.0, ("x",)))[0].fit
    assert fit.terms == "NR"
    walk = next(a for a in fit.alternatives if a.gauss_markov is None)
    assert walk.terms == "NK" and (walk.fit.values["K"] or 0.0) > 0.3
    assert AMBIGUITY_MARGIN < walk.criterion_delta <= RAMP_MARGIN
    assert walk.wavelet_criterion_delta is not None
    assert walk.wavelet_criterion_delta > AMBIGUITY_MARGIN
    assert any("information criterion prefers" in n for n in fit.notes)
    profile, spec = _rrw_profile(10.0)
    k_bound = fit.stderr["K"] or 0.0
    assert best_supported(fit) is fit
    sheet = grade_figure(spec, Interval(0.0, 0.0, k_bound), profile,
                         alternative_readings(fit, "K", 1.0), fit.terms)
    # the ramp reading is printed (K 0), its interval reaching the walk reading's K
    assert sheet.value == 0.0 and sheet.terms == "NR" and sheet.ci_low == 0.0
    assert sheet.ci_high >= walk.fit.values["K"] + walk.fit.stderr["K"]


SHEET_PROFILE = """name = "NB-SHEET"
version = "1"
model = "TG-1"

[transport]
url = "sim+serial://GENERIC?protocol=stim300&rate=10"

[test]
sample_rate_hz = 10.0
duration_s = 21600.0
warmup_s = 0.0
axes = ["x"]

[grading]
rule = "guard-banded"
confidence = 0.95
grades = ["A"]

[figures.arw_fit]
unit = "deg/sqrt(h)"
limits = { A = 0.2 }

[figures.bias_instability_fit]
unit = "deg/h"
limits = { A = 2.0 }

[figures.rrw]
unit = "deg/h^1.5"
limits = { A = 5.0 }

[figures.rate_ramp]
unit = "deg/h^2"
"""


def test_a_sheet_prints_one_reading_with_intervals_covering_the_others(tmp_path: Path):
    # N 0.1 + B 0.3 (issue 38's records): the analysis printed the walk (N+K), the
    # selection preferred the ramp (N+R) by 0.3; the sheet prints N+R whole, never the
    # walk's K beside another reading's N
    model = NoiseModel((AngleRandomWalk(N_deg_rt_h=0.1), BiasInstability(B_deg_h=0.3)))
    rate = simulate(model, 6 * 3600.0, 10.0, seed=3804).rate_deg_s
    record = write_csv_record(tmp_path / "nb.csv", rate, 10.0, axis_names=["x"])
    profile = parse_profile(SHEET_PROFILE)
    unit = grade_run(open_run(record), profile).units[0]
    axis = unit.axis("x")
    analysed = analyze_record(RateRecord(rate, 10.0, ("x",)))[0].fit
    assert analysed.terms == "NK"
    sheet = axis.analysis.fit
    assert sheet.terms == best_supported(analysed).terms == "NR"
    figures = {f.name: f for f in axis.figures}
    assert {figures[n].terms for n in ("arw_fit", "bias_instability_fit", "rrw",
                                       "rate_ramp")} == {"NR"}
    rrw, b = figures["rrw"], figures["bias_instability_fit"]
    walk_k = analysed.values["K"] + 1.96 * analysed.stderr["K"]
    assert rrw.value == 0.0 and rrw.ci_low == 0.0 and rrw.ci_high >= walk_k * 0.999
    assert b.ci_low == 0.0 and b.ci_high >= 0.3  # the true B is inside
    assert figures["arw_fit"].value == pytest.approx(sheet.values["N"])
    lines = ambiguity_lines(unit)
    assert lines and all("supports best (terms NR)" in t for t in lines)
    assert not any("largest" in t for t in lines)


def test_a_tool_of_three_axes_is_told_when_fewer_were_measured(ambiguous_axis):
    noise = axis_noise(ambiguous_axis)
    text = render("kalibr", [noise], ExportContext("walk.csv"))
    assert "Kalibr applies one value to all three gyroscope axes; only 1 of three" in text
    # the printed reading drops K: the random walk written is a bound, and says so
    walk_line = next(t for t in text.splitlines() if t.startswith("gyroscope_random_walk"))
    assert "UPPER BOUND" in walk_line
    three = [replace(noise, name=n) for n in "xyz"]
    assert "applies one value" not in render("kalibr", three, ExportContext("walk.csv"))
