"""``bench_reliability.py``'s sequence cases: a temperature test killed (SIGKILL) in a step
drawn at random, or in each step kind, and resumed; each kill prints the temperature
coefficient and its 95 % interval against the simulated truth."""

from __future__ import annotations

import random
from pathlib import Path

from benchmarks.reliability_case import Case
from tests import sequence_kill


def _sequence_kill(case: Case, folder: Path, kind: str, nth: int, share: float) -> None:
    """Kill the temperature sequence in the ``nth`` step of ``kind``, resume it, print the
    coefficient and its interval against the truth; count figures that differ from what
    the sequence measured (switch-ons: the asked-for one plus each a resume made)."""
    folder.mkdir()
    profile = folder / "p.toml"
    profile.write_text(sequence_kill.PROFILE, encoding="utf-8")
    case.trials += 1
    where = f"{kind} #{nth + 1} at {share:.2f}"
    try:
        out = sequence_kill.killed_and_resumed(profile, folder / "runs", seed=case.trials,
                                               kind=kind, nth=nth, share=share)
    except sequence_kill.KillMissed as exc:  # not the resume's failure: printed, no error
        print(f"  {where:24s} not killed: {exc}"[:200], flush=True)
        return
    except Exception as exc:  # noqa: BLE001 - every failure is counted
        case.bad_errors.append(f"{where}: {type(exc).__name__}: {exc}"[:300])
        return
    f = out.figures
    where += f", landed in {out.kind}"
    points = f["temperature_points"].get("x", [])  # type: ignore[attr-defined]
    low, high = f["temperature_coefficient_deg_h_per_c_ci"] or (None, None)  # type: ignore[misc]
    covered = low is not None and low <= sequence_kill.TEMPCO <= high
    missing = sum(int(s["samples_missing_declared"]) for s in out.summary)  # type: ignore[call-overload]
    # the switch-ons with data: the profile's one (or its redo) and each a resume made that
    # a record followed (one made before the last power_off records nothing)
    journal = out.run.journal
    by_resume = sum(1 for n, e in enumerate(journal)
                    if e.kind == "power_on" and not out.run.asked_for(e)
                    and any(later.kind == "segment" for later in journal[n:]))
    summary_cycles = out.summary[0]["cycles"]
    coefficient = f["temperature_coefficient_deg_h_per_c"]
    print(f"  {where:40s} (step {out.step + 1:2d}): switch-ons {f['cycles']} "
          f"(summary {summary_cycles}, by the resume {by_resume}), points {len(points)} "
          f"of switch-ons {sorted({p['power_cycle'] for p in points})}, coefficient "
          f"{_fmt(coefficient)} deg/h/degC in [{_fmt(low)}, {_fmt(high)}] "
          f"{'covers' if covered else 'MISSES'} the truth {sequence_kill.TEMPCO}, "
          f"declared missing {missing}{_one_line_fit(points)}", flush=True)
    expected_cycles = 1 + by_resume
    if (f["cycles"] != expected_cycles or summary_cycles != f["cycles"] or len(points) != 4
            or not covered or (f["cycles"] == 1) != (f["turn_on_repeatability_deg_h"] is None)):
        case.bad_errors.append(f"{where}: figures differ from what the sequence measured")


def _one_line_fit(points: list[dict[str, object]]) -> str:
    """Where the points come from two switch-ons or more: what one line through them all
    (one bias for every switch-on, as before issue 39) would have said, for contrast."""
    from analysis.errors import AnalysisError
    from analysis.sequences.temperature_sensitivity import (
        TemperaturePoint,
        fit_temperature_sensitivity,
    )

    if len({p["power_cycle"] for p in points}) < 2:
        return ""
    pooled = [TemperaturePoint(float(p["temperature_c"]), float(p["bias_deg_h"]),  # type: ignore[arg-type]
                               float(p["stderr_deg_h"]), "plateau", 1) for p in points]  # type: ignore[arg-type]
    try:
        fit = fit_temperature_sensitivity(pooled, confidence=0.95)
    except AnalysisError:
        return ""
    return (f"; one line through all {fit.slope_deg_h_per_c:.3f} in [{fit.ci_low[1]:.3f}, "
            f"{fit.ci_high[1]:.3f}]")


def _fmt(value: object) -> str:
    return f"{value:.3f}" if isinstance(value, float) else str(value)


def sequence_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    kind, nth, share = sequence_kill.random_kind(rng)
    _sequence_kill(case, tmp / f"seq{case.trials}", kind, nth, share)


def sequence_every_kind_trial(case: Case, tmp: Path, rng: random.Random) -> None:
    """One kill in each step kind of the temperature test (which of its steps and how far
    into it drawn)."""
    for kind in sequence_kill.STEP_KINDS:
        _, nth, share = sequence_kill.random_kind(rng, kind)
        _sequence_kill(case, tmp / f"seq{case.trials}", kind, nth, share)
