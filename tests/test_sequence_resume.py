"""A temperature sequence killed (kill -9) in the middle of a plateau and resumed by the same
command measures what an uninterrupted one does (issue 29): the simulated fixture died with
the station, so the resume finds the chamber at ambient and the relay open; it switches the
unit on again as no turn-on, brings the chamber back and holds it stable, and redoes the
plateau's record in full.

The uninterrupted run of this sequence is ``tests/test_sequences.py``'s temperature test (the
same simulated units, coefficient and intervals); ``benchmarks/bench_reliability.py`` kills
this sequence at moments spread over every step kind.
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
    killed_and_resumed,
)


@pytest.mark.slow
def test_a_sequence_killed_mid_plateau_resumes_from_its_settle(tmp_path: Path) -> None:
    """Killed halfway through the 40 degC plateau's record: one switch-on the profile asked
    for (no turn-on repeatability, as uninterrupted), four temperature points at the four
    set points (no ramp recorded while the chamber came back), the coefficient's interval
    covering the truth, no hysteresis invented; the journal says what the resume did."""
    profile = tmp_path / "p.toml"
    profile.write_text(PROFILE, encoding="utf-8")
    out = killed_and_resumed(profile, tmp_path / "runs", seed=11, kind="record", nth=1,
                             share=0.5)
    run, figures = out.run, out.figures
    assert [(s["state"], s["cycles"], s["turn_ons"], s["interruptions"])
            for s in out.summary] == [("done", 1, 1, 1)]
    assert figures["cycles"] == 1 and figures["turn_on_repeatability_deg_h"] is None
    resume = next(n for n, e in enumerate(run.journal) if e.kind == "resume")
    after = run.journal[resume:]
    restored = [e for e in after if e.kind == "power_on"]
    assert len(restored) == 1 and not run.asked_for(restored[0])
    assert any(e.kind == "stable" and e.step == out.step for e in after)
    parts = [s for s in run.segments if s.step == out.step]
    assert [(s.interrupted, s.superseded) for s in parts] == [(True, True), (False, False)]
    points = figures["temperature_points"]["x"]  # type: ignore[index]
    assert len(points) == len(PLATEAUS_C), points
    for point, set_point in zip(sorted(p["temperature_c"] for p in points),
                                sorted(PLATEAUS_C), strict=True):
        assert point == pytest.approx(set_point + SELF_HEATING_C, abs=0.5)
    low, high = figures["temperature_coefficient_deg_h_per_c_ci"]  # type: ignore[misc]
    assert low <= TEMPCO <= high
    h_low = (figures["hysteresis_deg_h_ci"] or [None])[0]  # type: ignore[index]
    assert h_low in (0.0, None)
    assert [p["set_point_c"] for p in out.plateaus] == list(PLATEAUS_C)
    redone = next(p for p in out.plateaus if p["step"] == out.step + 1)
    # in full, not the half left; and no longer (a unit ends on its own clock), give or take
    # the samples a loaded host lets out before a unit's hold takes (10 at 5 Hz, 2 s, seen
    # with a process spinning beside the suite: 10 ms of wall time at x200)
    assert RECORD_S - 5.0 <= redone["duration_s"] <= RECORD_S + 5.0
