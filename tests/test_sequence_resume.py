"""A temperature sequence killed (kill -9) in the middle of a plateau and resumed by the same
command (issues 29 and 39): the simulated fixture died with the station, so the resume finds
the chamber at ambient and the relay open; it switches the unit on again, brings the chamber
back and holds it stable, and redoes the plateau's record in full. The unit switched on
again draws a new turn-on bias, as a real one does (the fixture's count of switch-ons goes
on from the journal's), so the points before and after the resume are not on one line: the
fit gives each switch-on its own bias, and the coefficient's interval holds the truth.

The uninterrupted run of this sequence is ``tests/test_sequences.py``'s temperature test (the
same simulated units, coefficient and intervals); ``benchmarks/bench_reliability.py`` kills
this sequence in every step kind.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.sequence_kill import (
    PLATEAUS_C,
    PROFILE,
    RECORD_S,
    SELF_HEATING_C,
    TEMPCO,
    TURN_ON,
    killed_and_resumed,
    turn_on_bias_deg_h,
)

#: Its turn-on biases: 17.6 deg/h at the first switch-on, -0.85 at the second (a jump like
#: the 18.5 deg/h a resumed campaign unit made).
SEED = 12


@pytest.mark.slow
def test_a_sequence_killed_mid_plateau_resumes_with_a_new_switch_on(tmp_path: Path) -> None:
    """Killed halfway through the 40 degC plateau's record: the resume's switch-on is a
    switch-on of its own (summary and grade count 2), the unit drew its second turn-on bias
    there, four temperature points at the four set points (no ramp recorded while the
    chamber came back), the fit gives each switch-on its own bias and its 95 % interval
    holds the true coefficient, no hysteresis invented across the switch-ons; the journal
    says what the resume did."""
    profile = tmp_path / "p.toml"
    profile.write_text(PROFILE, encoding="utf-8")
    out = killed_and_resumed(profile, tmp_path / "runs", seed=SEED, kind="record", nth=1,
                             share=0.5)
    run, figures = out.run, out.figures
    assert [(s["state"], s["cycles"], s["turn_ons"], s["interruptions"])
            for s in out.summary] == [("done", 2, 1, 1)]
    assert figures["cycles"] == 2  # the summary's count
    per_cycle = figures["per_cycle"]  # type: ignore[index]
    assert [(c["power_cycle"], c["by_resume"]) for c in per_cycle] == [(1, False), (2, True)]
    resume = next(n for n, e in enumerate(run.journal) if e.kind == "resume")
    after = run.journal[resume:]
    restored = [e for e in after if e.kind == "power_on"]
    assert len(restored) == 1 and not run.asked_for(restored[0])
    assert any(e.kind == "stable" and e.step == out.step for e in after)
    parts = [s for s in run.segments if s.step == out.step]
    assert [(s.interrupted, s.superseded) for s in parts] == [(True, True), (False, False)]
    points = figures["temperature_points"]["x"]  # type: ignore[index]
    assert len(points) == len(PLATEAUS_C), points
    assert [p["power_cycle"] for p in points] == [1, 2, 2, 2]
    for point, set_point in zip(sorted(p["temperature_c"] for p in points),
                                sorted(PLATEAUS_C), strict=True):
        assert point == pytest.approx(set_point + SELF_HEATING_C, abs=0.5)
    # each point is its switch-on's own draw plus the temperature's bias: a new draw at the
    # resume (the two differ by 18 deg/h), to the points' noise and a transient's tail
    first, second = turn_on_bias_deg_h(SEED, 1), turn_on_bias_deg_h(SEED, 2)
    assert abs(first - second) > 10.0
    for p in points:
        truth = (turn_on_bias_deg_h(SEED, p["power_cycle"])
                 + float(TURN_ON.temperature_bias_deg_h(p["temperature_c"])))
        assert p["bias_deg_h"] == pytest.approx(truth, abs=2.0), (p, truth)
    low, high = figures["temperature_coefficient_deg_h_per_c_ci"]  # type: ignore[misc]
    assert low <= TEMPCO <= high
    assert figures["temperature_coefficient_deg_h_per_c"] == pytest.approx(TEMPCO, abs=0.1)
    assert any("its own bias" in n for n in figures["notes"])  # type: ignore[attr-defined]
    # the two switch-ons' biases, compared at one temperature: a turn-on repeatability of
    # 2 draws, whose interval holds the spread they are drawn with
    r_low, r_high = figures["turn_on_repeatability_deg_h_ci"]  # type: ignore[misc]
    assert r_low <= TURN_ON.turn_on_bias_deg_h <= r_high
    h_low = (figures["hysteresis_deg_h_ci"] or [None])[0]  # type: ignore[index]
    assert h_low in (0.0, None)
    assert [p["set_point_c"] for p in out.plateaus] == list(PLATEAUS_C)
    redone = next(p for p in out.plateaus if p["step"] == out.step + 1)
    # in full, not the half left; and no longer (a unit ends on its own clock), give or take
    # the samples a loaded host lets out before a unit's hold takes (10 at 5 Hz, 2 s, seen
    # with a process spinning beside the suite: 10 ms of wall time at x200)
    assert RECORD_S - 5.0 <= redone["duration_s"] <= RECORD_S + 5.0
